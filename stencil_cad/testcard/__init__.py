"""The calibration card: its layout, the sheet it is sprayed on, and the photo fit of the can's constants."""

from .layout import CardLayout, card_description, card_layout, layout_from_description

__all__ = ["CardLayout", "card_description", "card_layout", "layout_from_description"]
