"""The instruction sheet a maker holds in hand: ``instructions.html`` and ``instructions.pdf``.

Built from the job's manifest (the same figures ``manifest.json`` holds) and the job's preview
images (:mod:`.content`), so whatever a stage adds to the manifest (scores, spray units,
tiles) reaches the sheet without this package knowing the stage. The HTML
(:mod:`.html`) is one self-contained file that opens offline; the PDF (:mod:`.pdf`) is
drawn with ReportLab. :mod:`.make` says how to print or cut each part, :mod:`.mural` how to
lay out and spray a mural's tiles.
"""

from .content import Sheet, sheet_from_manifest
from .html import render_html
from .pdf import render_pdf

__all__ = ["Sheet", "render_html", "render_pdf", "sheet_from_manifest"]
