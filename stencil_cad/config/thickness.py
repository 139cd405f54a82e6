"""The plate thickness a process fills in for ``plate.thickness_mm: null``: the thinnest it makes that stays flat.

A plate rests on the wall's ledge all round and sags under its own weight; the sag lowers its
middle towards the sprayed surface, and under the physical spray model every hole's blur follows
its stand-off (sigma = k * g). The fill-in takes the thinnest sheet the process makes (whole
layers of the shipped profile, or a stock sheet for a laser) whose sag stays within
:data:`SAG_LIMIT_FRACTION` of the process's stand-off, and never thinner than an engraved label
needs (``label_depth_mm`` + :data:`LABEL_FLOOR_MM`).

The model (Timoshenko & Woinowsky-Krieger, *Theory of Plates and Shells*, table 8: a simply
supported square plate of side a under a uniform load q): ``w = 0.00406 * q * a**4 / D`` with
``q = rho * g * t`` (its own weight) and ``D = E * t**3 / (12 * (1 - nu**2))``, so the sag grows
with a**4 / t**2. The longest side is taken as the square's side, which over-states a long
narrow plate's sag (its short side governs it): the fill-in errs thick. Holes make the plate
lighter by its open fraction phi and softer by about its ligament efficiency eta =
(pitch - hole diameter) / pitch (the effective-modulus results for perforated plates, O'Donnell &
Langer 1962, ASME Section VIII appendix): sag times (1 - phi) / eta. At the densest the stippler
packs (hexagonal at the process's web: r 1.0-2.0 mm at a 0.8 mm web gives phi 0.46-0.63, eta
0.29-0.17) that is 1.9-2.2 over the whole plate; real plates are dense only in their dark patches
and keep a solid border, so :data:`PERFORATION_FACTOR` 2 errs thick too.

The sag limit, 5 % of the stand-off (0.5 mm under every process's 10 mm), keeps the blur in a plate's middle within 5 % of the one designed; the blur moves
S-CIELAB slowly (the FDM astronaut scores 10.8 / 9.1 at 1 m from 10 / 15 mm stand-offs, 16 % for
a 50 % change of blur), so a 5 % change is far below what a viewer sees.

A mural's plates also stand on posts (:mod:`stencil_cad.mural.posts`): the fill-in then takes the
panel between four posts (:func:`column_side_mm`: point supports at its corners, Timoshenko's
0.00581 against the edge-supported 0.00406) instead of the whole plate, and an FDM plate comes out
0.4 mm: two 0.2 mm layers (:data:`~stencil_cad.config.process.FDM_THIN_PLATE_MM`).

The thinnest FDM plate is two 0.2 mm layers, not two of the profile's 0.3 mm: a plate's filament
is its plastic, and a two-layer plate's print time is its two layers' lines whatever their height
(the first at the first-layer speed; the second under the volumetric cap, faster when thinner).
Measured with PrusaSlicer 2.5 and the shipped profile on a plate of the 600 x 400 mm coffee mural
(4,632 holes): 0.6 mm (two 0.3 mm layers) 1 h 32 min and 30.9 g, 0.4 mm (two 0.2 mm layers, the
slicer told by :func:`stencil_cad.slicing.part_settings`) 1 h 29 min and 20.8 g (-3 % time, -33 %
filament). It carries an engraved label one layer deep: the default ``label_depth_mm`` 0.2 over
:data:`LABEL_FLOOR_MM` 0.2 (on 0.3 mm layers the slicer still cuts the engraving from the whole
top layer: it slices at mid-layer).

Thinner still, an FDM plate is one 0.3 mm layer of the shipped profile (:data:`~stencil_cad.config.process.FDM_SINGLE_LAYER_MM`),
when nothing is engraved into it (``plate.label`` emboss or none: an engraving needs a layer under
it) and it stays flat: up to a 111 mm side, so a mural's plate on posts every 78 mm
(:data:`stencil_cad.mural.posts.SINGLE_LAYER_POST_PITCH_MM`). One layer instead of two is a quarter
less plastic and no second pass over the sheet and its hole loops: the print is its first layer.

Sag in mm from this model (solid plate; times 2 for the perforation), PLA E 3.5 GPa, 1240 kg/m3:

==========  =======  =======  =======  =======  =======
side (mm)     150      200      250      300      360
==========  =======  =======  =======  =======  =======
0.9 mm        0.09     0.29     0.71     1.47     3.05
1.2 mm        0.05     0.16     0.40     0.83     1.72
1.5 mm        0.03     0.10     0.26     0.53     1.10
1.8 mm        0.02     0.07     0.18     0.37     0.76
2.1 mm        0.02     0.05     0.13     0.27     0.56
==========  =======  =======  =======  =======  =======

So with the perforation and the 0.5 mm limit an FDM plate is 0.4 mm (two 0.2 mm layers) up to a
128 mm side, 0.6 mm (two 0.3 mm layers) up to a 157 mm side,
0.9 mm up to a 192 mm side (the
bundled example's 173 mm plates, a Prusa MINI's bed), 1.2 mm to 222 mm, 1.5 mm to 248 mm (a Prusa
MK4's bed), 1.8 mm to 272 mm, 2.1 mm to 294 mm, 2.4 mm to 314 mm, and 3.3 mm on a 360 mm bed
(Prusa XL). (Under the 15 mm FDM stand-off of before, with its 0.75 mm limit, each step came about
30 mm later: 1.2 mm to 246 mm.)
Measured on the bundled example with the shipped FDM profile (PrusaSlicer 2.5, `stencil-cad
slice`): a 154 x 183 mm plate of about 590 holes printed in 1 h 40 / 12.6 m of filament at
1.2 mm and 1 h 18 / 9.5 m at 0.9 mm (-22 % time, -25 % filament) with S-CIELAB at 1 m unchanged
(7.94 vs 7.92). The default `--image` job (FDM, 173 mm plates; `stencil-cad run --image
stencil_cad/data/example.png`, then `stencil-cad slice layer_0*.stl wall.stl --bed prusa_mk4`): 0.9 mm
plates print in 1 h 27 / 1 h 22 / 1 h 14 / 1 h 17 with 41.3 m of filament, 1.2 mm ones in 1 h 53 /
1 h 45 / 1 h 33 / 1 h 38 with 55.0 m (-22 % time, -25 % filament), the wall 1 h 54 against 1 h 55;
S-CIELAB at 1 m 9.09 against 9.06, at 2 m 7.43 against 7.42. Each layer the sag lets go saves about
a fifth of a plate's print.
"""

from __future__ import annotations

from dataclasses import dataclass

from .process import Process, Sheet

#: Sag coefficient of a simply supported square plate under a uniform load (Timoshenko, table 8).
SQUARE_SAG_COEFFICIENT = 0.00406
#: Sag coefficient of a square panel of a plate carried by equidistant point supports (columns) at
#: its corners, under a uniform load (Timoshenko, ch. 10, the panel's middle): a plate on posts.
COLUMN_SAG_COEFFICIENT = 0.00581
#: How much a stippled plate sags more than a solid one: (1 - open fraction) / ligament efficiency.
PERFORATION_FACTOR = 2.0
#: Largest sag as a fraction of the process's stand-off (see the module's text).
SAG_LIMIT_FRACTION = 0.05
#: An engraved label leaves this much plate under it (``plate.label_depth_mm`` is at most the thickness
#: less this): one 0.2 mm layer of the thinnest FDM plate.
LABEL_FLOOR_MM = 0.2
_G = 9.81


def sag_mm(side_mm: float, thickness_mm: float, sheet: Sheet, perforated: bool = True) -> float:
    """Sag in mm of a square plate of ``side_mm`` resting on its edges, under its own weight.

    Args:
        side_mm: The plate's side in mm (its longest side stands in for a rectangle's).
        thickness_mm: Its thickness in mm.
        sheet: Its material.
        perforated: Times :data:`PERFORATION_FACTOR` for the holes.
    """
    a, t = side_mm / 1000.0, thickness_mm / 1000.0
    q = sheet.density_kg_m3 * _G * t
    rigidity = sheet.modulus_gpa * 1e9 * t**3 / (12.0 * (1.0 - sheet.poisson**2))
    w = SQUARE_SAG_COEFFICIENT * q * a**4 / rigidity * 1000.0
    return w * (PERFORATION_FACTOR if perforated else 1.0)


@dataclass(frozen=True)
class Thickness:
    """A filled-in plate thickness and why.

    Attributes:
        thickness_mm: The plate's thickness in mm.
        side_mm: The plate side it was chosen for, in mm (0 when the config gives the thickness).
        sag_mm: The model's sag of a perforated plate at that side, in mm.
        reason: One line for the summary and the instruction sheet.
    """

    thickness_mm: float
    side_mm: float
    sag_mm: float
    reason: str

    @property
    def filled(self) -> bool:
        """Whether the process filled it in (False: ``plate.thickness_mm`` gave it)."""
        return self.side_mm > 0.0


def fill_thickness(
    process: Process, side_mm: float, standoff_mm: float, at_least_mm: float = 0.0
) -> Thickness:
    """The thinnest plate ``process`` makes whose sag at ``side_mm`` stays within the limit.

    Args:
        process: The plate's process.
        side_mm: The plate's longest side in mm.
        standoff_mm: The process's stand-off in mm; the sag limit is :data:`SAG_LIMIT_FRACTION` of it.
        at_least_mm: The thinnest plate the label allows (``label_depth_mm`` + :data:`LABEL_FLOOR_MM`
            for an engraving).

    Returns:
        The thickness, or the process's thickest when none stays within the limit (said in the reason).
    """
    sheet = process.record.sheet
    limit = SAG_LIMIT_FRACTION * standoff_mm
    flat = [t for t in sheet.thicknesses_mm if sag_mm(side_mm, t, sheet) <= limit]
    labelled = [t for t in sheet.thicknesses_mm if t >= at_least_mm - 1e-9] or [sheet.thicknesses_mm[-1]]
    by_sag = flat[0] if flat else sheet.thicknesses_mm[-1]
    t = max(by_sag, labelled[0])
    sag = sag_mm(side_mm, by_sag, sheet)
    if not flat:
        why = (
            f"the thickest {process.value} plate; it still sags about {sag:.1f} mm, more than {limit:.2f} mm"
        )
    else:
        why = (
            f"the thinnest {process.value} plate ({sheet.made_as}, {sheet.material}) whose {side_mm:.0f} mm side "
            f"sags ≤ {limit:.2f} mm under its own weight (about {sag:.2f} mm)"
        )
    if t > by_sag:
        why = f"{by_sag:g} mm is {why}, raised for the engraved label (label_depth_mm + {LABEL_FLOOR_MM:g})"
        sag = sag_mm(side_mm, t, sheet)
    return Thickness(t, float(side_mm), float(sag), f"{t:g} mm: {why}")


def column_side_mm(span_mm: float) -> float:
    """The simply supported square's side that sags as much as a plate panel of ``span_mm`` between posts.

    A panel carried at its four corners (:data:`COLUMN_SAG_COEFFICIENT`) sags more than one resting
    on its four edges (:data:`SQUARE_SAG_COEFFICIENT`); the sag goes as the side to the fourth power.
    """
    return float(span_mm) * (COLUMN_SAG_COEFFICIENT / SQUARE_SAG_COEFFICIENT) ** 0.25


def given_thickness(thickness_mm: float) -> Thickness:
    """An explicit ``plate.thickness_mm``, kept as given."""
    return Thickness(float(thickness_mm), 0.0, 0.0, f"{thickness_mm:g} mm, as plate.thickness_mm gives")
