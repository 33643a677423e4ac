"""Benchmarks: medians of step costs, ratios between solvers, one long run.

Each module runs as a script, ``python -m cases.bench.NAME``, to measure the machine it runs on:
:mod:`.continuum` (cost per step against node count; the target run to radius 150),
:mod:`.particles` (cost per step against particle count and threads).
Their measured tables are in docs/benchmarks.md. The one-off measurements behind
docs/benchmarks.md and docs/validation.md (contact solvers, time step, elements, Psi transport,
hand-off, ...) are scripts in docs/measurements/ of the repository, not part of the package.
"""
