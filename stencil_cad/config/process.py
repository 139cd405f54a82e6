"""The processes that make plates, in one table: a new process is one member and one record here.

Each :class:`ProcessRecord` holds what the rest of the config fills in for ``stipple.process``
(the hole floor, web, edge margin and hole offset of ``stipple``, the wall's stand-off, the paper
model's nozzle height, the laser kerf), the sheet the sag rule fills the plate's thickness from
(:mod:`.thickness`), and how its plates are made (:class:`Method`), which the cost model, the
mural's posts and stand and the instruction sheet ask instead of naming a process.

Where each value comes from:

* ``fdm`` — measured from PrusaSlicer's own G-code with the shipped ``prusa_fdm`` profile
  (0.4 mm nozzle), not from service guides (which advise holes of 2 mm diameter and 0.8 mm walls
  for parts that must be dimensionally exact): ``python -m benchmarks printed --case radius
  --case web`` rasterises an inner layer's extrusions at their widths. Holes of r = 0.5-1.5 mm
  drawn larger by the process's hole offset (0.015 mm) open within 5 % of their designed area at
  a 0.6 mm web; a 0.6 mm web prints whole at every radius (at least 0.55 mm of plastic on each), a
  0.5 mm web breaks between r = 0.5 mm holes (5 of 15 webs under half laid) and a 0.4 mm web
  between r = 0.5 and 0.75 mm holes (all of them). Hole floor r = 0.5 mm, web 0.6 mm; 0.7 mm on a
  plate of one layer (``one_layer_web_mm``; a soft FDM mural's plates are one 0.3 mm layer). Such a
  plate is all first layer, which the shipped profile lays in 0.8 mm lines under its elephant-foot
  compensation: there PrusaSlicer lays nothing across a 0.6 or 0.65 mm web between r = 0.5 mm holes
  (every web of the test plate; the holes print as slots), while a 0.7 mm web prints whole at every
  radius (at least 0.62 mm of plastic). From layer 2 up, in 0.45 mm hole loops, 0.6 mm holds
  (python -m benchmarks printed --case web: the ``*_first_layer`` keys against the others).
* ``sla`` — resin printers resolve features down to about 0.5 mm (Hycube "3D design guidelines":
  SLA minimum feature 0.5 mm). Hole floor r = 0.5 mm, web 0.5 mm; hole offset 0.02 mm (resin
  over-cure, a prior not measured).
* ``laser`` — laser kerf is about 0.1–0.3 mm (Ponoko and Snijlab: about 0.2 mm; Cut Laser Cut:
  0.08–0.45 mm) and cut lines closer than about 0.5 mm can burn away entirely (Cut Laser Cut,
  "What is laser kerf"). Hole floor r = 0.5 mm, web 0.6 mm (raise it for thick or soft sheet: the
  same source advises webs no thinner than the sheet); hole offset 0, because the DXF/SVG writers
  compensate ``export.dxf_kerf_mm`` (0.2 mm).

Every edge margin is 0: the plate's solid border (``plate.outline.margin_mm``, at least 3 mm) holds
the holes at the picture's edge, as it holds the hard stencils' cut-outs, which reach it. A margin
leaves a band along the edge unsprayed: python -m benchmarks quality's rocket-sla scored S-CIELAB
2.34 at 1 m with the 2 mm margin of before, 1.80 without it (its 2 mm edge band held a quarter of
the error). The floor does not grow with the viewing distance: on the 600 x 400 mm coffee mural
seen from 3 m (FDM, 3 layers), a 1 mm floor halved the holes (39,271 against 84,772) but cut the
plan's printer-hours by only 5 % and S-CIELAB at 3 m rose from 1.71 to 3.61 (sparse large holes
show in the light tones); ``variable_radius`` (r 0.5 to 1.0 mm) there: 43,846 holes, -7 % of the
plan's hours, S-CIELAB 4.82.

Every stand-off is 10 mm (soft stencils of every process score best from it at 1 m under the
physical spray model; ``wall.standoff_mm``'s description gives the figures) and every nozzle
height 30 (``spray.nozzle_height``'s description gives the figures; laser holes are the size of
SLA ones and take its value).

The sheets: FDM in PLA (E 3.5 GPa), one 0.3 mm layer (:data:`FDM_SINGLE_LAYER_MM`), two 0.2 mm
layers (:data:`FDM_THIN_PLATE_MM`: a bottom and a top solid layer; the 0.2 mm engraving leaves the
bottom one under the label; flat up to a 128 mm side, so a small plate or a plate carried by posts,
:mod:`stencil_cad.mural.posts`), then whole 0.3 mm layers of the shipped prusa_fdm profile from
two; SLA in a standard resin (E about 2 GPa after post-cure), whole 0.1 mm layers of prusa_sla from
0.8 mm (the label's 0.7 mm; resin sheets thinner than that curl in the post-cure, a prior not
measured here); a laser cuts stock sheet, PETG/PET 1 mm or acrylic and plywood 1.5-6 mm (E about
3 GPa). Thinner film (mylar 0.25-0.5 mm) cuts well but cannot hold an engraved label: give it as
plate.thickness_mm with plate.label none.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class Process(str, enum.Enum):
    """Manufacturing process of the stencil plates."""

    fdm = "fdm"
    sla = "sla"
    laser = "laser"

    @property
    def record(self) -> ProcessRecord:
        """What the tool knows of this process (:data:`PROCESSES`)."""
        return PROCESSES[self]


class Method(str, enum.Enum):
    """How a process makes a plate."""

    #: Printed in layers of extruded plastic (sliced; its print time and filament are modelled).
    extrude = "extrude"
    #: Cured from resin in a vat, layer by layer.
    cure = "cure"
    #: Cut from stock sheet (DXF/SVG; a mural stands in a cut frame, not a printed wall).
    cut = "cut"


#: The thinnest FDM plate that carries an engraved label, mm, and the layer height it prints at: two
#: 0.2 mm layers (the profile's other plates are whole 0.3 mm layers; see :mod:`.thickness`).
FDM_THIN_PLATE_MM = 0.4
FDM_THIN_LAYER_MM = 0.2
#: The thinnest FDM plate of all, mm: one layer of the shipped profile's 0.3 mm, for a plate whose
#: label needs no floor (``plate.label`` emboss or none) carried densely enough (a mural's posts,
#: :data:`stencil_cad.mural.posts.SINGLE_LAYER_POST_PITCH_MM`).
FDM_SINGLE_LAYER_MM = 0.3


@dataclass(frozen=True)
class Sheet:
    """The sheets a process makes a plate from.

    Attributes:
        material: In words, for the reason line.
        modulus_gpa: Young's modulus E in GPa.
        density_kg_m3: Density in kg/m³.
        poisson: Poisson's ratio.
        thicknesses_mm: The thicknesses it makes, thinnest first.
        made_as: How the thicknesses come about, for the reason line.
    """

    material: str
    modulus_gpa: float
    density_kg_m3: float
    poisson: float
    thicknesses_mm: tuple[float, ...]
    made_as: str


@dataclass(frozen=True)
class ProcessRecord:
    """One process: the values a job fills in for it, its sheet and how it makes plates.

    Attributes:
        method: How it makes a plate.
        hole_min_r_mm: The hole floor (``stipple.hole_min_r_mm`` left null), mm.
        web_mm: The web between holes (``stipple.web_mm`` left null), mm.
        edge_margin_mm: The margin to the picture's edge and keep-outs (``stipple.edge_margin_mm``), mm.
        hole_offset_mm: How much narrower (radius) it makes a hole than drawn (``stipple.hole_offset_mm``), mm.
        one_layer_web_mm: The web a plate of one layer needs where wider than ``web_mm``, or None.
        standoff_mm: The wall's stand-off of its soft stencils (``wall.standoff_mm`` left null), mm.
        nozzle_height: The paper model's nozzle height (``spray.nozzle_height`` left null).
        dxf_kerf_mm: The kerf the DXF and SVG are offset for (``export.dxf_kerf_mm`` left null), mm.
        sheet: The sheet the plate's thickness is filled in from (:mod:`.thickness`).
        note: Said after its hole floor and web in ``stipple.process``'s choices.
    """

    method: Method
    hole_min_r_mm: float
    web_mm: float
    edge_margin_mm: float
    hole_offset_mm: float
    one_layer_web_mm: float | None
    standoff_mm: float
    nozzle_height: float
    dxf_kerf_mm: float
    sheet: Sheet
    note: str = ""

    def choice(self, name: str) -> str:
        """How ``stipple.process``'s description names this process among its choices."""
        return f"{name} (r >= {self.hole_min_r_mm:g} mm, web {self.web_mm:g} mm{self.note})"


def _layers(height_mm: float, first: int, last: int) -> tuple[float, ...]:
    return tuple(round(n * height_mm, 3) for n in range(first, last + 1))


#: Every process, by its ``stipple.process`` value (see the module's text for the figures).
PROCESSES: dict[Process, ProcessRecord] = {
    Process.fdm: ProcessRecord(
        method=Method.extrude,
        hole_min_r_mm=0.5,
        web_mm=0.6,
        edge_margin_mm=0.0,
        hole_offset_mm=0.015,
        one_layer_web_mm=0.7,
        standoff_mm=10.0,
        nozzle_height=30.0,
        dxf_kerf_mm=0.0,
        sheet=Sheet(
            "PLA",
            3.5,
            1240.0,
            0.36,
            (FDM_SINGLE_LAYER_MM, FDM_THIN_PLATE_MM, *_layers(0.3, 2, 20)),
            "one 0.3 mm layer, two 0.2 mm layers or whole 0.3 mm layers",
        ),
        note=": the thinnest the shipped profile prints whole; 0.7 mm on a plate of one layer, such as a soft mural's",
    ),
    Process.sla: ProcessRecord(
        method=Method.cure,
        hole_min_r_mm=0.5,
        web_mm=0.5,
        edge_margin_mm=0.0,
        hole_offset_mm=0.02,
        one_layer_web_mm=None,
        standoff_mm=10.0,
        nozzle_height=30.0,
        dxf_kerf_mm=0.0,
        sheet=Sheet("resin", 2.0, 1150.0, 0.35, _layers(0.1, 8, 60), "whole 0.1 mm layers"),
    ),
    Process.laser: ProcessRecord(
        method=Method.cut,
        hole_min_r_mm=0.5,
        web_mm=0.6,
        edge_margin_mm=0.0,
        hole_offset_mm=0.0,
        one_layer_web_mm=None,
        standoff_mm=10.0,
        nozzle_height=30.0,
        dxf_kerf_mm=0.2,
        sheet=Sheet(
            "PETG, acrylic or plywood", 3.0, 1300.0, 0.37, (1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0), "stock sheet"
        ),
    ),
}
