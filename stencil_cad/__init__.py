"""stencil_cad: turn an image into spray-paint stencils to 3D-print or laser-cut."""

__version__ = "0.1.0"
