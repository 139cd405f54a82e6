"""Config section `paints`: the maker's can catalogue and the paint estimate."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field

from .base import StrictModel


class PaintsConfig(StrictModel):
    """The cans a maker can buy, and how far one can goes."""

    catalogue: Path | None = Field(
        None,
        description=(
            "A CSV of cans (columns name, code, hex) that an 'auto' palette is snapped to: each solved "
            "paint (and an 'auto' primer) becomes its nearest can by CIEDE2000, the opacities are solved "
            "again for those cans, and the cost of snapping is reported. null: no snapping. A relative "
            "path is taken from the config file's folder. Example: stencil_cad/data/example_cans.csv."
        ),
    )
    can_names: bool = Field(
        True,
        description=(
            "Name every paint (and the primer) that no can list names after its nearest colour in the "
            "shipped list of common colour names (stencil_cad/data/colour_names.csv), shown as "
            "'~Orange (ΔE 4.2)' on the sheet, the swatch card and spray.json; the colour itself is not "
            "changed. false: leave such paints unnamed. Defaults to true."
        ),
    )
    coverage_m2_per_can: float = Field(
        1.5,
        gt=0.0,
        le=100.0,
        description=(
            "Area in m² one can covers with one opaque coat, for the paint estimate on the instruction "
            "sheet. Range (0, 100]. Defaults to 1.5 m² (a 400 ml can covers about 1-2 m²)."
        ),
    )
    can_ml: float = Field(
        400.0,
        gt=0.0,
        le=10000.0,
        description="Contents of one can in ml, for the paint estimate. Range (0, 10000]. Defaults to 400 ml.",
    )
