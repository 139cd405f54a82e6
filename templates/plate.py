"""Stencil plate template (build123d). Copy this file, edit it, and point the config at the copy.

A template is Python code: stencil-cad runs it with your rights. Use only templates you wrote
or trust, as you would any script; a shared config naming a template shares that code.

    plate:
      template: my_plate.py          # relative to the config file
      template_params:               # optional: values for the constants below
        THICKNESS_MM: 1.6

The UPPER_CASE constants are the template's parameters (units in their names). The
config's plate settings (thickness_mm, label, ...) replace them when the config sets them,
and ``template_params`` sets any of them by name; a name not defined here is an error.

``build`` receives:
    holes       the layer: a DotSet (hole centres ``xy_mm`` (N, 2) and radii ``r_mm`` (N,),
                mm) or a CutLayer (polygon cut-outs), in the picture frame: x right, y up,
                origin at the picture's bottom-left corner;
    outline     the plate's outer boundary, an (M, 2) ndarray ring in mm, counter-clockwise,
                with the asymmetric key tabs that fit the wall;
    label_area  (x0, y0, x1, y1) mm, the free strip in the bottom border for the label;
    label       what the label says (LabelInfo: layer, layers, colour, job), or None;
and returns the plate: the PlateModel of ``perforated_plate`` (exported by the fast STEP
writer and mesher), or that model with an edited solid (``plate.with_part(shape)``), or any
build123d shape. Edited solids go through OCCT's own STEP writer and mesher, which are fine
for a few hundred holes but slow for thousands (minutes).
"""

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
    """Build one stencil plate; see the module docstring for the arguments."""
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
    # Edit here. Extra round through-holes, e.g. a 3 mm hanging hole in the top-right corner
    # of the border, stay in the plate's description and keep the fast writers and checks
    # at any hole count:
    #
    #   x, y = outline[:, 0].max() - 6, outline[:, 1].max() - 5
    #   return plate.with_holes([(x, y)], 1.5)
    #
    # Any other change with build123d (plate.part is a build123d Part, z from 0 to
    # THICKNESS_MM) goes through OCCT's writers, slow above a few hundred holes:
    #
    #   from build123d import Box, Pos
    #   return plate.with_part(plate.part + Pos(x, y, THICKNESS_MM) * Box(4, 4, 1))
    return plate
