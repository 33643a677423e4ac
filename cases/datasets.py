"""The cases' data sets on disk: which lam a file is of, the seed ensemble's data, merging.

A case's data set is a folder of small CSVs (a case's ``OUT/data``, the committed
``cases/data/NAME``). This module holds what the figures (:mod:`cases.figures`), the seed
ensemble (:mod:`cases.studies.ensemble`) and the merge command (:mod:`cases.figures.merge`)
share about them, so that none of them imports another for it:

- :func:`lam_of`: the lam a case's file belongs to (``..._lam=L.csv``);
- :func:`ensemble_data`: the seed ensemble's data beside a figure's (the seed bands of Fig 3
  and Fig 4);
- :func:`merge`: the ensemble's data with the lam of a partial reduction (``colony case
  ensemble --lams L,...``) added or replaced, whole rows (:func:`merge_rows`) of its tables
  (:data:`LAM_TABLES`) and whole per-lam files; run as ``python -m cases.figures.merge
  ensemble NEW OLD OUT``. The figure cases' merge, particle columns completed lam by lam, is
  :func:`cases.figures.merge.merge`.
"""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np

from cases import analysis as A

__all__ = ["lam_of", "ensemble_data", "LAM_TABLES", "merge_rows", "merge"]

_LAM = re.compile(r"lam=([0-9.eE+-]+?)(?:_|\.csv)")


def lam_of(name: str) -> float | None:
    """The lam a case's file belongs to (``..._lam=L.csv``, ``..._lam=L_k=K.csv.gz``), or None."""
    m = _LAM.search(name)
    return float(m.group(1)) if m else None


def ensemble_data(figure_data: str | Path, radius: float | None = None) -> Path | None:
    """The ensemble's data beside a figure case's data, if any (for the figures' seed bands).

    ``cases/data/fig3`` -> ``cases/data/ensemble``, ``NAME_paper`` -> ``ensemble_paper``, an
    ``OUT/data`` folder -> ``OUT/ensemble`` (copy or link an ensemble's data there). Taken only
    when its radius is ``radius`` (within one particle length), if given.
    """
    figure_data = Path(figure_data)
    suffix = "_paper" if figure_data.name.endswith("_paper") else ""
    for candidate in (figure_data.parent / f"ensemble{suffix}",
                      figure_data.parent / "ensemble"):
        if (candidate / "summary.csv").is_file():
            if radius is not None and math.isfinite(radius):
                R = float(A.read_csv(candidate / "summary.csv")["radius"][0])
                if abs(R - radius) > 1.0:
                    return None
            return candidate
    return None


#: The tables with one row per lam (seeds.csv: per lam and seed) that :func:`merge` replaces
#: lam by lam; numerics.csv and the files of docs/measurements/stress_offset.py (estimators.csv,
#: growth_paper.csv) are the earlier data set's.
LAM_TABLES = ("seeds.csv", "summary.csv", "differences.csv", "growth_rates.csv")


def merge_rows(new: str, old: str) -> str:
    """CSV text: ``old``'s rows of the lam ``new`` has no row of, and ``new``'s rows.

    The rows are ordered by lam (the first column), stably: a lam's rows keep their order (the
    seeds of seeds.csv) and every row is kept as its text, so the untouched lam's rows stay
    byte for byte. ValueError when the headers differ.
    """
    new_lines, old_lines = new.splitlines(keepends=True), old.splitlines(keepends=True)
    if not new_lines or not old_lines or new_lines[0] != old_lines[0]:
        raise ValueError("the tables' columns differ: "
                         f"{new_lines[:1]!r} and {old_lines[:1]!r}")
    if not new_lines[0].startswith("lam,"):
        raise ValueError(f"the first column must be lam, got {new_lines[0]!r}")

    def lam(line: str) -> float:
        return float(line.split(",", 1)[0])

    replaced = {lam(line) for line in new_lines[1:]}
    rows = [line for line in old_lines[1:] if lam(line) not in replaced] + new_lines[1:]
    rows = [line if line.endswith("\n") else line + "\n" for line in rows]
    return old_lines[0] + "".join(sorted(rows, key=lam))


def merge(new: str | Path, old: str | Path, out: str | Path) -> Path:
    """The ensemble data ``old`` with the lam of the partial reduction ``new`` added or replaced.

    ``new``: the data of ``colony case ensemble --lams L,...``
    (:func:`cases.studies.ensemble.compute` with ``lams``). Written to ``out`` (which must not
    exist; staged as OUT.partial, then renamed, as
    :func:`cases.figures.merge.merge`): every file of ``old``, the per-lam files of ``new``
    (``profile_lam=``, ``radius_lam=``, ``time_lam=``, ``growth_lam=``), and in each table of
    :data:`LAM_TABLES` the rows of ``new``'s lam in place of ``old``'s (:func:`merge_rows`).
    """
    new, old, out = Path(new), Path(old), Path(out)
    for d in (new, old):
        if not (d / "summary.csv").is_file():
            raise ValueError(f"no ensemble data (summary.csv) in {d}")
    if out.exists():
        raise ValueError(f"{out} exists already")
    tables = {name: merge_rows((new / name).read_text(), (old / name).read_text())
              for name in LAM_TABLES}
    lams = set(np.atleast_1d(A.read_csv(new / "summary.csv")["lam"]).tolist())
    files = [p for p in sorted(new.iterdir()) if lam_of(p.name) is not None]
    for p in files:
        if lam_of(p.name) not in lams:
            raise ValueError(f"{p.name} of {new} belongs to no lam of its summary.csv")
    stage = out.with_name(out.name + ".partial")
    if stage.exists():
        shutil.rmtree(stage)
    shutil.copytree(old, stage)
    for p in files:
        shutil.copy2(p, stage / p.name)
    for name, text in tables.items():
        (stage / name).write_text(text)
    stage.rename(out)
    return out
