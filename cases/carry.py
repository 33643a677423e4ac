"""Carry a paused run to another machine: its resume state, packed and unpacked.

A run stopped or paused (``--max-hours``, SIGTERM) resumes from four files of its stage folder
``DIR.partial`` (RESUME_FILES): ``run.json``, ``config.json``, ``history.csv`` and
``checkpoint.npz``. The trajectory frames stay behind (far larger; a run resumed without
``trajectory.gsd`` starts a new one at its next frame), and ``checkpoint.prev.npz`` too (the
checkpoint is verified when packed).

    python -m cases.carry pack DIR.partial FOLDER     # FOLDER: e.g. in a git repository
    python -m cases.carry unpack FOLDER DIR           # makes DIR.partial; then the run's command

``pack`` replaces FOLDER as a whole (written beside it, then renamed) and adds ``carry.json``:
each file's bytes and sha256, the cells and step of the checkpoint, and its bytes per cell;
``unpack`` checks those digests before it creates ``DIR.partial``, and refuses a ``DIR`` or
``DIR.partial`` that exists.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np

from cases.rundir import partial_of

#: What a stopped run needs to resume, from its stage folder.
RESUME_FILES = ("run.json", "config.json", "history.csv", "checkpoint.npz")
#: The record ``pack`` adds to the folder.
CARRY = "carry.json"


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def checkpoint_size(path: Path) -> tuple[int, int]:
    """(cells, step) of a checkpoint: particles (array x) or mesh nodes (array points).

    The step is in the particle engine's ``meta`` or the continuum's ``meta["colony"]``.
    """
    with np.load(path, allow_pickle=False) as arrays:
        meta = json.loads(str(arrays["meta"]))
        cells = len(arrays["x" if "x" in arrays.files else "points"])
    step = meta["step"] if "step" in meta else meta.get("colony", {}).get("step", -1)
    return cells, int(step)


def pack(stage: str | os.PathLike, folder: str | os.PathLike) -> dict:
    """Copy the resume state of ``stage`` into ``folder`` (replaced whole); its carry.json."""
    stage, folder = Path(stage), Path(folder)
    missing = [name for name in RESUME_FILES if not (stage / name).is_file()]
    if missing:
        raise ValueError(f"{stage} is not a stopped run's stage: no {', '.join(missing)}")
    cells, step = checkpoint_size(stage / "checkpoint.npz")
    tmp = folder.with_name(folder.name + ".tmp")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    files = {}
    for name in RESUME_FILES:
        shutil.copyfile(stage / name, tmp / name)
        files[name] = {"bytes": (tmp / name).stat().st_size, "sha256": _sha256(tmp / name)}
    record = {"cells": cells, "step": step, "files": files,
              "checkpoint_bytes_per_cell": round(files["checkpoint.npz"]["bytes"]
                                                 / max(cells, 1), 1)}
    (tmp / CARRY).write_text(json.dumps(record, indent=2) + "\n")
    if folder.exists():
        shutil.rmtree(folder)
    tmp.rename(folder)
    return record


def unpack(folder: str | os.PathLike, out: str | os.PathLike) -> Path:
    """Make ``out.partial`` from a packed resume state (digests checked); returns it."""
    folder, out = Path(folder), Path(out)
    record = json.loads((folder / CARRY).read_text())
    for name, expected in record["files"].items():
        if _sha256(folder / name) != expected["sha256"]:
            raise ValueError(f"{folder / name} differs from what {CARRY} recorded")
    partial = partial_of(out)
    for existing in (out, partial):
        if existing.exists():
            raise ValueError(f"{existing} exists; move it away first")
    tmp = partial.with_name(partial.name + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    for name in record["files"]:
        shutil.copyfile(folder / name, tmp / name)
    tmp.rename(partial)
    return partial


def main(argv: list[str] | None = None) -> None:
    """``python -m cases.carry pack STAGE FOLDER`` / ``unpack FOLDER DIR``."""
    p = argparse.ArgumentParser(prog="python -m cases.carry", description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    a = sub.add_parser("pack", help="copy a stopped run's resume state into FOLDER")
    a.add_argument("stage")
    a.add_argument("folder")
    b = sub.add_parser("unpack", help="make DIR.partial from a packed resume state")
    b.add_argument("folder")
    b.add_argument("out")
    args = p.parse_args(argv)
    if args.command == "pack":
        record = pack(args.stage, args.folder)
        print(f"{args.folder}: {record['cells']:,} cells at step {record['step']}, checkpoint "
              f"{record['checkpoint_bytes_per_cell']} bytes per cell")
    else:
        print(f"{unpack(args.folder, args.out)}: give the run's command to resume it")


if __name__ == "__main__":
    main()
