#!/usr/bin/env python3
"""Hash the outputs of a fixed set of small runs: the before/after check of a refactoring.

A maintainer's tool, not a test (issue 43; the hash check of issue 29 is the model). It runs,
into a temporary folder and on one core,

- ``colony particles``: one plain colony and one of two strains in a core layout (fixed seeds);
- ``colony continuum``: one plain colony and one of two strains;
- ``colony case NAME --scale smoke`` for every case ``colony case --help`` lists, in a fixed
  order, their engine runs shared in one ``--runs`` folder (as a user shares them);

and writes the sha256 of every output file, by sorted relative path, to OUTFILE (JSON). Left out
are the files that record the run's circumstances rather than its results: ``run.json`` (wall
time, dates, host, versions), logs and progress files. PDFs are made byte-stable by
``SOURCE_DATE_EPOCH`` (matplotlib then writes a fixed creation date); the temporary folder's
path, which a hand-off records, is read as ``ROOT``. Two runs on one commit (364bd6e) hashed
the same in every other file, PNG and PDF included.

The tree under test is the current directory (or ``--tree``): every command runs there with
``PYTHONPATH`` set to it, so a worktree of another commit is measured with this one script::

    git worktree add /work/base HEAD
    cd /work/base && python /path/to/.ci/hashes.py /tmp/hashes-base.json
    cd /work/main && python .ci/hashes.py /tmp/hashes-after.json
    python .ci/hashes.py --compare /tmp/hashes-base.json /tmp/hashes-after.json

About 4-5 minutes on one core.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ENGINE_RUNS = {
    "particles-plain": ["particles", "--lam", "1e-2", "--radius", "6", "--seed", "3"],
    "particles-strains": ["particles", "--lam", "1e-2", "--strains", "1e-2,0", "--layout",
                          "core:3", "--shape", "circle:4", "--radius", "8", "--seed", "5"],
    "continuum-plain": ["continuum", "--lam", "1e-2", "--radius", "8"],
    "continuum-strains": ["continuum", "--lam", "1e-2", "--strains", "1e-2,0:1.2", "--layout",
                          "core:2", "--shape", "circle:3", "--radius", "6"],
}
CASES = ("fig2", "fig3", "fig4", "crosscheck", "stability", "convergence", "ensemble", "shapes",
         "orientation", "strains")
# Files that record how a run went (wall time, dates, host), not what it computed.
SKIP_NAMES = {"run.json"}
SKIP_SUFFIXES = (".log",)
SKIP_PARTS = ("progress", "timing")


def _env(tree: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree)
    env["SOURCE_DATE_EPOCH"] = "0"
    env["MPLBACKEND"] = "Agg"
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[var] = "1"
    return env


def _colony(args: list[str], tree: Path, env: dict[str, str]) -> float:
    """Run ``python -m cases.cli ARGS`` in TREE; return its wall seconds."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "cases.cli", *args, "--quiet"], cwd=tree, env=env,
                   check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def _kept(rel: Path) -> bool:
    name = rel.name.lower()
    return (name not in SKIP_NAMES and not name.endswith(SKIP_SUFFIXES)
            and not any(part in name for part in SKIP_PARTS))


def hash_folder(root: Path) -> dict[str, str]:
    """sha256 of every kept file below ROOT, by sorted relative POSIX path.

    ROOT's own absolute path, which a run records where it names another run's folder (a
    hand-off's particle run, its init.csv), is read as ``ROOT`` first, so the temporary
    folder's name does not count.
    """
    prefix = str(root.resolve()).encode()
    out = {}
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        rel = path.relative_to(root)
        if _kept(rel):
            data = path.read_bytes().replace(prefix, b"ROOT")
            out[rel.as_posix()] = hashlib.sha256(data).hexdigest()
    return out


def run_all(tree: Path, work: Path, only: set[str] | None = None) -> dict:
    """Run the engine runs and cases of TREE into WORK; return the provenance and the hashes."""
    env = _env(tree)
    imported = subprocess.run([sys.executable, "-c", "import cases; print(cases.__file__)"],
                              cwd=tree, env=env, check=True, capture_output=True,
                              text=True).stdout.strip()
    if not Path(imported).resolve().is_relative_to(tree.resolve()):
        raise SystemExit(f"cases imports from {imported}, not from the tree {tree}")
    seconds = {}
    for name, args in ENGINE_RUNS.items():
        if only is None or name in only:
            seconds[name] = _colony([*args, "--out", str(work / "engines" / name)], tree, env)
            print(f"{name}: {seconds[name]:.0f} s", file=sys.stderr)
    for case in CASES:
        if only is None or case in only:
            seconds[case] = _colony(["case", case, "--scale", "smoke", "--workers", "1",
                                     "--out", str(work / "cases" / case),
                                     "--runs", str(work / "cases" / "runs")], tree, env)
            print(f"{case}: {seconds[case]:.0f} s", file=sys.stderr)
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=tree, capture_output=True,
                            text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                                cwd=tree, capture_output=True, text=True).stdout.strip())
    return {"tree": str(tree), "commit": commit, "dirty": dirty, "cases_module": imported,
            "seconds": {k: round(v, 1) for k, v in seconds.items()},
            "files": hash_folder(work)}


def compare(a_path: Path, b_path: Path) -> int:
    """Print the files that differ, are missing or are new; 0 when every hash agrees."""
    a = json.loads(a_path.read_text())["files"]
    b = json.loads(b_path.read_text())["files"]
    changed = sorted(k for k in a.keys() & b.keys() if a[k] != b[k])
    only_a, only_b = sorted(a.keys() - b.keys()), sorted(b.keys() - a.keys())
    for label, names in (("differ", changed), (f"only in {a_path}", only_a),
                         (f"only in {b_path}", only_b)):
        for name in names:
            print(f"{label}: {name}")
    same = len(a.keys() & b.keys()) - len(changed)
    print(f"{same} identical, {len(changed)} differ, {len(only_a)} + {len(only_b)} unpaired")
    return 0 if not (changed or only_a or only_b) else 1


def main(argv: list[str] | None = None) -> int:
    """Command line: write OUTFILE, or compare two hash files (exit 1 when they differ)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("outfile", nargs="?", type=Path, help="JSON of the hashes to write")
    ap.add_argument("--tree", type=Path, default=Path.cwd(),
                    help="checkout to run (default: the current directory)")
    ap.add_argument("--keep", type=Path, default=None,
                    help="write the runs here (kept) instead of a temporary folder")
    ap.add_argument("--only", default=None,
                    help="comma-separated names of engine runs or cases (default: all)")
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("A", "B"),
                    help="compare two hash files instead of running")
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    if args.outfile is None:
        ap.error("OUTFILE is required unless --compare is given")
    only = set(args.only.split(",")) if args.only else None
    tree = args.tree.resolve()
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=False)
        result = run_all(tree, args.keep.resolve(), only)
    else:
        with tempfile.TemporaryDirectory(prefix="colony-hashes-") as tmp:
            result = run_all(tree, Path(tmp), only)
    args.outfile.write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    print(f"{len(result['files'])} files hashed into {args.outfile}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
