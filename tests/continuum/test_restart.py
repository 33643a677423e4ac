"""Continuum runs are deterministic, and a stopped run resumes to the uninterrupted result.

Bit for bit: two runs of one configuration (in one process and in two processes), and a run
stopped (``max_steps`` or SIGTERM) and resumed from its checkpoint against the
uninterrupted run, compared file by file (history.csv, boundary.csv, config.json, fields.pvd,
every VTU) and array by array (history, points, triangles, every field). The returned
simulation is ``continuum.run``'s.

The small configuration (SMALL of conftest.py) remeshes at steps 14, 17 and 20 of its 21 steps
(boundary criterion, with h_max = 0.25 and stretch = 1.2) and writes a VTU frame every 0.5 time
units (t = 4.07 at the end); each run takes about 0.3 s.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from continuum import Simulation, run
from continuum.runfiles import CHECKPOINT

from .conftest import SMALL, small_config, state_bytes


def folder_digest(folder: Path) -> dict:
    """sha256 of every file of a run folder except checkpoints, by relative path."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.name.startswith("checkpoint")
    }


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run of SMALL: (folder, returned simulation)."""
    out = tmp_path_factory.mktemp("reference")
    return out, run(small_config(), out=out)


def frame_steps(history: list, output_every: float) -> list[int]:
    """Steps after which run() writes a VTU frame (t >= next frame time, not the last step)."""
    steps, next_frame = [], output_every
    for i, row in enumerate(history[1:-1], start=1):
        if row["t"] >= next_frame:
            steps.append(i)
            next_frame += output_every
    return steps


def test_same_configuration_same_bits_in_process():
    """Two runs in one process give the same bytes.

    The AMG setup no longer draws random start vectors from numpy's global generator
    (continuum.pressure.amg_hierarchy).
    """
    assert state_bytes(run(small_config())) == state_bytes(run(small_config()))


DIGEST_SCRIPT = """
import hashlib, sys
import numpy as np
sys.path.insert(0, {root!r})
from tests.continuum.conftest import small_config, state_bytes
from continuum import run
h = hashlib.sha256()
for k, v in sorted(state_bytes(run(small_config())).items()):
    h.update(k.encode()); h.update(v)
print(h.hexdigest())
"""


def test_same_configuration_same_bits_in_two_processes():
    """Two fresh interpreters give the same bytes, and the same as this process."""
    script = DIGEST_SCRIPT.format(root=str(Path(__file__).resolve().parents[2]))
    digests = [
        subprocess.run(
            [sys.executable, "-c", script], capture_output=True, text=True, check=True
        ).stdout.strip()
        for _ in range(2)
    ]
    h = hashlib.sha256()
    for k, v in sorted(state_bytes(run(small_config())).items()):
        h.update(k.encode())
        h.update(v)
    assert digests[0] == digests[1] == h.hexdigest()


def test_global_random_state_untouched():
    """A run neither depends on nor disturbs numpy's global generator."""
    # The legacy global generator is what this test is about (NPY002 asks to avoid it).
    np.random.seed(7)  # noqa: NPY002
    expected = np.random.rand(3)  # noqa: NPY002
    np.random.seed(7)  # noqa: NPY002
    run(small_config(radius=1.0))
    assert np.array_equal(np.random.rand(3), expected)  # noqa: NPY002


def resumed_run(out: Path, stops: list[int]):
    """Run SMALL into ``out`` stopping after each count of ``stops`` steps, then to the end."""
    for n in stops:
        state = run(small_config(), out=out, max_steps=n)
        assert not state.finished
        assert (out / CHECKPOINT).is_file()
    return run(small_config(), out=out)


def assert_same_run(reference, out: Path, state, skip: tuple = ()) -> None:
    """Same files (but ``skip``) and same returned bytes as the reference (folder, simulation)."""
    ref_out, ref_state = reference
    assert state.finished
    files, ref_files = folder_digest(out), folder_digest(ref_out)
    for name in skip:
        files.pop(name), ref_files.pop(name)
    assert files == ref_files
    assert state_bytes(state) == state_bytes(ref_state)


def test_stop_at_ordinary_step_resumes_bit_identical(reference, tmp_path):
    history = reference[1].history
    ordinary = next(i for i in range(3, len(history) - 1)
                    if not history[i]["remesh"] and not history[i + 1]["remesh"]
                    and i not in frame_steps(history, SMALL["output_every"]))
    assert_same_run(reference, tmp_path, resumed_run(tmp_path, [ordinary]))


def test_stop_at_remesh_steps_resumes_bit_identical(reference, tmp_path):
    """Stops after a remeshing step and just before one (the resumed call remeshes first).

    The AMG hierarchy is in use at some of the checkpoints (rebuilt from its saved matrix).
    """
    history = reference[1].history
    remesh = [i for i, row in enumerate(history) if row["remesh"]]
    assert len(remesh) >= 2
    stops = [remesh[0] - 1, 1, remesh[1] - remesh[0]]  # at steps r0 - 1, r0, r1
    assert_same_run(reference, tmp_path, resumed_run(tmp_path, stops))


def test_stop_at_frame_step_resumes_bit_identical(reference, tmp_path):
    """Stops right after a step that writes a VTU frame.

    A frame written after the checkpoint (an interrupted run's) is removed on resume and
    written again.
    """
    history = reference[1].history
    frames = frame_steps(history, SMALL["output_every"])
    assert len(frames) >= 3
    run(small_config(), out=tmp_path, max_steps=frames[1])
    ckpt = (tmp_path / CHECKPOINT).read_bytes()
    run(small_config(), out=tmp_path, max_steps=frames[2] - frames[1])
    (tmp_path / CHECKPOINT).write_bytes(ckpt)  # as if killed after frame 3 was written
    assert_same_run(reference, tmp_path, resumed_run(tmp_path, []))


def test_stop_after_every_step_resumes_bit_identical(reference, tmp_path):
    """One step per call, each resumed from the checkpoint of the previous one.

    The checkpoints carry the AMG matrix (measured: resuming with a fresh hierarchy instead
    changes the bits after 17 of these 20 stops).
    """
    held = []
    while not (state := run(small_config(), out=tmp_path, max_steps=1)).finished:
        with np.load(tmp_path / CHECKPOINT) as z:
            held.append("amg" in z.files)
    assert len(held) == len(reference[1].history) - 2 and any(held)
    assert_same_run(reference, tmp_path, state)


def test_mismatched_configuration_refuses_to_resume(tmp_path):
    run(small_config(), out=tmp_path, max_steps=2)
    with pytest.raises(ValueError, match=r"differs in lam.*start afresh"):
        run(small_config(lam=2e-2), out=tmp_path)
    # an execution setting may differ
    state = run(small_config(checkpoint_seconds=5.0), out=tmp_path, max_steps=1)
    assert len(state.history) == 4


def test_periodic_checkpoints_do_not_change_the_result(reference, tmp_path):
    """A checkpoint after every step (checkpoint_seconds = 0) gives the same files.

    config.json aside, which records checkpoint_seconds.
    """
    state = run(small_config(checkpoint_seconds=0.0), out=tmp_path)
    assert_same_run(reference, tmp_path, state, skip=("config.json",))
    meta = json.loads(str(np.load(tmp_path / CHECKPOINT)["meta"]))
    assert meta["history"]["rows"] == len(state.history) - 1  # the last step before the goal


def interrupt_at(monkeypatch, step: int, signum=signal.SIGINT) -> None:
    """Make the next run receive ``signum`` while it remeshes or steps its ``step``-th step."""
    advance, calls = Simulation._step, [0]

    def advance_and_signal(sim, *args, **kwargs):
        calls[0] += 1
        if calls[0] == step:
            signal.raise_signal(signum)
        return advance(sim, *args, **kwargs)

    monkeypatch.setattr(Simulation, "_step", advance_and_signal)


@pytest.mark.parametrize("where", ["remesh", "last"])
def test_sigint_finishes_the_step_checkpoints_and_resumes(reference, tmp_path, monkeypatch,
                                                          where):
    """SIGINT during a remeshing step, or during the last step.

    In the last step the checkpoint records a finished run, whose final outputs the resumed
    call writes again. KeyboardInterrupt comes after that step's checkpoint; the resumed run
    equals the uninterrupted one.
    """
    history = reference[1].history
    step = {"remesh": next(i for i, r in enumerate(history) if r["remesh"]),
            "last": len(history) - 1}[where]
    # Python's own SIGINT handler before the run, also where the test process inherited SIG_IGN
    # (started in the background by a shell); the run must put it back.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        interrupt_at(monkeypatch, step)
        with pytest.raises(KeyboardInterrupt):
            run(small_config(), out=tmp_path)
        monkeypatch.undo()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)
    meta = json.loads(str(np.load(tmp_path / CHECKPOINT)["meta"]))
    assert meta["history"]["rows"] == step + 1 and meta["done"] == (where == "last")
    assert_same_run(reference, tmp_path, run(small_config(), out=tmp_path))


SIGTERM_SCRIPT = """
import sys
sys.path.insert(0, {root!r})
from tests.continuum.conftest import small_config
from continuum import run
run(small_config(radius=8.0), out={out!r})
"""


def test_sigterm_checkpoints_and_resumes(tmp_path):
    """SIGTERM while stepping: exit status 143, a checkpoint, a resumed run as uninterrupted."""
    ref = tmp_path / "ref"
    ref.mkdir()
    ref_state = run(small_config(radius=8.0), out=ref)
    out = tmp_path / "run"
    out.mkdir()
    script = SIGTERM_SCRIPT.format(root=str(Path(__file__).resolve().parents[2]), out=str(out))
    proc = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 120
        while not (out / "fields" / "frame_00002.vtu").exists():  # stepping, t >= 1
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGTERM)
        status = proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert status == 128 + signal.SIGTERM
    assert (out / CHECKPOINT).is_file()
    assert not (out / "boundary.csv").exists()
    state = run(small_config(radius=8.0), out=out)
    assert_same_run((ref, ref_state), out, state)
