"""The instruction sheet a maker holds in hand: ``instructions.html`` and ``instructions.pdf``.

Built from the job's figures (:class:`stencil_cad.figures.Figures`: the run's, or a
``manifest.json`` read back), its settings (:class:`.settings.JobSettings`) and its preview
images (:mod:`.content`). The HTML
(:mod:`.html`) is one self-contained file that opens offline; the PDF (:mod:`.pdf`) is
drawn with ReportLab. :mod:`.make` says how to print or cut each part, :mod:`.mural` how to
lay out and spray a mural's tiles.
"""

from .content import Sheet, sheet, sheet_from_manifest
from .html import render_html
from .pdf import render_pdf
from .settings import JobSettings

__all__ = ["JobSettings", "Sheet", "render_html", "render_pdf", "sheet", "sheet_from_manifest"]
