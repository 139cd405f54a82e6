"""Command line (being written)."""


def main(argv=None) -> int:
    """Entry point."""
    return 0
