"""Bad input and faults of the ``colony`` command.

One test per row of README's "Bad input and faults" table (message, exit status, state of the
output folder).

Runs go through ``cases.cli.main`` in this process (fast) unless a signal is involved.
"""

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from cases import cli, rundir


def one_line_error(status, err, *needles):
    assert status == 2, err
    assert err.count("\n") == 1 and err.startswith("colony: error:"), err
    for needle in needles:
        assert needle in err, err


def tree(folder: Path) -> dict:
    """Every file under ``folder`` with its bytes (to show nothing was touched)."""
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


SMALL_CONTINUUM = ("continuum", "--lam", "1e-2", "--radius", "1.2", "--quiet",
                   "--set", "n_nodes=200")
SMALL_PARTICLES = ("particles", "--lam", "1e-2", "--radius", "2", "--quiet")


# --------------------------------------------------------------------------- output folders


@pytest.mark.parametrize("out,why", [("..", "working directory"), (".", "working directory"),
                                     ("../..", "working directory")])
def test_out_is_the_working_directory_or_a_parent(colony, tmp_path, monkeypatch, out, why):
    work = tmp_path / "a" / "work"
    work.mkdir(parents=True)
    (tmp_path / "a" / "keep.txt").write_text("precious")
    (work / "notes.txt").write_text("mine")
    before = tree(tmp_path)
    monkeypatch.chdir(work)
    status, err = colony(*SMALL_CONTINUUM, "--out", out, "--overwrite")
    one_line_error(status, err, why, "refusing --out")
    assert tree(tmp_path) == before


def test_out_is_root_or_home(colony, tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    for out, why in (("/", "root folder"), (str(tmp_path), "home folder")):
        status, err = colony(*SMALL_CONTINUUM, "--out", out, "--overwrite")
        one_line_error(status, err, why)


def test_out_is_a_file(colony, tmp_path):
    f = tmp_path / "results.txt"
    f.write_text("data")
    status, err = colony(*SMALL_CONTINUUM, "--out", str(f), "--overwrite")
    one_line_error(status, err, "is a file")
    assert f.read_text() == "data" and not rundir.partial_of(f).exists()


def test_existing_out_without_overwrite(colony, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.json").write_text("{}")
    status, err = colony(*SMALL_CONTINUUM, "--out", str(out))
    one_line_error(status, err, "exists", "--overwrite")


def test_overwrite_refuses_a_folder_colony_did_not_write(colony, tmp_path):
    out = tmp_path / "thesis"
    out.mkdir()
    (out / "config.json").write_text("{}")
    (out / "chapter1.tex").write_text("years of work")
    before = tree(out)
    status, err = colony(*SMALL_CONTINUUM, "--out", str(out), "--overwrite")
    one_line_error(status, err, "chapter1.tex", "colony did not")
    assert tree(out) == before and not rundir.partial_of(out).exists()


def test_overwrite_replaces_a_finished_run_only_once_the_new_one_is_complete(colony, tmp_path):
    out = tmp_path / "run"
    assert colony(*SMALL_CONTINUUM, "--out", str(out))[0] == 0
    record = json.loads((out / "run.json").read_text())
    assert record["status"] == "finished" and set(record["files"]) == {
        p.name for p in out.iterdir()} - {"run.json"}
    # a user's file in the published folder: --overwrite refused, nothing removed
    (out / "my_analysis.py").write_text("x = 1")
    status, err = colony(*SMALL_CONTINUUM, "--out", str(out), "--overwrite")
    one_line_error(status, err, "my_analysis.py")
    (out / "my_analysis.py").unlink()
    assert colony(*SMALL_CONTINUUM, "--out", str(out), "--overwrite")[0] == 0
    assert json.loads((out / "run.json").read_text())["status"] == "finished"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


# --------------------------------------------------------------------------- stale stages


def test_stale_stage_of_the_same_run_without_checkpoint_is_cleared(colony, tmp_path):
    """A stage holding VTU frames of an earlier attempt.

    The published folder holds exactly the frames fields.pvd lists.
    """
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    (partial / "fields").mkdir(parents=True)
    for k in range(48):
        (partial / "fields" / f"frame_{k:05d}.vtu").write_text("stale")
    (partial / "config.json").write_text(json.dumps({"lam": 0.01, "shape": "circle"}))
    assert colony(*SMALL_CONTINUUM, "--out", str(out))[0] == 0
    listed = (out / "fields.pvd").read_text().count(".vtu")
    assert len(list((out / "fields").iterdir())) == listed
    assert all(p.read_bytes() != b"stale" for p in (out / "fields").iterdir())


def test_stage_of_another_engine_is_refused_until_overwrite(colony, tmp_path):
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    partial.mkdir()
    from particles import Config, run

    run(Config(lam=1e-2, radius=3.0), partial, max_steps=5)
    before = tree(partial)
    status, err = colony(*SMALL_CONTINUUM, "--out", str(out))
    one_line_error(status, err, "stopped particles run", "--overwrite")
    assert tree(partial) == before
    assert colony(*SMALL_CONTINUUM, "--out", str(out), "--overwrite")[0] == 0
    assert not (out / "trajectory.gsd").exists() and not (out / "particles.csv").exists()


def test_stage_of_another_configuration_is_refused(colony, tmp_path):
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    partial.mkdir()
    from particles import Config, run

    run(Config(lam=2e-2, radius=2.0), partial, max_steps=5)
    status, err = colony(*SMALL_PARTICLES, "--out", str(out))
    one_line_error(status, err, "differs in lam", "--overwrite")
    assert (partial / "checkpoint.npz").exists()


def test_stage_with_foreign_files_is_refused_even_with_overwrite(colony, tmp_path):
    out = tmp_path / "run"
    partial = rundir.partial_of(out)
    partial.mkdir()
    (partial / "data.h5").write_text("not ours")
    status, err = colony(*SMALL_CONTINUUM, "--out", str(out), "--overwrite")
    one_line_error(status, err, "data.h5", "colony did not write")
    assert (partial / "data.h5").read_text() == "not ours"


# --------------------------------------------------------------------------- resources


def test_no_space_before_the_run(colony, tmp_path, monkeypatch):
    real = rundir.shutil.disk_usage
    monkeypatch.setattr(rundir.shutil, "disk_usage",
                        lambda p: real(p)._replace(free=280 * 1024))
    status, err = colony(*SMALL_PARTICLES, "--out", str(tmp_path / "run"))
    one_line_error(status, err, "no space left on", "0.3 MB free")
    assert not any(tmp_path.iterdir())


def test_no_space_during_the_run_keeps_the_last_checkpoint(colony, tmp_path, monkeypatch):
    """The disk fills after a checkpoint.

    The run stops with one line before writing into the full file system (a trajectory write
    there can end the process with SIGBUS), the checkpoint is intact and the run resumes from
    it once space is back.
    """
    import particles.checkpoint as checkpoint
    import particles.runfiles as sim

    out = tmp_path / "run"
    real = sim.shutil.disk_usage
    calls = {"n": 0}

    def filling(path):
        calls["n"] += 1
        return real(path)._replace(free=2**40 if calls["n"] < 12 else 100 * 1024)

    monkeypatch.setattr(sim.shutil, "disk_usage", filling)
    args = (*SMALL_PARTICLES, "--set", "checkpoint_seconds=0", "--set", "output_every=0.02")
    status, err = colony(*args, "--out", str(out))
    one_line_error(status, err, "no space left on")
    partial = rundir.partial_of(out)
    assert json.loads((partial / "run.json").read_text())["status"] == "failed"
    assert not list(partial.glob("*.tmp*"))
    checkpoint_step = checkpoint.checkpoint_config(partial / "checkpoint.npz")  # loads
    assert checkpoint_step.lam == 1e-2
    monkeypatch.setattr(sim.shutil, "disk_usage", real)
    assert colony(*args, "--out", str(out))[0] == 0
    reference = tmp_path / "reference"
    assert colony(*args, "--out", str(reference))[0] == 0
    for name in ("particles.csv", "history.csv", "trajectory.gsd"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name


def test_failed_checkpoint_write_leaves_the_previous_one(tmp_path, monkeypatch):
    import particles
    import particles.checkpoint as sim

    particles.run(particles.Config(lam=1e-2, radius=3.0), tmp_path, max_steps=5)
    before = (tmp_path / "checkpoint.npz").read_bytes()

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(sim.np, "savez", full)
    with pytest.raises(OSError):
        particles.run(particles.Config(lam=1e-2, radius=3.0), tmp_path, max_steps=3)
    assert (tmp_path / "checkpoint.npz").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir() if ".tmp" in p.name) == []


def test_continuum_too_large_for_memory(colony, tmp_path):
    status, err = colony("continuum", "--lam", "1e-2", "--time", "0.01", "--shape",
                         "ellipse:1e6,1e6", "--out", str(tmp_path / "run"))
    one_line_error(status, err, "mesh nodes", "GiB", "h_max")
    assert not any(tmp_path.iterdir())


def test_memory_estimate_against_a_run():
    """The node estimate of continuum.budget against the node count of a run at radius 12."""
    from continuum import Config, run
    from continuum.budget import estimate_nodes

    config = Config(lam=1e-2, radius=12.0, write_fields=False)
    state = run(config).state
    estimate = estimate_nodes(np.pi * 12.0**2, 2 * np.pi * 12.0, config)
    assert abs(estimate / len(state.points) - 1) < 0.15


# --------------------------------------------------------------------------- input


def test_overlapping_or_identical_init(colony, tmp_path):
    for name, rows in (("same", "0,0,0,1\n0,0,0,1\n"), ("cross", "0,0,0,1.5\n0.3,0.1,1,1.2\n")):
        f = tmp_path / f"{name}.csv"
        f.write_text("x,y,theta,length\n" + rows)
        status, err = colony(*SMALL_PARTICLES, "--init", str(f),
                             "--out", str(tmp_path / "run"))
        one_line_error(status, err, str(f), "overlap by")
    assert not (tmp_path / "run").exists() and not (tmp_path / "run.partial").exists()


def test_binary_init(colony, tmp_path):
    f = tmp_path / "image.csv"
    f.write_bytes(bytes(range(256)) * 4)
    status, err = colony(*SMALL_PARTICLES, "--init", str(f), "--out", str(tmp_path / "r"))
    one_line_error(status, err, str(f), "not a text CSV")


def test_radius_not_larger_than_the_initial_colony(colony, tmp_path):
    status, err = colony("particles", "--lam", "1e-2", "--radius", "0.1",
                         "--out", str(tmp_path / "r"))
    one_line_error(status, err, "not larger than the initial colony radius")
    assert not any(tmp_path.iterdir())


def test_lam_from_the_config_or_the_flag_never_silently_overridden(colony, tmp_path):
    status, err = colony("particles", "--radius", "2", "--set", "lam=0.02",
                         "--lam", "0.01", "--out", str(tmp_path / "a"))
    one_line_error(status, err, "lam given twice")
    status, err = colony("particles", "--radius", "2", "--out", str(tmp_path / "b"))
    one_line_error(status, err, "lam is required")
    toml = tmp_path / "c.toml"
    toml.write_text("lam = 0.02\n")
    status, err = colony("particles", "--radius", "2", "--config", str(toml), "--quiet",
                         "--out", str(tmp_path / "c"))
    assert status == 0, err
    assert json.loads((tmp_path / "c" / "config.json").read_text())["lam"] == 0.02


def test_closed_two_point_polygon(colony, tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("x,y\n0,0\n1,0\n0,0\n")
    status, err = colony("continuum", "--lam", "1e-2", "--radius", "5", "--shape",
                         f"polygon:{f}", "--out", str(tmp_path / "r"))
    one_line_error(status, err, "2 distinct vertices")


# --------------------------------------------------------------------------- signals


def _start(out: Path, *extra):
    return subprocess.Popen(
        [sys.executable, "-m", "cases.cli", *SMALL_PARTICLES[:3], "--radius", "20",
         "--out", str(out), "--quiet", *extra], stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("sig,status,word", [(signal.SIGTERM, 143, "terminated"),
                                             (signal.SIGINT, 130, "interrupted")])
def test_signal_ends_with_a_line_and_a_checkpoint(tmp_path, sig, status, word):
    out = tmp_path / "run"
    proc = _start(out)
    history = rundir.partial_of(out) / "trajectory.gsd"
    deadline = time.monotonic() + 120
    while not history.exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(1.0)
    proc.send_signal(sig)
    err = proc.communicate(timeout=120)[1]
    if proc.returncode == 0:
        pytest.skip("the run finished before the signal")
    assert proc.returncode == status, err
    assert err.count("\n") == 1 and word in err and "give the same command to resume" in err
    partial = rundir.partial_of(out)
    assert (partial / "checkpoint.npz").exists()
    assert json.loads((partial / "run.json").read_text())["status"] == "stopped"


def test_info_prints_the_provenance(colony, capsys, tmp_path):
    out = tmp_path / "run"
    assert colony(*SMALL_CONTINUUM, "--out", str(out))[0] == 0
    status = cli.main(["info", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    for needle in ("engine          continuum", "status          finished", "lam=0.01",
                   "peak memory", "command"):
        assert needle in text
    record = json.loads((out / "run.json").read_text())
    assert record["package_version"] and record["sessions"][0]["cpu_seconds"] >= 0
    status, err = colony("info", str(tmp_path / "nothing"))
    one_line_error(status, err, "no run folder")



# --------------------------------------------------------------------------- strains, --set


@pytest.mark.parametrize("engine", ["continuum", "particles"])
@pytest.mark.parametrize("extra,needle", [
    (("--strains", "-1,0", "--layout", "core:1"), "a strain's lam must be"),
    (("--strains", "1e-2:1e300,0", "--layout", "core:1"), "growth must be in (0, 100]"),
    (("--strains", "1e-2,0"), "2 strains need --layout to place them"),
    (("--strains", "1e-2,0", "--layout", "sector:1,nan"), "takes finite numbers"),
    (("--strains", ",".join(["0"] * 65), "--layout", "core:1"), "65 given, at most 64"),
])
def test_strains_that_cannot_run_are_refused_before_any_work(colony, tmp_path, engine, extra,
                                                             needle):
    status, err = colony(engine, "--radius", "3", "--quiet", "--out", str(tmp_path / "s"),
                         *extra)
    one_line_error(status, err, needle)
    assert list(tmp_path.iterdir()) == []


def test_lam_is_optional_with_strains():
    config = cli.build_config(__import__("particles").Config, None, [],
                              {"strains": [[1e-2, 1.0], [0.0, 1.0]], "radius": 3.0})
    assert config.lam == 1e-2


def test_a_huge_set_key_or_value_is_cut_in_the_message(colony, tmp_path):
    for item in ("k" * 100_000 + "=1", "seed=" + "1" * 100_000):
        status, err = colony("particles", "--lam", "0", "--radius", "3", "--set", item,
                             "--out", str(tmp_path / "s"))
        one_line_error(status, err)
        assert len(err) < 600 and "..." in err  # the key cut; the known keys' list stays


def test_case_help_and_quiet(capsys):
    cli.parser().parse_args(["case", "orientation", "--quiet"])
    help_text = cli.parser().format_help()
    for name in ("orientation", "strains", "shapes"):
        assert name in help_text


# --------------------------------------------------------------------------- plot, movie


@pytest.fixture
def particle_run(colony, tmp_path):
    out = tmp_path / "p8"
    assert colony("particles", "--lam", "1e-2", "--radius", "2", "--quiet", "--out",
                  str(out))[0] == 0
    return out


@pytest.mark.parametrize("command", [["plot"], ["movie", "--quiet"]])
def test_plot_or_movie_of_a_folder_a_run_is_writing(colony, particle_run, command):
    with rundir.hold(particle_run):
        status, err = colony(command[0], str(particle_run), *command[1:])
    one_line_error(status, err, f"{particle_run} is in use by")


@pytest.mark.parametrize("command", [["plot", "--out", "{other}"],
                                     ["movie", "--out", "{other}/m.mp4", "--quiet"]])
def test_plot_or_movie_into_another_runs_folder(colony, particle_run, tmp_path, command):
    other = tmp_path / "c8"
    assert colony(*SMALL_CONTINUUM, "--out", str(other))[0] == 0
    before = tree(other)
    args = [a.format(other=other) for a in command]
    status, err = colony(args[0], str(particle_run), *args[1:])
    one_line_error(status, err, f"refusing to write into {other}: it is the folder of another run")
    assert tree(other) == before


@pytest.mark.parametrize("command", [["plot"], ["movie", "--quiet"],
                                     ["continuum", "--radius", "20", "--from-particles"]])
def test_a_run_json_of_the_wrong_shape(colony, particle_run, tmp_path, command):
    (particle_run / "run.json").write_text("[1, 2]")
    args = [*command, str(particle_run)] + (["--out", str(tmp_path / "c9")]
                                            if command[0] == "continuum" else [])
    status, err = colony(*args)
    one_line_error(status, err, "run.json is damaged: expected a JSON object, found list")


@pytest.mark.parametrize("command", [["info"], ["plot"], ["movie", "--quiet"]])
@pytest.mark.parametrize("text,why", [
    ("[" * 100_000 + "]" * 100_000, "JSON nested too deeply to read"),
    ('{"engine": ', "not JSON (Expecting value at line 1 column 12)"),
    ("\udcff", "not UTF-8 text")])
def test_a_run_json_that_does_not_parse(colony, tmp_path, command, text, why):
    """Issue 54: a deep run.json said "maximum recursion depth"; one not JSON "NoneType"."""
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "run.json").write_bytes(text.encode(errors="surrogateescape"))
    before = tree(tmp_path)
    status, err = colony(command[0], str(folder), *command[1:])
    one_line_error(status, err, f"colony: error: {folder / 'run.json'} is damaged: {why}\n")
    assert tree(tmp_path) == before


@pytest.mark.parametrize("engine", ["continuum", "particles"])
def test_a_layout_outside_the_colony_warns(colony, tmp_path, engine, caplog):
    polygon = tmp_path / "far.csv"
    polygon.write_text("x,y\n100,100\n101,100\n101,101\n100,100\n")
    with caplog.at_level("WARNING"):
        status, _ = colony(engine, "--strains", "1e-2,0", "--layout", f"polygon:{polygon}",
                           "--radius", "1.5", "--quiet", "--set", "n_nodes=200"
                           if engine == "continuum" else "seed=0", "--out", str(tmp_path / "s"))
    assert status == 0
    assert any("strain(s) 1 absent from the initial colony" in r.message for r in caplog.records)


# --------------------------------------------------------------------------- round four (issue 54)


def _stage(folder: Path) -> Path:
    """A stopped run's stage as ``carry.pack`` reads it (four resume files)."""
    folder.mkdir(parents=True)
    np.savez(folder / "checkpoint.npz", meta=json.dumps({"step": 7}), x=np.arange(5.0))
    for name in ("run.json", "config.json", "history.csv"):
        (folder / name).write_text(name)
    return folder


def test_carry_pack_never_replaces_what_it_did_not_write(tmp_path, monkeypatch, capsys):
    """A folder pack did not write, or the stage: refused in one line, every file as it was.

    A user's folder, a run folder, the stage itself, a folder inside it, the working
    directory, a file. A pack's own folder is replaced whole, with nothing left beside it.
    """
    from cases import carry

    monkeypatch.chdir(tmp_path)
    stage = _stage(tmp_path / "q.partial")
    thesis = tmp_path / "thesis"
    thesis.mkdir()
    (thesis / "chapter1.tex").write_text("precious")
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.json").write_text("{}")
    before = tree(tmp_path)
    for dest, why in ((thesis, "is not a folder pack wrote"), (run, "is not a folder pack wrote"),
                      (stage, "is the stage"), (stage / "inner", "is the stage"),
                      (Path("."), "is not a folder pack wrote"), (thesis / "chapter1.tex",
                                                                  "is a file")):
        with pytest.raises(SystemExit) as exit_:
            carry.main(["pack", str(stage), str(dest)])
        err = capsys.readouterr().err
        assert exit_.value.code == 2 and err.count("\n") == 1, err
        assert f"error: refusing {dest}: " in err and why in err, err
        assert tree(tmp_path) == before
    carry.pack(stage, tmp_path / "repo" / "resume")
    (stage / "history.csv").write_text("history, one leg later")
    carry.pack(stage, tmp_path / "repo" / "resume")  # a pack's folder: replaced
    assert sorted(p.name for p in (tmp_path / "repo").iterdir()) == ["resume"]
    out = carry.unpack(tmp_path / "repo" / "resume", tmp_path / "again")
    assert (out / "history.csv").read_text() == "history, one leg later"
    assert oct((tmp_path / "repo" / "resume").stat().st_mode & 0o777) == oct(
        out.stat().st_mode & 0o777) == oct(thesis.stat().st_mode & 0o777)


def test_carry_refuses_a_damaged_record_naming_it_and_a_stage_name(tmp_path):
    from cases import carry

    packed = tmp_path / "resume"
    carry.pack(_stage(tmp_path / "q.partial"), packed)
    with pytest.raises(ValueError, match="give the run's --out"):
        carry.unpack(packed, tmp_path / "r.partial")
    with pytest.raises(ValueError, match="give the run's --out"):
        carry.unpack(packed, "/")
    (packed / "carry.json").write_text("{")
    with pytest.raises(ValueError, match=f"{packed / 'carry.json'} is damaged"):
        carry.unpack(packed, tmp_path / "r")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["q.partial", "resume"]


@pytest.mark.parametrize("size", [248, 255])
@pytest.mark.parametrize("engine", [SMALL_CONTINUUM, SMALL_PARTICLES])
def test_out_name_too_long_for_the_stage_is_refused_by_both_engines(colony, tmp_path,
                                                                    monkeypatch, engine, size):
    """A name of 248 to 255 bytes fits the file system, ``DIR.partial`` does not.

    Issue 54: the continuum said "[Errno 36] File name too long" (cases.handoff.check_resume
    looked into ``DIR.partial`` before rundir.check_target); both engines give the line.
    """
    if os.pathconf(tmp_path, "PC_NAME_MAX") != 255:
        pytest.skip("a file system whose names are not limited to 255 bytes")
    ran = []
    monkeypatch.setattr("continuum.simulation.run", lambda *a, **k: ran.append(1))
    monkeypatch.setattr("particles.run", lambda *a, **k: ran.append(1))
    for overwrite in ((), ("--overwrite",)):
        status, err = colony(*engine, "--out", str(tmp_path / ("x" * size)), *overwrite)
        one_line_error(status, err, f"colony: error: --out name too long: {size} bytes, at most "
                       "246 (the file system allows 255, colony adds '.replaced'); give a "
                       "shorter name\n")
    assert not ran and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["o.partial", "o.replaced"])
@pytest.mark.parametrize("engine", [SMALL_CONTINUUM, SMALL_PARTICLES])
def test_out_named_like_a_stage_is_refused(colony, tmp_path, engine, name):
    status, err = colony(*engine, "--out", str(tmp_path / name))
    one_line_error(status, err, f"refusing --out {tmp_path / name}: names ending in .partial")
    assert list(tmp_path.iterdir()) == []


def test_a_finished_run_in_the_stage_place_is_never_cleared(colony, tmp_path):
    """A finished run as ``o.partial``: a run of ``o`` refuses it instead of clearing it.

    An older version let ``--out o.partial`` make one; here another configuration is run.
    """
    assert colony(*SMALL_CONTINUUM, "--out", str(tmp_path / "x"))[0] == 0
    (tmp_path / "x").rename(tmp_path / "o.partial")
    before = tree(tmp_path)
    status, err = colony(*SMALL_CONTINUUM[:-1], "n_nodes=300", "--out", str(tmp_path / "o"))
    one_line_error(status, err, "o.partial is a finished run's folder, not a stage")
    assert tree(tmp_path) == before and not (tmp_path / "o").exists()


def _fit_data(folder: Path) -> Path:
    data = folder / "colony.csv"
    data.write_text("t,radius\n0,10\n60,12\n120,15\n")
    return data


@pytest.mark.parametrize("command", ["plot", "fit", "case"])
@pytest.mark.parametrize("where", ["root", "working directory", "another run", "stage name"])
def test_every_writing_command_follows_the_run_folder_rules(colony, particle_run, tmp_path,
                                                            monkeypatch, command, where):
    """One rule (rundir.check_output) refuses, in one line, with nothing written.

    ``/``, the working directory, a run's folder other than the one drawn, a name ending in
    .partial.
    """
    monkeypatch.chdir(tmp_path)
    other = tmp_path / "other"
    assert colony(*SMALL_CONTINUUM, "--out", str(other))[0] == 0
    out = {"root": "/", "working directory": ".", "another run": str(other / "sub"),
           "stage name": "p.partial"}[where]
    why = {"root": "it is the root folder", "working directory": "it is the working directory",
           "another run": f"refusing to write into {other}: it is the folder of a",
           "stage name": "names ending in .partial"}[where]
    before = tree(tmp_path)
    args = {"plot": ["plot", str(particle_run), "--out", out],
            "fit": ["fit", str(_fit_data(tmp_path.parent)), "--tau-minutes", "30",
                    "--cell-length-um", "2", "--out", out],
            "case": ["case", "convergence", "--out", out, "--workers", "1"]}[command]
    status, err = colony(*args)
    one_line_error(status, err, why)
    assert tree(tmp_path) == before


def test_case_runs_into_a_run_folder_is_refused(colony, tmp_path):
    other = tmp_path / "other"
    assert colony(*SMALL_CONTINUUM, "--out", str(other))[0] == 0
    before = tree(tmp_path)
    status, err = colony("case", "fig2", "--out", str(tmp_path / "c"), "--runs", str(other),
                         "--workers", "1")
    one_line_error(status, err, f"refusing to write into {other}: it is the folder of a run "
                   f"(--runs {other})")
    assert tree(tmp_path) == before and not (tmp_path / "c").exists()


def test_plot_out_with_dot_dots_leaves_no_stray_folder(colony, particle_run, tmp_path,
                                                       monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    shutil.copytree(particle_run, "a")
    names = sorted(p.name for p in Path("a").iterdir())
    assert colony("plot", "a", "--out", "ab/../a/x/../../b")[0] == 0
    assert sorted(p.name for p in Path("a").iterdir()) == names
    assert sorted(p.name for p in work.iterdir()) == ["a", "b"]
    assert (work / "b" / "colony.png").is_file()


def test_the_api_refuses_the_root_folder_in_one_line(tmp_path):
    import continuum
    import particles
    from cases import runs

    for config in (continuum.Config(lam=1e-2, radius=1.2), particles.Config(lam=1e-2, radius=2)):
        with pytest.raises(rundir.RunFolderError, match="refusing --out /: it is the root folder"):
            runs.run(config, "/")
