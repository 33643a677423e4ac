"""The hash check: sha256 of every output file of a fixed set of small runs and cases.

    python docs/measurements/output_hashes.py OUT [--cases]      # writes OUT/hashes.csv

Run it from a checkout (or a ``git worktree`` of the base commit, with that checkout's
environment) before and after a change that must not change any result, then compare the two
``hashes.csv`` (``diff``): a refactoring is byte-identical when they are. ``run.json`` (times,
versions, commands) is left out. Give both the same OUT (moving the first away in between):
the hand-off records the path of its particle run. ``--cases`` adds the smoke scale of the
figure cases (minutes). That a run in legs equals one uninterrupted run is tests/cases/
test_legs.py's.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import subprocess
import sys
from pathlib import Path

#: (name, colony arguments): the engine paths a refactoring of the run loop or the command
#: line touches: frames, both goals, shapes, the hand-off, strains.
RUNS = [
    ("continuum", ["continuum", "--lam", "1e-2", "--radius", "3", "--set", "n_nodes=300",
                   "--output-every", "0.5"]),
    ("continuum_time", ["continuum", "--lam", "1e-3", "--time", "3", "--set", "n_nodes=300"]),
    ("continuum_ellipse", ["continuum", "--lam", "1e-2", "--radius", "3", "--shape",
                           "ellipse:2,1", "--set", "n_nodes=300"]),
    ("particles", ["particles", "--lam", "1e-2", "--radius", "4", "--output-every", "0.3"]),
    ("particles_time", ["particles", "--lam", "1e-3", "--time", "3", "--seed", "2"]),
    ("particles_strains", ["particles", "--strains", "1e-2,0:0,1", "--layout", "sector:3.14159",
                           "--radius", "4"]),
    ("particles_shape", ["particles", "--lam", "1e-2", "--shape", "ellipse:3,1.5", "--radius",
                         "4"]),
    ("handoff", ["continuum", "--from-particles", "{particles}", "--radius", "6", "--set",
                 "n_nodes=300"]),
]
CASES = ["fig2", "fig3", "fig4"]
SKIP = {"run.json"}


def _colony(args: list[str]) -> int:
    return subprocess.run([sys.executable, "-m", "cases.cli", *args, "--quiet"],
                          capture_output=True, text=True).returncode


def digest(path: Path) -> str:
    """sha256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def hashes(root: Path) -> list[tuple[str, str]]:
    """(relative path, sha256) of every file under ``root`` but :data:`SKIP`, sorted."""
    return sorted((str(p.relative_to(root)), digest(p)) for p in root.rglob("*")
                  if p.is_file() and p.name not in SKIP)


def main(argv: list[str] | None = None) -> None:
    """Run the set into OUT and write OUT/hashes.csv."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--cases", action="store_true", help="also the figure cases at smoke scale")
    args = ap.parse_args(argv)
    runs = args.out / "runs"
    runs.mkdir(parents=True, exist_ok=True)
    for name, words in RUNS:
        words = [w.format(particles=runs / "particles") for w in words]
        status = _colony([*words, "--out", str(runs / name)])
        print(f"{name}: exit {status}", flush=True)
    if args.cases:
        for case in CASES:
            status = _colony(["case", case, "--scale", "smoke", "--workers", "1", "--out",
                              str(args.out / "cases" / case)])
            print(f"case {case}: exit {status}", flush=True)
    with open(args.out / "hashes.csv", "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["file", "sha256"])
        for root in (runs, args.out / "cases"):
            if root.is_dir():
                writer.writerows((f"{root.name}/{name}", h) for name, h in hashes(root))
    print(f"written {args.out / 'hashes.csv'}")


if __name__ == "__main__":
    main()
