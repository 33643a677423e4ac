"""Studies beyond the paper's figures (non-radial colonies, convergence), one module per study.

A study is written as a figure case (:mod:`cases.figures`): ``compute(scale, out, ...)`` runs or
reuses its engine runs through :mod:`cases.sweep` and reduces them with :mod:`cases.analysis` to
small CSVs, ``plot(data, out)`` draws from those CSVs alone, and the test suite runs it small.
Registered in :data:`cases.cli.CASES`, it runs as ``colony case NAME``.
"""
