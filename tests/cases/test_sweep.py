"""cases.sweep on a small LocalCluster: one folder per run, failures reported, resume skips."""

import json
import os
from pathlib import Path

import pytest

from cases.sweep import DONE, SweepError, run_name, run_one, sweep


def square_run(params: dict, folder: Path) -> None:
    """Trivial run: writes lam^2 and the worker's pid; fails on request."""
    if params.get("fail"):
        raise RuntimeError("asked to fail")
    (folder / "result.json").write_text(json.dumps({"sq": params["lam"] ** 2, "pid": os.getpid()}))


def fixed_run(params: dict, folder: Path) -> None:
    """The same run with the failure fixed."""
    (folder / "result.json").write_text(json.dumps({"sq": params["lam"] ** 2, "pid": os.getpid()}))


def test_run_name():
    assert run_name({"seed": 3, "lam": 1e-2}) == "lam=0.01_seed=3"
    assert run_name({"lam": 1e-4, "radius": 150.0}) == "lam=0.0001_radius=150"
    assert run_name({"shape": "polygon:a b/c"}) == "shape=polygon-a-b-c"
    with pytest.raises(ValueError):
        run_name({})


def resuming_run(params: dict, folder: Path) -> None:
    """A run that continues from the 'checkpoint' a stopped run left in its folder."""
    ckpt = folder / "checkpoint.txt"
    done = int(ckpt.read_text()) if ckpt.exists() else 0
    (folder / "result.json").write_text(json.dumps({"resumed_from": done}))


def test_run_one_stages_resumes_and_skips(tmp_path):
    folder = tmp_path / "lam=1"
    (tmp_path / "lam=1.partial").mkdir()  # left over from a killed run, with its checkpoint
    (tmp_path / "lam=1.partial" / "checkpoint.txt").write_text("7")
    assert run_one(resuming_run, {"lam": 1.0}, folder) == folder
    assert (folder / DONE).is_file()
    assert json.loads((folder / "result.json").read_text()) == {"resumed_from": 7}
    assert not (tmp_path / "lam=1.partial").exists()
    assert json.loads((folder / "params.json").read_text()) == {"lam": 1.0}
    stamp = (folder / "result.json").stat().st_mtime_ns
    run_one(square_run, {"lam": 1.0, "fail": True}, folder)  # done: not run again
    assert (folder / "result.json").stat().st_mtime_ns == stamp


def crashing_run(params, folder):
    """A run whose process dies without a word."""
    os._exit(3)


crashing_run.stages_itself = True


def test_a_workers_runs_report_in_one_line_and_a_crash_costs_one_run(tmp_path):
    """Off the main thread engine runs go to the thread's child Python.

    An error comes back as one line; a dead child fails its own run only and the thread's
    next run starts another.
    """
    import subprocess
    import sys
    import threading

    from cases.sweep import run_engine

    bad = {"engine": "particles", "lam": -1.0, "time": 1.0}
    errors = []

    def worker():
        for run_fn, name in ((run_engine, "bad"), (crashing_run, "crash"), (run_engine, "bad2")):
            try:
                run_one(run_fn, bad, tmp_path / name)
            except RuntimeError as err:
                errors.append(str(err))

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    error = "ValueError: lam must be a finite number >= 0 for particles, got -1.0"
    assert errors == [f"bad: {error}", "crash: its process ended with exit status 3",
                      f"bad2: {error}"]
    child = subprocess.run([sys.executable, "-m", "cases.sweep"], text=True, capture_output=True)
    assert child.returncode == 2 and child.stderr.count("\n") == 1, child.stderr


def test_sweep_local_cluster_then_resume_on_existing_scheduler(tmp_path):
    from dask.distributed import LocalCluster

    params = [{"lam": lam} for lam in (0.0, 1e-3, 1e-2)] + [{"lam": 2.0, "fail": True}]
    # 1) default LocalCluster of 2 processes: three runs succeed, one fails
    with pytest.raises(SweepError) as info:
        sweep(square_run, params, tmp_path, n_workers=2, progress=False)
    assert list(info.value.failures) == ["fail=True_lam=2"]
    assert "asked to fail" in info.value.failures["fail=True_lam=2"]
    done = sorted(p.name for p in tmp_path.iterdir() if (p / DONE).exists())
    assert done == ["lam=0", "lam=0.001", "lam=0.01"]
    assert (tmp_path / "fail=True_lam=2.partial").is_dir()  # kept for inspection
    pids = {json.loads((tmp_path / n / "result.json").read_text())["pid"] for n in done}
    assert os.getpid() not in pids  # ran in worker processes
    stamps = {n: (tmp_path / n / "result.json").stat().st_mtime_ns for n in done}

    # 2) resume through an existing scheduler: only the failed run is redone
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        folders = sweep(fixed_run, params, tmp_path, scheduler=cluster.scheduler_address,
                        progress=False)
    assert [f.name for f in folders] == ["lam=0", "lam=0.001", "lam=0.01", "fail=True_lam=2"]
    assert all((f / DONE).is_file() for f in folders)
    assert {n: (tmp_path / n / "result.json").stat().st_mtime_ns for n in done} == stamps
    assert json.loads((folders[3] / "result.json").read_text())["sq"] == 4.0
    assert not (tmp_path / "fail=True_lam=2.partial").exists()

    # 3) everything done: returns at once without starting a cluster
    assert sweep(square_run, params, tmp_path, scheduler="tcp://nowhere:1") == folders


def test_case_runs_finished_only_reuses_and_never_starts(tmp_path):
    """`colony case NAME --engines finished`: particle runs taken only where finished."""
    from cases.sweep import case_runs, finished_runs, run_name

    done = tmp_path / run_name({"engine": "particles", "lam": 0.1, "radius": 15.0,
                                "output_every": 0.4})
    done.mkdir()
    (done / DONE).write_text("")
    (tmp_path / run_name({"engine": "particles", "lam": 0.3, "radius": 15.0,
                          "output_every": 0.4})).mkdir()  # unfinished: not taken
    needed = [("particles", 0.03), ("particles", 0.1), ("particles", 0.3)]
    assert finished_runs(needed, "smoke", tmp_path) == {("particles", 0.1): done}
    got = case_runs("fig2", needed, "smoke", tmp_path / "out", runs=tmp_path,
                    scheduler="tcp://nowhere:1", needs_continuum=False,
                    finished_only=("particles",))
    assert got == {("particles", 0.1): done}  # nothing to run: no scheduler contacted
    with pytest.raises(ValueError, match="finished_only"):
        case_runs("fig2", needed, "smoke", tmp_path, finished_only=("fluid",),
                  needs_continuum=False)


def test_paper_scale_particles_take_the_default_step_at_every_lam():
    """SCALES["paper"]: every particle run takes the default step control (issue 18).

    Until then the runs below lam = 1e-2 took dt = 0.005; now only the frames are set.
    """
    from cases.sweep import _engine_params, scale_config
    cfg = scale_config("paper")
    for lam in (0.0, 1e-4, 1e-3, 1e-2):
        assert _engine_params("particles", lam, cfg) == {
            "engine": "particles", "lam": lam, "radius": 150.0, "output_every": 0.2}
    assert _engine_params("continuum", 1e-3, cfg)["output_every"] == 0.5


@pytest.fixture
def scheduler(tmp_path_factory):
    """A real ``dask scheduler`` and two ``dask worker`` processes (not a LocalCluster).

    Started from the command line in a folder of their own, as on a cluster; yields the
    address and that folder.
    """
    import shutil
    import subprocess
    import sys
    import time

    elsewhere = tmp_path_factory.mktemp("workers-cwd")
    info = elsewhere / "scheduler.json"
    bindir = Path(sys.executable).parent
    dask = shutil.which("dask", path=str(bindir)) or "dask"
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(info)], cwd=elsewhere,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        procs += [subprocess.Popen([dask, "worker", address, "--nworkers", "1", "--nthreads",
                                    "1", "--no-dashboard"], cwd=elsewhere,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                  for _ in range(2)]
        from dask.distributed import Client

        with Client(address) as client:
            client.wait_for_workers(2, timeout=60)
        yield address, elsewhere
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            proc.wait(timeout=30)


def test_engine_sweep_on_a_real_scheduler_with_a_relative_root(scheduler, tmp_path,
                                                                monkeypatch):
    """Runs of both engines on workers that work in another folder.

    The relative root is resolved on the client, and every folder is the command line's
    (run.json finished, profile, picture), so ``colony info`` reads it.
    """
    from cases import cli, rundir
    from cases.sweep import run_engine

    address, elsewhere = scheduler
    monkeypatch.chdir(tmp_path)
    params = [{"engine": "continuum", "lam": 1e-2, "radius": 1.2, "n_nodes": 200},
              {"engine": "particles", "lam": 1e-2, "radius": 2.0}]
    folders = sweep(run_engine, params, "runs", scheduler=address, progress=False)
    assert [f.parent for f in folders] == [tmp_path / "runs"] * 2
    assert not (elsewhere / "runs").exists()
    for folder, picture in zip(folders, ("mean_length.png", "colony.png"), strict=True):
        record = rundir.read_record(folder)
        assert record["status"] == "finished" and record["sessions"][0]["pid"] != os.getpid()
        assert set(record["files"]) >= {"history.csv", "profile.csv", picture, "config.json"}
        assert (folder / "profile.csv").read_text().count("\n") > 2
        assert cli.main(["info", str(folder)]) == 0
    assert "rings.csv" in rundir.read_record(folders[0])["files"]
