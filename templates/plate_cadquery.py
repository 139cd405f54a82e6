"""Stencil plate template (CadQuery). Needs the ``cadquery`` extra: ``pip install stencil_cad[cadquery]``.

A template is Python code: stencil-cad runs it with your rights (see ``templates/plate.py``).

The same parameters and ``build`` as ``templates/plate.py`` (see its docstring), with the
solid handed to CadQuery: the plate's OCCT shape (``plate.shape``) goes in as it is, since
CadQuery 2.8 runs on OCP 7.9 as stencil-cad does (``plate.part`` would import build123d only to
wrap the same shape). Point the config at this file (or a copy) with ``plate.template``.
"""

import cadquery as cq

from stencil_cad.cad.plate import perforated_plate

#: Plate thickness in mm. Range [0.3, 20]. A job replaces it with plate.thickness_mm (given, or
#: filled in for its process and plate size).
THICKNESS_MM = 0.9
#: Label on the top face: "engrave", "emboss" or "none".
LABEL = "engrave"
#: Depth of an engraved label / height of an embossed one, in mm.
LABEL_DEPTH_MM = 0.2
#: Font size of the label in mm; shrinks to fit the label area.
LABEL_HEIGHT_MM = 4.0
#: Smallest font size in mm the label may shrink to.
LABEL_MIN_HEIGHT_MM = 2.0
#: Font family of the label.
LABEL_FONT = "DejaVu Sans"
#: Chord error of the letters' polygons in mm.
LABEL_TOLERANCE_MM = 0.01


def build(holes, outline, label_area, label):
    """Build one stencil plate as a CadQuery solid; see ``templates/plate.py``."""
    plate = perforated_plate(
        holes,
        outline,
        label_area,
        label,
        thickness_mm=THICKNESS_MM,
        label_mode=LABEL,
        label_depth_mm=LABEL_DEPTH_MM,
        label_height_mm=LABEL_HEIGHT_MM,
        label_min_height_mm=LABEL_MIN_HEIGHT_MM,
        label_font=LABEL_FONT,
        label_tolerance_mm=LABEL_TOLERANCE_MM,
    )
    solid = cq.Workplane("XY").add(cq.Solid(plate.shape))
    # Edit here with CadQuery. A round hole (a 3 mm hanging hole)
    # (top-right corner) is best added to the description, which keeps the fast writers at any
    # hole count:
    #
    #   x, y = outline[:, 0].max() - 6, outline[:, 1].max() - 5
    #   return plate.with_holes([(x, y)], 1.5)
    #
    # Other changes edit the solid, e.g.
    #
    #   solid = solid.cut(cq.Workplane("XY").center(x, y).rect(4, 2).extrude(THICKNESS_MM))
    #
    # An unchanged solid keeps the fast STEP writer and mesher; an edited one is exported
    # through OCCT.
    return plate.with_part(solid)
