"""Runs in legs: a hard kill at any write, ``--max-hours`` pauses, and the engine version.

A run killed with SIGKILL (power loss, the OOM killer) at any of its writes, then given the
same command, ends with the files of an uninterrupted run, byte for byte (run.json aside, the
record of its sessions); a chain of legs paused by ``--max-hours`` too; a checkpoint is resumed
only by the version of the engine that wrote it, unless asked.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cases import cli, rundir

KILLPOINT = Path(__file__).resolve().parent.parent / "killpoint.py"

RUNS = {  # a checkpoint after every step, frames often: every kind of write, many times over
    "continuum": ("continuum", "--lam", "1e-2", "--radius", "3", "--quiet",
                  "--set", "n_nodes=200", "--set", "checkpoint_seconds=0"),
    "particles": ("particles", "--lam", "1e-2", "--time", "0.4", "--quiet",
                  "--set", "checkpoint_seconds=0", "--set", "output_every=0.06"),
}


def files(folder: Path) -> dict:
    """Every file of a run folder with its bytes, run.json aside (sessions, times).

    config.json without ``max_hours``: an execution setting each leg gives anew (its legs'
    values are in run.json's commands).
    """
    out = {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*"))
           if p.is_file() and p.name != rundir.RECORD}
    config = json.loads(out.pop(Path("config.json")))
    config.pop("max_hours")
    return out | {Path("config.json"): config}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run of each engine: {engine: files}."""
    out = {}
    for engine, args in RUNS.items():
        folder = tmp_path_factory.mktemp(engine) / "run"
        assert cli.main([*args, "--out", str(folder)]) == 0
        out[engine] = files(folder)
    return out


def kill_and_resume(engine: str, name: str, k: int, mode: str, out: Path) -> int:
    """SIGKILL the run at its k-th write of ``name`` (tests/killpoint.py), then resume it.

    Returns the killed process's exit status (-9: killed; 0: it had fewer writes).
    """
    args = [*RUNS[engine], "--out", str(out)]
    killed = subprocess.run([sys.executable, str(KILLPOINT), name, str(k), mode, *args],
                            capture_output=True, text=True, timeout=600)
    if killed.returncode == 0:
        return 0
    assert killed.returncode == -9, killed.stderr
    assert cli.main(args) == 0
    return -9


# A kill in the middle of writing each kind of file (torn), with the file written but not
# renamed, and just after the rename; the full sweep over every write is the slow test below.
POINTS = [
    ("continuum", "frame_", 3, "torn"), ("continuum", "checkpoint.npz", 2, "written"),
    ("continuum", "history.csv", 3, "renamed"), ("continuum", "fields.pvd", 2, "torn"),
    ("particles", "trajectory", 2, "torn"), ("particles", "checkpoint.npz", 3, "torn"),
    ("particles", "history.csv", 2, "written"), ("particles", "particles.csv", 1, "torn"),
]


@pytest.mark.parametrize("engine,name,k,mode", POINTS)
def test_a_hard_kill_then_the_same_command_gives_the_uninterrupted_run(
        reference, tmp_path, engine, name, k, mode):
    out = tmp_path / "run"
    assert kill_and_resume(engine, name, k, mode, out) == -9
    assert files(out) == reference[engine]
    assert json.loads((out / rundir.RECORD).read_text())["status"] == "finished"


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["torn", "written", "renamed"])
@pytest.mark.parametrize("engine", list(RUNS))
def test_a_hard_kill_at_every_write(reference, tmp_path, engine, mode):
    k = 0
    while True:
        k += 1
        out = tmp_path / f"run{k}"
        if kill_and_resume(engine, "", k, mode, out) == 0:
            break
        assert files(out) == reference[engine], f"killed at write {k}"
    assert k > 20  # it did reach the checkpoints, the frames and the final files


def test_the_temporary_files_of_a_killed_run_are_its_own(tmp_path):
    partial = tmp_path / "run.partial"
    (partial / "fields").mkdir(parents=True)
    (partial / "config.json").write_text("{}")
    for name in ("fields/frame_00003.vtu.tmp", "fields/frame_00002.vtu",
                 "checkpoint.npz.tmp.npz", "history.csv.tmp", "trajectory.gsd.tmp"):
        (partial / name).write_text("")
    assert rundir.foreign_entries(partial) == []
    (partial / "fields" / "notes.txt").write_text("")
    assert rundir.foreign_entries(partial) == ["fields/notes.txt"]


# --------------------------------------------------------------------------- --max-hours


def test_a_chain_of_three_legs_equals_one_uninterrupted_run(colony, tmp_path):
    """Three steps, three legs: each leg pauses after its first step (the limit passed at once).

    Each exits with PAUSED_STATUS but the last; then the files are those of one run.
    """
    args = ["particles", "--lam", "1e-2", "--time", "0.06", "--quiet"]
    assert colony(*args, "--out", str(tmp_path / "one"))[0] == 0
    legs = []
    while True:
        status, err = colony(*args, "--out", str(tmp_path / "legs"), "--max-hours", "1e-9")
        legs.append(status)
        if status != rundir.PAUSED_STATUS:
            break
        assert err.count("\n") == 1 and "paused at max_hours = 1e-09" in err
        assert "give the same command to resume" in err, err
        record = json.loads((rundir.partial_of(tmp_path / "legs") / rundir.RECORD).read_text())
        assert record["status"] == "paused" and record["sessions"][-1]["status"] == "paused"
    assert legs == [rundir.PAUSED_STATUS] * 2 + [0]
    assert files(tmp_path / "legs") == files(tmp_path / "one")


def test_a_continuum_chain_equals_one_uninterrupted_run(reference, colony, tmp_path):
    out = tmp_path / "legs"
    statuses = [colony(*RUNS["continuum"], "--out", str(out), "--max-hours", "1e-9")[0]
                for _ in range(3)]
    assert statuses == [rundir.PAUSED_STATUS] * 3
    assert colony(*RUNS["continuum"], "--out", str(out))[0] == 0
    assert files(out) == reference["continuum"]


def test_a_run_within_its_limit_does_not_pause(colony, tmp_path):
    status, _ = colony(*RUNS["particles"], "--out", str(tmp_path / "run"), "--max-hours", "1")
    assert status == 0


@pytest.mark.parametrize("value", ["0", "-1", "inf", "nan"])
def test_max_hours_must_be_positive_and_finite(colony, tmp_path, value):
    status, err = colony(*RUNS["particles"], "--out", str(tmp_path / "run"),
                         f"--max-hours={value}")
    assert status == 2 and err.count("\n") == 1 and "max" in err and "hours" in err, err
    assert not (tmp_path / "run.partial").exists()


def test_the_limit_counts_the_next_step_and_checkpoint():
    from particles.runfiles import WallLimit

    limit = WallLimit(1.0)
    assert not limit.due  # no step yet: the first step is always taken
    limit.start -= 3600 - 25  # 25 s left
    limit.steps.append(10.0)  # a step takes 10 s: 2 x 10 + 2 x 10 (no checkpoint yet) > 25
    assert limit.due
    limit.saved(1.0)  # a checkpoint takes 1 s: 2 x 10 + 2 x 1 < 25 - a little
    assert not limit.due
    assert not WallLimit(None).due


# --------------------------------------------------------------------------- engine version


def test_a_checkpoint_of_another_engine_version_is_refused_unless_asked(colony, tmp_path,
                                                                        monkeypatch):
    args = ["particles", "--lam", "1e-2", "--time", "0.06", "--quiet",
            "--out", str(tmp_path / "run")]
    assert colony(*args, "--max-hours", "1e-9")[0] == rundir.PAUSED_STATUS
    made = rundir.engine_sources("particles")
    monkeypatch.setattr(rundir, "engine_sources", lambda engine: "0123456789abcdef")
    status, err = colony(*args)
    assert status == 2 and err.count("\n") == 1, err
    assert f"another version of the particles engine (engine sources {made}" in err
    assert "this one: 0123456789abcdef" in err and "--other-engine" in err
    assert colony(*args, "--other-engine")[0] == 0
    sessions = json.loads((tmp_path / "run" / rundir.RECORD).read_text())["sessions"]
    assert [s["engine_sources"] for s in sessions] == [made, "0123456789abcdef"]


def test_the_engine_version_is_the_digest_of_its_sources():
    assert rundir.engine_sources("particles") != rundir.engine_sources("continuum")
    assert len(rundir.engine_sources("particles")) == 16


def test_a_sweep_resumes_its_paused_runs(tmp_path):
    """Runs of a sweep that pause at max_hours are submitted again until they finish."""
    from cases.sweep import run_engine, sweep

    points = [{"engine": "particles", "lam": lam, "time": 0.06} for lam in (1e-2, 0.0)]
    folders = sweep(run_engine, points, tmp_path, n_workers=1, progress=False, max_hours=1e-9)
    for folder in folders:
        record = json.loads((folder / rundir.RECORD).read_text())
        assert record["status"] == "finished"
        assert [s["status"] for s in record["sessions"]] == ["paused", "paused", "finished"]


# --------------------------------------------------------------------------- colony info


def test_the_projection_of_an_exact_power_law():
    """Work C(R) = R^3 exactly: the exponent 3, and from R = 100 to 200 seven times the wall."""
    from cases.standing import projected_wall

    R = np.linspace(10, 100, 91)
    cost = R**3
    work = np.diff(np.concatenate([[0.0], cost]))  # per step: C is their sum
    history = {"radius": R, "n_contacts": work - 1, "iterations": np.zeros_like(R)}
    wall, a = projected_wall(history, "radius", 200.0, wall=3600.0)
    assert a == pytest.approx(3.0, rel=1e-12)
    assert wall == pytest.approx(7 * 3600.0, rel=1e-10)
    assert projected_wall({k: v[:5] for k, v in history.items()}, "radius", 200.0, 3600) is None


def test_info_says_where_a_paused_run_stands(colony, capsys, tmp_path):
    out = tmp_path / "run"
    args = ["particles", "--lam", "1e-2", "--radius", "3", "--quiet", "--out", str(out)]
    assert colony(*args, "--max-hours", "1e-9")[0] == rundir.PAUSED_STATUS
    assert cli.main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "status          paused" in text
    assert "stands at       radius 0.5101 of 3, 1 cell, t = 0.02, step 1; wall spent" in text
    assert " s in 1 session\n" in text  # one session, one cell: the singular; seconds


def test_durations_read_as_people_read_them():
    from cases.standing import duration

    assert [duration(s) for s in (0.004, 40, 750, 11_556)] == ["0 s", "40 s", "12.5 min",
                                                               "3.21 h"]


def test_info_of_a_run_that_died_before_its_first_checkpoint(colony, capsys, tmp_path):
    """A dead run with no checkpoint is not offered a resume: its command starts afresh."""
    out = tmp_path / "run"
    stage = rundir.partial_of(out)
    assert colony("particles", "--lam", "1e-2", "--radius", "3", "--quiet", "--out", str(out),
                  "--max-hours", "1e-9")[0] == rundir.PAUSED_STATUS
    record = json.loads((stage / rundir.RECORD).read_text())
    (stage / rundir.RECORD).write_text(json.dumps(record | {"status": "running"}))
    assert cli.main(["info", str(out)]) == 0
    assert "give its command to resume it from the last checkpoint" in capsys.readouterr().out
    for name in rundir.CHECKPOINTS:
        (stage / name).unlink(missing_ok=True)
    assert cli.main(["info", str(out)]) == 0
    assert "give its command to start it afresh (it wrote no checkpoint)" in \
        capsys.readouterr().out


# --------------------------------------------------------------------------- carry


def test_a_paused_run_carried_without_its_trajectory_resumes(colony, tmp_path):
    """pack, unpack on "another machine", the same command: the uninterrupted run's results.

    The history and the final state are the uninterrupted run's; the trajectory restarts at
    the leg's first frame.
    """
    from cases import carry

    args = ["particles", "--lam", "1e-2", "--time", "0.3", "--quiet", "--set", "output_every=0.06"]
    assert colony(*args, "--out", str(tmp_path / "one"))[0] == 0
    here = tmp_path / "here" / "run"
    while colony(*args, "--out", str(here), "--max-hours", "1e-9")[0] == rundir.PAUSED_STATUS:
        if len(json.loads((rundir.partial_of(here) / "run.json").read_text())["sessions"]) == 4:
            break
    record = carry.pack(rundir.partial_of(here), tmp_path / "repo" / "resume")
    assert record["cells"] >= 1 and record["step"] == 4
    assert sorted(p.name for p in (tmp_path / "repo" / "resume").iterdir()) == sorted(
        [*(name + carry.COMPRESSED.get(name, "") for name in carry.RESUME_FILES), carry.CARRY])
    there = tmp_path / "there" / "run"
    carry.unpack(tmp_path / "repo" / "resume", there)
    for name in carry.RESUME_FILES:
        assert (rundir.partial_of(there) / name).read_bytes() == \
            (rundir.partial_of(here) / name).read_bytes(), name
    assert colony(*args, "--out", str(there))[0] == 0
    one, carried = files(tmp_path / "one"), files(there)
    for name in ("history.csv", "particles.csv", "profile.csv"):
        assert carried[Path(name)] == one[Path(name)], name
    with pytest.raises(ValueError, match="exists; move it away first"):
        carry.unpack(tmp_path / "repo" / "resume", there)


def test_carry_reads_an_uncompressed_state_and_refuses_a_damaged_one(tmp_path, capsys):
    """Old folders (the checkpoint stored as it is) unpack; a damaged one is refused.

    The refusal is one line, and nothing is left behind; so is packing a held stage.
    """
    import hashlib

    from cases import carry

    stage = tmp_path / "run.partial"
    stage.mkdir()
    np.savez(stage / "checkpoint.npz", meta=json.dumps({"step": 7}), x=np.arange(5.0))
    for name in ("run.json", "config.json", "history.csv"):
        (stage / name).write_text(name)
    with rundir.hold(stage), pytest.raises(rundir.FolderInUseError, match="is in use by"):
        carry.pack(stage, tmp_path / "new")
    assert not (tmp_path / "new").exists() and not (tmp_path / "new.tmp").exists()
    record = carry.pack(stage, tmp_path / "new")
    assert (record["cells"], record["step"]) == (5, 7)
    assert record["files"]["checkpoint.npz"]["stored"] == "checkpoint.npz.xz"
    old = tmp_path / "old"  # a folder packed before the checkpoint was compressed
    old.mkdir()
    files = {}
    for name in carry.RESUME_FILES:
        data = (stage / name).read_bytes()
        (old / name).write_bytes(data)
        files[name] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    (old / carry.CARRY).write_text(json.dumps({"cells": 5, "step": 7, "files": files,
                                               "checkpoint_bytes_per_cell": 1.0}))
    for folder in ("new", "old"):
        out = carry.unpack(tmp_path / folder, tmp_path / f"{folder}-run")
        for name in carry.RESUME_FILES:
            assert (out / name).read_bytes() == (stage / name).read_bytes(), (folder, name)
    stored = tmp_path / "new" / "checkpoint.npz.xz"
    stored.write_bytes(stored.read_bytes()[:-40])
    with pytest.raises(ValueError, match="checkpoint.npz.xz does not decompress"):
        carry.unpack(tmp_path / "new", tmp_path / "again")
    (old / "history.csv").write_text("edited")
    with pytest.raises(ValueError, match="history.csv differs from what carry.json recorded"):
        carry.unpack(old, tmp_path / "again")
    (old / "history.csv").unlink()
    with pytest.raises(SystemExit) as exit_:
        carry.main(["unpack", str(old), str(tmp_path / "again")])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1
    assert err.startswith("python -m cases.carry: error: ") and "no history.csv, which" in err
    assert not (tmp_path / "again.partial").exists()
    assert not (tmp_path / "again.partial.tmp").exists()


def test_a_stage_holding_only_a_torn_run_json_is_ours(tmp_path):
    """Killed in the first write of a run, run.json's temporary file alone: colony's own."""
    partial = tmp_path / "run.partial"
    partial.mkdir()
    (partial / ".run.json.24553.78abe933.tmp").write_text("{")
    assert rundir.foreign_entries(partial) == []
    (partial / ".notes.24553.78abe933.tmp").write_text("")
    assert rundir.foreign_entries(partial) != []


def test_legs_give_every_sweep_its_limit(tmp_path):
    """``colony case --max-hours``: cases.sweep.legs sets the limit of the sweeps inside it."""
    from cases.sweep import legs, run_engine, sweep

    points = [{"engine": "particles", "lam": 1e-2, "time": 0.04}]
    with legs(1e-9):
        (folder,) = sweep(run_engine, points, tmp_path, n_workers=1, progress=False)
    sessions = json.loads((folder / rundir.RECORD).read_text())["sessions"]
    assert [s["status"] for s in sessions] == ["paused", "finished"]


def test_case_max_hours_must_be_positive(colony, tmp_path):
    status, err = colony("case", "fig2", "--out", str(tmp_path / "c"), "--max-hours", "-1")
    assert status == 2 and "--max-hours must be positive and finite" in err
    assert not (tmp_path / "c").exists()


def test_carry_counts_a_continuum_checkpoints_nodes(colony, tmp_path):
    from cases import carry

    out = tmp_path / "run"
    assert colony(*RUNS["continuum"], "--out", str(out), "--max-hours", "1e-9")[0] == \
        rundir.PAUSED_STATUS
    record = carry.pack(rundir.partial_of(out), tmp_path / "resume")
    assert record["cells"] > 100 and record["step"] == 1


def test_a_stopped_sweep_ends_its_runs_after_a_step_with_a_checkpoint(tmp_path):
    """SIGTERM to a sweep: its runs end after a step with a checkpoint.

    Each run, in a process of its own on its worker, finishes its step, writes its checkpoint
    and is recorded as stopped (no periodic checkpoint here).
    """
    import os
    import signal
    import time

    from cases.sweep import run_name
    from particles.checkpoint import load_checkpoint

    point = {"engine": "particles", "lam": 1e-2, "time": 50.0, "checkpoint_seconds": 1e9,
             "output_every": 0.02}
    stage = tmp_path / (run_name(point) + ".partial")
    script = ("import sys; from cases.sweep import run_engine, sweep; "
              f"sweep(run_engine, [{point!r}], sys.argv[1], n_workers=1, progress=False)")
    sweep = subprocess.Popen([sys.executable, "-c", script, str(tmp_path)],
                             start_new_session=True, stderr=subprocess.PIPE, text=True)
    try:
        frames, sizes = stage / "trajectory.gsd", set()
        while len(sizes) < 3:  # until the run has written frames after its first (steps made)
            sizes.add(frames.stat().st_size if frames.is_file() else 0)
            time.sleep(0.05)
        sweep.send_signal(signal.SIGTERM)
        assert sweep.wait(timeout=120) == 128 + signal.SIGTERM, sweep.stderr.read()
        for _ in range(600):  # the run's own process ends after its step
            record = rundir.read_record(stage)
            if record is not None and record["status"] != "running":
                break
            time.sleep(0.2)
        assert record["status"] == "stopped"
        steps = (stage / "history.csv").read_text().count("\n") - 1
        assert load_checkpoint(stage / "checkpoint.npz").state.step == steps > 0
    finally:
        try:
            os.killpg(sweep.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def test_a_trajectory_rewritten_on_resume_has_the_uninterrupted_bytes(colony, tmp_path):
    """Killed after frames the last checkpoint does not hold: the rewrite gives the same bytes.

    151 frames, a checkpoint after every step, a kill after the 120th frame: the resume
    rewrites trajectory.gsd with the frames of its checkpoint
    (particles.output.truncate_trajectory), frame by frame as the run wrote them; a rewrite
    in one open of gsd laid the index out otherwise (issue 54: 3,163,816 against 3,188,392
    bytes).
    """
    args = ["particles", "--lam", "1e-2", "--time", "3", "--quiet", "--set",
            "output_every=0.01", "--set", "checkpoint_seconds=0"]
    assert colony(*args, "--out", str(tmp_path / "one"))[0] == 0
    out = tmp_path / "run"
    killed = subprocess.run([sys.executable, str(KILLPOINT), "trajectory", "120", "renamed",
                             *args, "--out", str(out)], capture_output=True, text=True,
                            timeout=600)
    assert killed.returncode == -9, killed.stderr
    stage = rundir.partial_of(out)
    with np.load(stage / "checkpoint.npz") as checkpoint:
        frames = json.loads(str(checkpoint["meta"]))["frames"]
    assert frames[2] != (stage / "trajectory.gsd").stat().st_size  # the rewrite will be needed
    assert colony(*args, "--out", str(out))[0] == 0
    assert (out / "trajectory.gsd").read_bytes() == (tmp_path / "one" / "trajectory.gsd"
                                                     ).read_bytes()
    assert oct((out / "trajectory.gsd").stat().st_mode & 0o777) == oct(
        (out / "history.csv").stat().st_mode & 0o777)


def test_a_paused_run_given_a_farther_goal_says_what_to_do(colony, tmp_path):
    out = tmp_path / "run"
    args = ["particles", "--lam", "1e-2", "--quiet", "--out", str(out)]
    assert colony(*args, "--radius", "3", "--max-hours", "1e-9")[0] == rundir.PAUSED_STATUS
    status, err = colony(*args, "--radius", "4")
    assert status == 2 and "differs in radius; give its command to resume it (its goal is " \
        "part of it: resume it to that goal, then grow further from its final state" in err
