"""The paper's figures and the engines' cross-check, one module per case.

Each case module (:mod:`.fig2`, :mod:`.fig3`, :mod:`.fig4`, :mod:`.crosscheck`) has
``compute(scale, out, ...)`` (runs or reuses the engine runs, :mod:`cases.sweep`, and reduces
them to small CSVs with :mod:`cases.analysis`), ``reduce(folders, data)`` and ``plot(data,
out)`` (draws from those CSVs alone), so ``colony case NAME [--from-data]`` runs it
(:data:`cases.cli.CASES`) and the tests run it small. :mod:`.draw` holds the pictures shared by
the figures, the CLI and the viewer (sphero-cylinders coloured by length, the continuum's
mean-length field, colour bars, file output).
"""
