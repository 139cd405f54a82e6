"""The printers a bed preset names: their motion limits and the speeds their maker's own profile prints at.

A job that names its printer's bed (``--bed prusa_mk4``) is sliced, and its making cost estimated,
for that printer rather than for the shipped profile's generic machine (``templates/prusa_fdm.ini``:
a Marlin 2 printer of the Prusa MK3S class, which PrusaSlicer times at its default 1,500 mm/s²).
A bed preset without an entry here keeps the generic machine.

**Original Prusa MK4** (input shaper firmware, 0.4 mm nozzle; the MK4's input shaper came with
firmware 5.0, per Prusa's knowledge base article "Input Shaper"). The figures are those of Prusa
Research's own PrusaSlicer profiles for the printer (the vendor bundle ``PrusaResearch.ini``,
printer "Original Prusa MK4 Input Shaper 0.4 nozzle", print "0.20mm SPEED @MK4IS 0.4", and its PLA
for the MK4's standard nozzle):

* machine limits (normal mode): accelerations X/Y 4,000 mm/s², extruding 4,000, travel 4,000,
  retracting 1,200, Z 200, E 2,500; feed rates X/Y 300 mm/s, Z 40, E 100; jerk X/Y 8 mm/s, Z 2, E 10;
* accelerations of the print: 4,000 mm/s² for perimeters and infill, 500 for the first layer, 1,500
  for bridges;
* speeds: perimeters (external and small ones too) 170 mm/s, infill and solid infill 200, top solid infill 100,
  gap fill 120, first layer 40, travel 300;
* PLA's volumetric cap on that nozzle: 15 mm³/s.

PrusaSlicer 2.5 (the slicer this project is measured with) has one infill acceleration where 2.6
splits it into solid (4,000) and top solid infill (1,500, for the look of a visible top face):
:data:`PRINTERS` keeps the solid infill's 4,000 for both; a stencil's top face is never looked at.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["PRINTERS", "Printer", "printer_for_bed"]


@dataclass(frozen=True)
class Printer:
    """One printer's motion limits and its maker's print speeds, as PrusaSlicer settings.

    Attributes:
        name: The printer in words, for the manifest and the sheet.
        limits: PrusaSlicer's ``machine_*`` settings (accelerations mm/s², feed rates and jerk mm/s).
        accelerations: The print's accelerations per feature, mm/s² (PrusaSlicer 2.5 keys).
        speeds: The print's speeds per feature, mm/s.
        max_flow_mm3_s: The filament's volumetric cap on this printer's nozzle, mm³/s.
    """

    name: str
    limits: dict[str, float] = field(default_factory=dict)
    accelerations: dict[str, float] = field(default_factory=dict)
    speeds: dict[str, float] = field(default_factory=dict)
    max_flow_mm3_s: float = 11.0

    @property
    def speed(self) -> dict[str, float]:
        """The speeds by feature without the ``_speed`` suffix (``first_layer``, ``solid_infill``, ...), mm/s."""
        return {k.removesuffix("_speed"): v for k, v in self.speeds.items()}


#: Printers by bed preset name (:data:`stencil_cad.config.bed.BED_PRESETS`); see the module's text.
PRINTERS: dict[str, Printer] = {
    "prusa_mk4": Printer(
        name="Original Prusa MK4 (input shaper)",
        limits={
            "machine_max_acceleration_x": 4000,
            "machine_max_acceleration_y": 4000,
            "machine_max_acceleration_z": 200,
            "machine_max_acceleration_e": 2500,
            "machine_max_acceleration_extruding": 4000,
            "machine_max_acceleration_retracting": 1200,
            "machine_max_acceleration_travel": 4000,
            "machine_max_feedrate_x": 300,
            "machine_max_feedrate_y": 300,
            "machine_max_feedrate_z": 40,
            "machine_max_feedrate_e": 100,
            "machine_max_jerk_x": 8,
            "machine_max_jerk_y": 8,
            "machine_max_jerk_z": 2,
            "machine_max_jerk_e": 10,
        },
        accelerations={
            "default_acceleration": 4000,
            "perimeter_acceleration": 4000,
            "infill_acceleration": 4000,
            "bridge_acceleration": 1500,
            "first_layer_acceleration": 500,
        },
        speeds={
            "perimeter_speed": 170,
            "external_perimeter_speed": 170,
            "small_perimeter_speed": 170,
            "infill_speed": 200,
            "solid_infill_speed": 200,
            "top_solid_infill_speed": 100,
            "gap_fill_speed": 120,
            "first_layer_speed": 40,
            "travel_speed": 300,
        },
        max_flow_mm3_s=15.0,
    ),
}


def printer_for_bed(bed: object) -> Printer | None:
    """The printer a bed preset names (``"prusa_mk4"``), or None for a custom size or a preset without one."""
    return PRINTERS.get(bed) if isinstance(bed, str) else None
