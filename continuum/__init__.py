"""continuum package (see docs/DESIGN.md)."""
