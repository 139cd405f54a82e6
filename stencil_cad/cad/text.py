"""A line of text as OCCT faces, through OCCT's own font classes: the label's letters without build123d.

:func:`text_faces` registers the font file with OCCT's font manager as its family's bold face,
has ``StdPrs_BRepTextBuilder`` lay the line out as planar faces (``StdPrs_BRepFont``) centred on
the origin, and moves the faces so the low corner of their exact bounding box is at the origin.
``tests/cad/test_label_order.py`` holds the label rings sampled from them to those of build123d's
``Text`` in the same font and placement, to the bit (the plates' files are made from them), and to
one order of the letters in every process and thread. With the wall made through OCP too
(:mod:`.occt`), a job imports no build123d (nor the scikit-learn and IPython under it):
``stencil-cad build`` on the example's saved stage took 11.6 CPU-s, 10.4 so (user + system,
``/usr/bin/time``, medians of five and four runs alternated with the other code). Only the
bundled font goes this way; another font family keeps build123d's route, which also knows its
single-stroke fonts and its font aliases.
"""

from __future__ import annotations

import os
import sys
import threading

from . import occt

__all__ = ["FONT_LOCK", "text_faces"]

#: OCCT's font manager is one per process and not thread-safe (its font map, FreeType's library):
#: a worker with several threads lays out one label at a time.
FONT_LOCK = threading.Lock()
_manager = None


def _font_manager():
    """OCCT's font manager, made once per process, after fontconfig is pointed at the system's files on Linux.

    Called with :data:`FONT_LOCK` held.
    """
    global _manager
    from OCP.Font import Font_FontMgr

    if _manager is None:
        if sys.platform.startswith("linux"):
            # The manager reads the system's fonts when first made. build123d, which sets a label
            # in any other font, sets these (whatever the user set) before it first asks for the
            # manager; set alike here, the manager knows the same fonts whichever asks first.
            # Only then: the manager reads them once, and setting the environment while other
            # threads read it is unsafe.
            os.environ["FONTCONFIG_FILE"] = "/etc/fonts/fonts.conf"
            os.environ["FONTCONFIG_PATH"] = "/etc/fonts/"
        _manager = Font_FontMgr.GetInstance_s()
    return _manager


def _bold_font(family: str, path: str):
    """The font file ``path`` registered as the bold aspect of ``family`` (replacing the system's), and its font."""
    from OCP.Font import Font_FA_Bold, Font_SystemFont
    from OCP.TCollection import TCollection_AsciiString

    manager = _font_manager()
    font = Font_SystemFont(TCollection_AsciiString(family))
    font.SetFontPath(Font_FA_Bold, TCollection_AsciiString(path), 0)
    font.SetSingleStrokeFont(False)
    manager.RegisterFont(font, True)
    return manager.FindFont(TCollection_AsciiString(family), Font_FA_Bold)


def text_faces(text: str, size: float, family: str, path: str) -> list:
    """The faces of ``text`` set in the bold face of the font file ``path``, its ink's low corner at the origin.

    Args:
        text: One line of text.
        size: Font size in mm.
        family: The font's family name, as the file names it (``"DejaVu Sans"``).
        path: The font file (a bold face).

    Returns:
        ``TopoDS_Face`` per glyph part, in the order OCCT's explorer gives them.
    """
    from OCP.BRepTools import BRepTools
    from OCP.Font import Font_FA_Bold
    from OCP.gp import gp_Ax3, gp_Trsf, gp_Vec
    from OCP.Graphic3d import Graphic3d_HTA_CENTER, Graphic3d_VTA_CENTER
    from OCP.NCollection import NCollection_Utf8String
    from OCP.StdPrs import StdPrs_BRepFont, StdPrs_BRepTextBuilder
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    with FONT_LOCK:
        system_font = _bold_font(family, path)
        font = StdPrs_BRepFont(
            NCollection_Utf8String(system_font.FontName().ToCString()), Font_FA_Bold, float(size)
        )
        laid = TopoDS.Compound_s(
            StdPrs_BRepTextBuilder().Perform(
                font, NCollection_Utf8String(text), gp_Ax3(), Graphic3d_HTA_CENTER, Graphic3d_VTA_CENTER
            )
        )
    BRepTools.Clean_s(laid)
    x0, y0 = occt.bounding_box(laid)[:2]
    shift = gp_Trsf()
    shift.SetTranslation(gp_Vec(-x0, -y0, 0.0))
    placed = laid.Moved(TopLoc_Location(shift))
    faces = []
    exp = TopExp_Explorer(placed, TopAbs_FACE)
    while exp.More():
        faces.append(TopoDS.Face_s(exp.Current()))
        exp.Next()
    return faces
