"""cases package (see docs/DESIGN.md)."""
