"""Carry a paused run to another machine: its resume state, packed and unpacked.

A run stopped or paused (``--max-hours``, SIGTERM) resumes from four files of its stage folder
``DIR.partial`` (RESUME_FILES): ``run.json``, ``config.json``, ``history.csv`` and
``checkpoint.npz``. The trajectory frames stay behind (far larger; a run resumed without
``trajectory.gsd`` starts a new one at its next frame), and ``checkpoint.prev.npz`` too (the
checkpoint is verified when packed).

    python -m cases.carry pack DIR.partial FOLDER     # FOLDER: e.g. in a git repository
    python -m cases.carry unpack FOLDER DIR           # makes DIR.partial; then the run's command

``pack`` replaces FOLDER as a whole (written beside it, then renamed) and adds ``carry.json``:
each file's bytes and sha256, the cells and step of the checkpoint, and its bytes per cell.
The checkpoint is stored xz-compressed (``checkpoint.npz.xz``: 0.58 of its bytes at 243,629
cells, against 0.66 for git's own zlib), since a colony's states stay in the repository's
history. ``unpack`` restores each file, checks its digest before it creates ``DIR.partial``,
and refuses a ``DIR`` or ``DIR.partial`` that exists; it also reads the folders of earlier
versions, which stored the checkpoint as it is.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import lzma
import os
import shutil
from pathlib import Path

import numpy as np

from cases.rundir import partial_of

#: What a stopped run needs to resume, from its stage folder.
RESUME_FILES = ("run.json", "config.json", "history.csv", "checkpoint.npz")
#: The record ``pack`` adds to the folder.
CARRY = "carry.json"
#: The files ``pack`` stores compressed, under their name with this suffix.
COMPRESSED = {"checkpoint.npz": ".xz"}


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
        files[name] = {"bytes": (stage / name).stat().st_size, "sha256": _sha256(stage / name)}
        stored = name + COMPRESSED.get(name, "")
        if stored == name:
            shutil.copyfile(stage / name, tmp / name)
        else:
            with open(stage / name, "rb") as src, lzma.open(tmp / stored, "wb", preset=9) as dst:
                shutil.copyfileobj(src, dst, 1 << 20)
            files[name]["stored"] = stored
            files[name]["stored_bytes"] = (tmp / stored).stat().st_size
    if _sha256(stage / "checkpoint.npz") != files["checkpoint.npz"]["sha256"]:
        raise ValueError(f"{stage / 'checkpoint.npz'} changed while packed: is its run going?")
    checkpoint = files["checkpoint.npz"]
    record = {"cells": cells, "step": step, "files": files,
              "checkpoint_bytes_per_cell": round(checkpoint["bytes"] / max(cells, 1), 1),
              "stored_bytes_per_cell": round(checkpoint["stored_bytes"] / max(cells, 1), 1)}
    (tmp / CARRY).write_text(json.dumps(record, indent=2) + "\n")
    if folder.exists():
        shutil.rmtree(folder)
    tmp.rename(folder)
    return record


def unpack(folder: str | os.PathLike, out: str | os.PathLike) -> Path:
    """Make ``out.partial`` from a packed resume state (digests checked); returns it."""
    folder, out = Path(folder), Path(out)
    record = json.loads((folder / CARRY).read_text())
    partial = partial_of(out)
    for existing in (out, partial):
        if existing.exists():
            raise ValueError(f"{existing} exists; move it away first")
    tmp = partial.with_name(partial.name + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        for name, expected in record["files"].items():
            stored = folder / expected.get("stored", name)
            if stored.name == name:
                shutil.copyfile(stored, tmp / name)
            else:
                with lzma.open(stored, "rb") as src, open(tmp / name, "wb") as dst:
                    shutil.copyfileobj(src, dst, 1 << 20)
            if _sha256(tmp / name) != expected["sha256"]:
                raise ValueError(f"{stored} differs from what {CARRY} recorded")
    except (lzma.LZMAError, EOFError) as error:
        shutil.rmtree(tmp, ignore_errors=True)
        raise ValueError(f"{folder}: a compressed file does not decompress ({error})") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
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
              f"{record['checkpoint_bytes_per_cell']} bytes per cell "
              f"({record['stored_bytes_per_cell']} stored)")
    else:
        print(f"{unpack(args.folder, args.out)}: give the run's command to resume it")


if __name__ == "__main__":
    main()
