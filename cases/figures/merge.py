"""Merge a case's new reduction with the particle part of an earlier one.

A paper-scale particle colony takes an hour or more, so a paper case is often reduced again
when only some of its particle runs are new (``colony case CASE --scale paper --engines
finished`` takes the continuum runs and the particle runs on disk): its data then hold the
continuum of every lam and the particles of the new runs, with nan in the particle columns of
the others. :func:`merge` completes them from the earlier data set, lam by lam:

- files: every file of NEW; the files of OLD that NEW has not, if they are particle files
  (names with ``particles`` or ``radius_diff``) or belong to a lam that NEW has no row of;
- the summary table (fig3, fig4: ``summary.csv``; crosscheck: ``table.csv``): each particle
  column (:data:`TABLES`) that is nan in NEW takes OLD's value of the
  same lam, and OLD's rows of the lam NEW has not are added (rows ordered by lam);
  crosscheck's ``exponents.csv`` is fitted again from the merged table;
- fig2's ``snapshots.csv``: every row of NEW, and OLD's rows of each (engine, lam) that NEW has
  no row of.

So NEW may also hold only some lam (``colony case CASE --lams L,...``): a new particle colony
is then reduced with its continuum run alone, and the other lam keep their earlier data.

The seed ensemble (``ensemble``: ``colony case ensemble --lams L,...``) is merged by
:func:`cases.datasets.merge`: NEW's lam replace or add whole rows and per-lam files. The lam a
file belongs to is :func:`cases.datasets.lam_of`.

Command line::

    python -m cases.figures.merge CASE NEW_DATA OLD_DATA OUT

OUT must not exist (it is written as OUT.partial, then renamed); OLD_DATA's README.md is
copied (to be edited).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases import datasets
from cases.figures import crosscheck, fig3

__all__ = ["merge", "TABLES"]

TABLES = {"fig3": ("summary.csv", fig3.PARTICLE_COLUMNS),
          "fig4": ("summary.csv", ("radius_particles", "wavelength_particles",
                                   "ring_z_particles")),
          "crosscheck": ("table.csv", crosscheck.PARTICLE_COLUMNS)}
"""Per case, its summary table and the table's particle columns."""

CASES = ("fig2", *TABLES, "ensemble")


def is_particle_file(name: str) -> bool:
    """A file of a case's particle part (``particles`` or ``radius_diff`` in its name)."""
    return "particles" in name or name.startswith("radius_diff")


def merge_table(new: dict, old: dict, columns) -> dict:
    """``new`` with its nan particle ``columns`` taken from ``old``'s row of the same lam.

    ``old``'s rows of the lam that ``new`` has not are added; the rows are ordered by lam.
    """
    if list(new) != list(old):
        raise ValueError(f"the tables' columns differ: {list(new)} and {list(old)}")
    merged = {k: np.array(v, dtype=float) for k, v in new.items()}
    old = {k: np.array(v, dtype=float) for k, v in old.items()}
    for i, lam in enumerate(merged["lam"]):
        j = np.flatnonzero(old["lam"] == lam)
        if j.size != 1:
            continue
        for c in columns:
            if np.isnan(merged[c][i]):
                merged[c][i] = old[c][j[0]]
    extra = ~np.isin(old["lam"], merged["lam"])
    merged = {k: np.concatenate([v, old[k][extra]]) for k, v in merged.items()}
    order = np.argsort(merged["lam"], kind="stable")
    return {k: v[order] for k, v in merged.items()}


def merge_snapshots(new: dict, old: dict) -> dict:
    """fig2's snapshot rows: every row of ``new`` and the other rows of ``old``.

    Those are ``old``'s rows of each (engine, lam) that ``new`` has no row of; the rows are
    ordered by (engine, lam, k), as ``fig2.reduce`` writes them.
    """
    pairs = set(zip(np.asarray(new["engine"]).tolist(), np.asarray(new["lam"]).tolist(),
                    strict=True))
    keep = np.array([(e, lam) not in pairs for e, lam in
                     zip(np.asarray(old["engine"]).tolist(), np.asarray(old["lam"]).tolist(),
                         strict=True)], dtype=bool)
    rows = {k: np.concatenate([np.asarray(new[k], dtype=float),
                               np.asarray(old[k], dtype=float)[keep]]) for k in new}
    order = np.lexsort((rows["k"], rows["lam"], rows["engine"]))
    return {k: v[order] for k, v in rows.items()}


def new_lams(case: str, new: Path) -> set[float]:
    """The lam that NEW's table (fig2: snapshot index) has rows of."""
    name = "snapshots.csv" if case == "fig2" else TABLES[case][0]
    return set(np.asarray(A.read_csv(new / name)["lam"], dtype=float).tolist())


def merge(case: str, new: str | Path, old: str | Path, out: str | Path) -> Path:
    """Write to ``out`` the data of ``case`` merged from ``new`` and ``old`` (module docstring)."""
    if case not in CASES:
        raise ValueError(f"case must be one of {', '.join(CASES)}, got {case!r}")
    if case == "ensemble":
        return datasets.merge(new, old, out)
    new, old, out = Path(new), Path(old), Path(out)
    for d in (new, old):
        if not d.is_dir():
            raise ValueError(f"no data folder {d}")
    if out.exists():
        raise ValueError(f"{out} exists already")
    stage = out.with_name(out.name + ".partial")
    if stage.exists():
        shutil.rmtree(stage)
    shutil.copytree(new, stage)
    lams = new_lams(case, new)
    for p in sorted(old.iterdir()):
        lam = datasets.lam_of(p.name)
        if lam is None or (stage / p.name).exists():
            continue
        if is_particle_file(p.name) or lam not in lams:
            shutil.copy2(p, stage / p.name)
    if (old / "README.md").is_file():
        shutil.copy2(old / "README.md", stage / "README.md")
    if case == "fig2":
        A.write_csv(stage / "snapshots.csv", merge_snapshots(
            A.read_csv(new / "snapshots.csv"), A.read_csv(old / "snapshots.csv")))
    else:
        name, columns = TABLES[case]
        table = merge_table(A.read_csv(new / name), A.read_csv(old / name), columns)
        A.write_csv(stage / name, table)
        if case == "crosscheck":
            A.write_csv(stage / "exponents.csv", crosscheck.exponents(table))
    stage.rename(out)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case", help=f"one of {', '.join(CASES)}")
    p.add_argument("new", type=Path, help="the new reduction (a case's OUT/data)")
    p.add_argument("old", type=Path, help="the earlier data set (e.g. cases/data/fig3_paper)")
    p.add_argument("out", type=Path, help="the merged data set (must not exist)")
    a = p.parse_args(argv)
    try:
        merge(a.case, a.new, a.old, a.out)
    except ValueError as err:
        print(f"merge: error: {err}", file=sys.stderr)
        return 2
    part = "the other lam" if a.case == "ensemble" else "the particle part"
    print(f"{a.case}: merged {a.new} with {part} of {a.old} into {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
