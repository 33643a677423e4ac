"""Tests of the cases layer: CLI, faults, analysis, figures, sweeps, viewer, benchmarks."""
