"""particles package (see docs/DESIGN.md)."""
