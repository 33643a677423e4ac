"""Checkpoints and frames that nothing can corrupt unnoticed (continuum.checkpoint, .output).

The catalogue of damaged checkpoints (the particle engine's, with this engine's entries), each
refused with one CheckpointError line naming the file, the run folder untouched; the previous
checkpoint taking over from a damaged one with the bytes of an uninterrupted run; frame names
made by the code, whatever a checkpoint says; frames removed only by their exact names, never
through a link; a checkpoint whose metadata does not grow with the steps; the free-space
reserve; checkpoints of the previous version resuming.

SMALL (conftest.py) writes frames after steps 3, 5, 7, 9, 12, 14 and 17 of its 21; the run
stopped here checkpoints after steps 8 (then checkpoint.prev.npz) and 15 (checkpoint.npz).
"""

import errno
import json
import logging
import shutil
from pathlib import Path

import numpy as np
import pytest

import continuum.runfiles as runfiles
import particles
from continuum import Simulation, run
from continuum.checkpoint import checkpoint_config, load_checkpoint
from continuum.output import remove_frames_from
from continuum.runfiles import (
    CHECKPOINT,
    PREVIOUS,
    RESERVE_BYTES,
    CheckpointError,
    NotCheckpointError,
)
from tests.particles.test_checkpoint_safety import (
    BYTES,
    assert_not_a_checkpoint,
    assert_one_line,
    no_checkpoint,
    rewrite,
)

from .conftest import small_config
from .test_restart import assert_same_run

STOPS = (8, 15)
"""Steps after which the stopped run checkpoints."""


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run of SMALL: (folder, returned simulation)."""
    out = tmp_path_factory.mktemp("reference")
    return out, run(small_config(), out=out)


@pytest.fixture(scope="module")
def stopped(tmp_path_factory):
    """SMALL stopped after steps 8 and 15: checkpoint.prev.npz and checkpoint.npz."""
    out = tmp_path_factory.mktemp("stopped")
    run(small_config(), out=out, max_steps=STOPS[0])
    run(small_config(), out=out, max_steps=STOPS[1] - STOPS[0])
    return out


@pytest.fixture
def folder(stopped, tmp_path):
    """A copy of the stopped run."""
    out = tmp_path / "run"
    shutil.copytree(stopped, out, symlinks=True)
    return out


def legacy(meta_change):
    """A change: an earlier version's checkpoint (no checksum) with ``meta_change(meta)``."""

    def change(arrays):
        del arrays["sha256"]
        meta = json.loads(str(arrays["meta"]))
        meta_change(meta)
        arrays["meta"] = np.array(json.dumps(meta))

    return change


ENTRIES = {
    "an entry missing": lambda a: a.pop("points"),
    "an entry missing, no checksum": lambda a: (a.pop("sha256"), a.pop("tris")),
    "an object array": lambda a: a.update(extra=np.array([{"a": 1}], dtype=object)),
    "an array changed": lambda a: a.update(G=a["G"] * 2),
    "triangles out of range, no checksum": lambda a: (a.pop("sha256"),
                                                      a.update(tris=a["tris"] + 10**6)),
    "fields of another length, no checksum": lambda a: (a.pop("sha256"),
                                                        a.update(p=a["p"][:-1])),
    "frame times of another shape, no checksum": lambda a: (
        a.pop("sha256"), a.update(frame_times=a["frame_times"][:, None])),
    "meta not JSON, no checksum": lambda a: (a.pop("sha256"), a.update(meta=np.array("{"))),
    "colony scalars missing, no checksum": legacy(lambda m: m.pop("colony")),
    "done not a bool, no checksum": legacy(lambda m: m.update(done="yes")),
    "history not rows, no checksum": legacy(lambda m: m.update(history=5)),
}


def damage(path: Path, kind: str) -> None:
    """Damage the checkpoint at ``path`` as ``kind`` (a key of BYTES or ENTRIES)."""
    if kind in BYTES:
        path.write_bytes(BYTES[kind](path.read_bytes()))
    else:
        rewrite(path, ENTRIES[kind])


def tree(folder: Path) -> dict:
    """Every file of a folder, checkpoints aside, with its bytes."""
    return {p: p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and not p.name.startswith("checkpoint")}


@pytest.mark.parametrize("kind", [*BYTES, *ENTRIES])
def test_a_damaged_checkpoint_is_refused_in_one_line(folder, kind):
    path = folder / CHECKPOINT
    (folder / PREVIOUS).unlink()
    damage(path, kind)
    before = tree(folder)
    for attempt in (lambda: load_checkpoint(path, small_config()), lambda: Simulation.load(path),
                    lambda: run(small_config(), out=folder)):
        with pytest.raises(CheckpointError) as err:
            attempt()
        assert_one_line(err, path)
    assert tree(folder) == before


@pytest.mark.parametrize("name", ["history.csv", "config.json", "fields.pvd", "fields",
                                  "data.npz", "notes.zip"])
def test_a_file_that_is_no_checkpoint_is_not_called_damaged(folder, name):
    """Issue 54: Simulation.load(history.csv) said "damaged ... remove it" of good data."""
    path = no_checkpoint(folder, name)
    before = tree(folder)
    for load in (lambda: Simulation.load(path), lambda: load_checkpoint(path, small_config()),
                 lambda: checkpoint_config(path)):
        with pytest.raises(NotCheckpointError) as err:
            load()
        assert_not_a_checkpoint(err, path, "continuum")
    assert tree(folder) == before


def test_a_checkpoint_of_the_other_engine_is_named_as_such(folder, tmp_path):
    """Issue 54: a particle checkpoint given to the continuum was "a removed transport"."""
    theirs = tmp_path / "p"
    theirs.mkdir()
    particle_config = particles.Config(lam=1e-2, time=1.0, dt=0.02, seed=3)
    particles.run(particle_config, theirs, max_steps=2)
    saved = particles.Simulation(particle_config).save(tmp_path / "p.npz")
    for path in (theirs / CHECKPOINT, saved):
        for load in (Simulation.load, checkpoint_config):
            with pytest.raises(NotCheckpointError) as err:
                load(path)
            assert str(err.value) == (f"{path} is a particles checkpoint, not a continuum one "
                                      "(particles.Simulation.load reads it)")
    with pytest.raises(NotCheckpointError, match="is a particles checkpoint, not a continuum"):
        run(small_config(), out=theirs)
    ours = folder / CHECKPOINT
    for load in (lambda: particles.Simulation.load(ours),
                 lambda: particles.run(particle_config, folder)):
        with pytest.raises(particles.runfiles.NotCheckpointError) as err:
            load()
        assert str(err.value) == (f"{ours} is a continuum checkpoint, not a particles one "
                                  "(continuum.Simulation.load reads it)")


def test_history_that_does_not_match_the_checkpoint_is_refused(folder):
    (folder / PREVIOUS).unlink()
    history = folder / "history.csv"
    history.write_bytes(history.read_bytes()[:-300])
    with pytest.raises(CheckpointError) as err:
        run(small_config(), out=folder)
    assert_one_line(err, history, folder / CHECKPOINT)


@pytest.mark.parametrize("fault", ["damaged", "missing", "a link"])
def test_previous_checkpoint_takes_over_with_the_uninterrupted_bytes(folder, reference, caplog,
                                                                    tmp_path, fault):
    """checkpoint.npz unusable: the run resumes from checkpoint.prev.npz (step 8).

    The history rows and the three frames written after step 8 are dropped, and the finished
    run equals the uninterrupted one byte for byte.
    """
    path = folder / CHECKPOINT
    if fault == "damaged":
        damage(path, "bytes zeroed")
    elif fault == "missing":
        path.unlink()
    else:  # a link to an intact checkpoint elsewhere is not read
        path.rename(tmp_path / "elsewhere.npz")
        path.symlink_to(tmp_path / "elsewhere.npz")
        elsewhere = path.resolve().read_bytes()
    assert len(list((folder / "fields").iterdir())) == 7
    with caplog.at_level(logging.WARNING, logger="continuum.checkpoint"):
        state = run(small_config(), out=folder)
    assert f"resuming from {folder / PREVIOUS}" in caplog.text
    if fault == "a link":  # the new checkpoint replaced the link, not its target
        assert (tmp_path / "elsewhere.npz").read_bytes() == elsewhere
    assert_same_run(reference, folder, state)


def test_both_checkpoints_damaged_are_named(folder):
    damage(folder / CHECKPOINT, "tail cut")
    damage(folder / PREVIOUS, "an array changed")
    with pytest.raises(CheckpointError) as err:
        run(small_config(), out=folder)
    assert_one_line(err, folder / CHECKPOINT, folder / PREVIOUS)


CRAFTED = 'fields/frame_00001.vtu"/><DataSet timestep="9" file="../victim.vtu'
"""A frame name of a crafted checkpoint: XML for fields.pvd, a file outside the run folder."""


@pytest.mark.parametrize("names", ["as written", "crafted"])
def test_checkpoint_of_the_previous_version_resumes_names_made_by_the_code(folder, reference,
                                                                           tmp_path, names):
    """A checkpoint as the previous version wrote it: history rows and (t, file) frames in meta.

    It resumes to the uninterrupted bytes; its frame names are not used (crafted ones neither
    reach fields.pvd nor make the resume delete or keep other files).
    """
    path = folder / CHECKPOINT
    (folder / PREVIOUS).unlink()
    rows = Simulation.load(path).history
    with np.load(path) as z:
        times = z["frame_times"].tolist()
    frames = [[t, f"fields/frame_{k:05d}.vtu" if names == "as written" else CRAFTED]
              for k, t in enumerate(times)]
    rewrite(path, legacy(lambda meta: meta.update(history=rows, frames=frames)))
    rewrite(path, lambda a: a.pop("frame_times"))
    victim = tmp_path / "victim.vtu"
    victim.write_text("not colony's")
    state = run(small_config(), out=folder)
    assert victim.read_text() == "not colony's"
    assert "victim" not in (folder / "fields.pvd").read_text()
    assert_same_run(reference, folder, state)


def test_later_frames_are_removed_by_their_exact_names_only(tmp_path):
    """Frames from index 2 on and temporary frames go; other names stay; links are not followed."""
    out, elsewhere = tmp_path / "run", tmp_path / "elsewhere"
    fields = out / "fields"
    fields.mkdir(parents=True)
    elsewhere.mkdir()
    (elsewhere / "frame_00003.vtu").write_text("outside")
    for name in ("frame_00000.vtu", "frame_00001.vtu", "frame_00002.vtu", "frame_00004.vtu",
                 "frame_00001.vtu.tmp", "frame_0002.vtu", "frame_000005.vtu", "xframe_00006.vtu",
                 "frame_00007.vtu.bak", "notes.txt"):
        (fields / name).write_text(name)
    (fields / "frame_00003.vtu").symlink_to(elsewhere / "frame_00003.vtu")
    remove_frames_from(out, 2)
    assert sorted(p.name for p in fields.iterdir()) == sorted([
        "frame_00000.vtu", "frame_00001.vtu", "frame_0002.vtu", "frame_000005.vtu",
        "xframe_00006.vtu", "frame_00007.vtu.bak", "notes.txt"])
    assert (elsewhere / "frame_00003.vtu").read_text() == "outside"
    (fields / "frame_00009.vtu").mkdir()
    with pytest.raises(ValueError, match="frame_00009.vtu is not a frame file"):
        remove_frames_from(out, 2)


def test_fields_as_a_link_is_refused(folder, tmp_path):
    """``fields`` a link to another folder: one line naming it; nothing there deleted or added."""
    elsewhere = tmp_path / "elsewhere"
    (folder / "fields").rename(elsewhere)
    (folder / "fields").symlink_to(elsewhere)
    before = tree(elsewhere)
    with pytest.raises(ValueError, match=r"fields is a symbolic link") as err:
        run(small_config(), out=folder)
    assert "\n" not in str(err.value)
    assert tree(elsewhere) == before


def test_checkpoint_metadata_does_not_grow_with_the_steps(tmp_path):
    """After 5 and after 20 steps the checkpoint's meta has the same length (history.csv grows)."""
    lengths = []
    for steps in (5, 15):
        run(small_config(), out=tmp_path, max_steps=steps)
        with np.load(tmp_path / CHECKPOINT) as z:
            lengths.append(len(str(z["meta"])))
    assert abs(lengths[1] - lengths[0]) < 50
    assert (tmp_path / "history.csv").stat().st_size > 20 * 150


def test_a_full_disk_stops_the_run_with_its_checkpoint_intact(reference, tmp_path, monkeypatch):
    """Less than the reserve free after some writes: ENOSPC before any write, then a resume.

    The checkpoint is written after every step (checkpoint_seconds = 0); the run resumes from
    the last one once there is space again and ends as the uninterrupted run.
    """
    real, calls = shutil.disk_usage, [0]

    def filling(path):
        calls[0] += 1
        return real(path)._replace(free=2**40 if calls[0] < 12 else RESERVE_BYTES)

    monkeypatch.setattr(runfiles.shutil, "disk_usage", filling)
    with pytest.raises(OSError) as err:
        run(small_config(checkpoint_seconds=0.0), out=tmp_path)
    assert err.value.errno == errno.ENOSPC and "no space left on" in str(err.value)
    assert load_checkpoint(tmp_path / CHECKPOINT).state.step > 0
    assert not list(tmp_path.rglob("*.tmp*"))
    monkeypatch.setattr(runfiles.shutil, "disk_usage", real)
    state = run(small_config(checkpoint_seconds=0.0), out=tmp_path)
    assert_same_run(reference, tmp_path, state, skip=("config.json",))


def test_a_checkpoint_of_the_former_step_limit_name_loads(folder):
    """A checkpoint from before Config.step_limit (``max_steps`` in its config) loads as it."""
    path = folder / CHECKPOINT
    expected = load_checkpoint(path).config

    def renamed(meta):
        meta["config"]["max_steps"] = meta["config"].pop("step_limit")

    rewrite(path, legacy(renamed))
    assert "max_steps" in json.loads(str(np.load(path)["meta"]))["config"]
    assert load_checkpoint(path).config == expected
