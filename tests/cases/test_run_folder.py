"""The run folder as a safe container (issue 28): one writer, no links, nothing outside touched.

Every test checks the exit status, the one-line message and that every file outside the run
folder is byte-identical afterwards (:func:`snapshot` of the neighbours before and after).
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cases import cli, rundir
from tests.cases.test_faults import SMALL_CONTINUUM, SMALL_PARTICLES, one_line_error


def snapshot(folder: Path) -> dict:
    """Every entry under ``folder`` (links as their targets, not followed) with its bytes."""
    found = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = Path(root) / name
            key = path.relative_to(folder)
            if path.is_symlink():
                found[key] = ("link", os.readlink(path))
            elif path.is_file():
                found[key] = path.read_bytes()
    return found


def published(folder: Path) -> dict:
    """The bytes of a published run, but its provenance (times, process)."""
    return {k: v for k, v in snapshot(folder).items() if k.name != rundir.RECORD}


@pytest.fixture
def neighbour(tmp_path):
    """A user's folder beside the runs, with files colony must never touch."""
    folder = tmp_path / "mine"
    (folder / "fields").mkdir(parents=True)
    (folder / "fields" / "frame_00000.vtu").write_text("my frame")
    (folder / "notes.txt").write_text("precious")
    (folder / "history.csv").write_text("t,radius\n0,1\n")
    return folder


# --------------------------------------------------------------------------- one writer


def _launch(out: Path, radius="8"):
    return subprocess.Popen(
        [sys.executable, "-m", "cases.cli", *SMALL_PARTICLES[:3], "--radius", radius,
         "--out", str(out), "--quiet"], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
        text=True)


def test_two_runs_on_one_folder_one_is_refused(tmp_path, colony):
    """Two identical runs started within milliseconds, three times.

    Exactly one runs, and what it publishes equals a run made alone, byte for byte (the run
    alone made in this process: the same command, without a process start's seconds).
    """
    solo = tmp_path / "solo"
    status, err = colony(*SMALL_PARTICLES[:3], "--radius", "8", "--out", str(solo), "--quiet")
    assert status == 0, err
    for attempt in range(3):
        out = tmp_path / f"run{attempt}"
        a, b = _launch(out), _launch(out)
        results = [(p.wait(timeout=300), p.stderr.read()) for p in (a, b)]
        statuses = sorted(status for status, _ in results)
        assert statuses == [0, 2], results
        err = next(err for status, err in results if status == 2)
        assert err.count("\n") == 1 and err.startswith("colony: error:"), err
        assert "is in use by" in err or "exists" in err, err
        assert published(out) == published(solo)
        assert not rundir.partial_of(out).exists()


def test_a_held_folder_is_refused_and_named(tmp_path):
    folder = tmp_path / "run.partial"
    folder.mkdir()
    rundir.write_record(folder, {"sessions": [{"pid": 4242, "start": "T0",
                                                "status": "running"}]})
    with rundir.hold(folder):
        assert rundir.is_held(folder)
        with pytest.raises(rundir.FolderInUseError, match="in use by process 4242 since T0"):
            with rundir.hold(folder):
                pass
    assert not rundir.is_held(folder)


def test_run_into_a_held_stage_is_refused(colony, tmp_path):
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    partial.mkdir()
    with rundir.hold(partial):
        status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "is in use by")
    assert not any(partial.iterdir()) and not out.exists()


def test_a_stage_taken_by_another_run_before_the_lock_is_left_to_it(colony, tmp_path,
                                                                   monkeypatch):
    """A run creates ``DIR.partial``; another locks it first: refused, and the stage stays.

    The race of ``test_two_runs_on_one_folder_one_is_refused`` made deterministic: the loser
    used to remove the (empty) stage it had created from under the winner.
    """
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    real_hold, winner = rundir.hold, []

    def contested(folder, wait=False):
        if not winner:
            winner.append(real_hold(folder))
            winner[0].__enter__()  # the other run takes the lock first
        return real_hold(folder, wait)

    monkeypatch.setattr(rundir, "hold", contested)
    status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "is in use by")
    assert partial.is_dir() and not out.exists()
    winner[0].__exit__(None, None, None)


def test_a_stage_published_by_another_run_before_the_lock_says_it_exists(colony, tmp_path,
                                                                       monkeypatch):
    """Another run publishes ``DIR.partial`` as ``DIR`` between this run's checks and its lock."""
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    partial.mkdir()
    real_hold = rundir.hold

    def published_first(folder, wait=False):
        if folder == partial:
            rundir.write_record(partial, {"sessions": []})
            partial.rename(out)  # the other run's publish
        return real_hold(folder, wait)

    monkeypatch.setattr(rundir, "hold", published_first)
    status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "exists")
    assert out.is_dir() and not partial.exists()


def test_a_folder_replaced_before_the_lock_is_refused(tmp_path, monkeypatch):
    """The folder at the path is no longer the one opened: the lock would guard nothing."""
    folder = tmp_path / "run.partial"
    folder.mkdir()
    real_flock = rundir.fcntl.flock

    def replace_then_lock(fd, how):
        folder.rename(tmp_path / "published")
        folder.mkdir()
        return real_flock(fd, how)

    monkeypatch.setattr(rundir.fcntl, "flock", replace_then_lock)
    with pytest.raises(rundir.FolderInUseError, match="took it up just now"):
        with rundir.hold(folder):
            pass


def test_info_tells_a_dead_run_from_a_live_one(capsys, tmp_path):
    out = tmp_path / "run"
    proc = _launch(out, radius="30")
    partial = rundir.partial_of(out)
    deadline = time.monotonic() + 120
    while not (partial / "trajectory.gsd").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert cli.main(["info", str(out)]) == 0
    assert "status          running" in capsys.readouterr().out
    proc.kill()
    proc.wait(timeout=60)
    assert json.loads((partial / "run.json").read_text())["status"] == "running"
    assert cli.main(["info", str(out)]) == 0
    assert "status          died" in capsys.readouterr().out


# --------------------------------------------------------------------------- links


@pytest.mark.parametrize("entry", ["fields", "history.csv", "config.json"])
def test_link_in_a_stopped_continuum_stage_is_refused(colony, tmp_path, neighbour, entry):
    out = tmp_path / "run"
    assert colony(*SMALL_CONTINUUM, "--out", str(out))[0] == 0
    partial = rundir.partial_of(out)
    out.rename(partial)  # a stage as a stopped run leaves it
    target = partial / entry
    if target.is_dir():
        for p in target.iterdir():
            p.unlink()
        target.rmdir()
    else:
        target.unlink()
    target.symlink_to(neighbour / entry if entry != "config.json" else neighbour / "notes.txt")
    before = snapshot(neighbour)
    status, err = colony(*SMALL_CONTINUUM, "--out", str(out))
    one_line_error(status, err, f"{entry} is a symbolic link")
    assert snapshot(neighbour) == before and target.is_symlink()
    # --overwrite removes the link, never what it points to
    assert colony(*SMALL_CONTINUUM, "--out", str(out), "--overwrite")[0] == 0
    assert snapshot(neighbour) == before and not (out / entry).is_symlink()


def particle_stage_with_link(tmp_path, neighbour, name):
    """A stopped particle stage DIR.partial holding a link ``name`` to a file outside; DIR."""
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    partial.mkdir()
    (partial / "config.json").write_text("{}")
    (partial / name).symlink_to(neighbour / "notes.txt")
    return out


def test_link_in_a_stopped_particle_stage_is_refused(colony, tmp_path, neighbour):
    out = particle_stage_with_link(tmp_path, neighbour, "trajectory.gsd")
    before = snapshot(neighbour)
    status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "trajectory.gsd is a symbolic link")
    assert snapshot(neighbour) == before


def test_foreign_link_in_a_stage_is_not_offered_overwrite(colony, tmp_path, neighbour):
    """A link colony did not write: the line says to remove it, and --overwrite refuses it too."""
    out = particle_stage_with_link(tmp_path, neighbour, "notes")
    partial = rundir.partial_of(out)
    before = snapshot(neighbour)
    status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "notes is a symbolic link")
    assert "colony did not write it" in err and "--overwrite" not in err
    status, err = colony(*SMALL_PARTICLES, "--out", str(out), "--overwrite")
    one_line_error(status, err, "did not write")
    assert snapshot(neighbour) == before and (partial / "notes").is_symlink()


def test_out_as_a_link_to_another_run_is_refused(colony, tmp_path):
    other = tmp_path / "other"
    assert colony(*SMALL_CONTINUUM, "--out", str(other))[0] == 0
    link = tmp_path / "link"
    link.symlink_to(other)
    before = snapshot(tmp_path)
    for extra in ((), ("--overwrite",)):
        status, err = colony(*SMALL_CONTINUUM, "--out", str(link), *extra)
        one_line_error(status, err, "is a symbolic link")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("kind", ["dangling", "loop", "long", "too-long", "stage-link"])
def test_unusable_out_fails_before_any_work(colony, tmp_path, kind, monkeypatch):
    out = tmp_path / "run"
    if kind == "dangling":
        out.symlink_to(tmp_path / "nowhere")
    elif kind == "loop":
        out.symlink_to(tmp_path / "loop2")
        (tmp_path / "loop2").symlink_to(out)
    elif kind == "long":  # fits the file system, DIR.replaced does not
        out = tmp_path / ("x" * 250)
    elif kind == "too-long":  # not even a name the file system can look up
        out = tmp_path / ("x" * 300)
    else:
        rundir.partial_of(out).symlink_to(tmp_path)
    before = snapshot(tmp_path)
    ran = []
    monkeypatch.setattr("particles.run", lambda *a, **k: ran.append(1))
    status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "name too long" if "long" in kind else "")
    assert "Errno" not in err and not ran and snapshot(tmp_path) == before


def test_publish_never_deletes_through_a_replaced_link(tmp_path):
    """A finished stage published over a ``DIR`` that became a link during the run."""
    stage = tmp_path / "run.partial"
    stage.mkdir()
    rundir.write_record(stage, {"engine": "particles"})
    (stage / "history.csv").write_text("t\n0\n")
    other = tmp_path / "other"
    other.mkdir()
    (other / "history.csv").write_text("theirs")
    (tmp_path / "run").symlink_to(other)
    with pytest.raises(rundir.RunFolderError, match="symbolic link"):
        rundir.publish(stage)
    assert (other / "history.csv").read_text() == "theirs" and stage.is_dir()


# --------------------------------------------------------------------------- signals


def test_sighup_stops_like_sigterm(tmp_path):
    out = tmp_path / "run"
    proc = _launch(out, radius="30")
    partial = rundir.partial_of(out)
    deadline = time.monotonic() + 120
    while not (partial / "trajectory.gsd").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)
    proc.send_signal(signal.SIGHUP)
    err = proc.communicate(timeout=120)[1]
    if proc.returncode == 0:
        pytest.skip("the run finished before the signal")
    assert proc.returncode == 129, err
    assert err.count("\n") == 1 and "give the same command to resume" in err
    record = json.loads((partial / "run.json").read_text())
    assert record["status"] == "stopped" and record["error"] == "stopped by SIGHUP"
    assert (partial / "checkpoint.npz").exists()


def test_a_field_added_later_with_an_empty_default_changes_nothing():
    """A run recorded before a Config field existed resumes when the field is empty now."""
    saved = {"lam": 0.01, "radius": 40.0}
    assert rundir.config_differences(saved, {**saved, "strains": []}) == []
    assert rundir.config_differences(saved, {**saved, "strains": [[0.0, 1.0]]}) == ["strains"]
    assert rundir.config_differences({**saved, "strains": [[0.0, 1.0]]}, {**saved, "strains": []}
                                     ) == ["strains"]
    # a tuple (a Config's value) equals the list its JSON record holds
    assert rundir.config_differences({**saved, "strains": [[0.0, 1.0]]},
                                     {**saved, "strains": ((0.0, 1.0),)}) == []
