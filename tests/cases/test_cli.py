"""The ``colony`` command: configuration layering, staging, bad input, end-to-end runs."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from cases import cli
from cases.figures import draw
from tests.pictures import assert_drawn, movie_frames


@dataclasses.dataclass
class _Config:
    lam: float = 0.0
    radius: float | None = None
    n: int = 3
    flag: bool = False

    def validate(self):
        if self.lam < 0:
            raise ValueError("lam must be >= 0")


def test_config_layers(tmp_path):
    toml = tmp_path / "c.toml"
    toml.write_text("lam = 0.5\nn = 7\n")
    c = cli.build_config(_Config, str(toml), ["n=9", "flag=true"], {"radius": 4.0, "lam": None})
    assert (c.lam, c.n, c.flag, c.radius) == (0.5, 9, True, 4.0)


@pytest.mark.parametrize(
    "toml,sets,match",
    [
        (None, ["nope=1"], "unknown setting"),
        (None, ["n"], "KEY=VALUE"),
        ("missing.toml", [], "not found"),
        (None, ["lam=-1"], "lam must be"),
    ],
)
def test_config_errors(toml, sets, match):
    with pytest.raises(ValueError, match=match):
        cli.build_config(_Config, toml, sets, {})


def _colony(*args):
    return subprocess.run(
        [sys.executable, "-m", "cases.cli", *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize(
    "args",
    [
        ["continuum", "--lam", "nan", "--radius", "2"],
        ["particles", "--lam", "0.01", "--radius", "inf"],
        ["particles", "--lam", "0.01", "--radius", "2", "--threads", "0"],
        ["continuum", "--lam", "0.01", "--radius", "-1"],
        ["continuum", "--lam", "0.01", "--radius", "2", "--config", "missing.toml"],
        ["case", "ensemble", "--scale", "paper"],  # a scale the case does not define
        ["particles", "--lam", "0.01", "--radius", "2", "--set", "threads=two"],
    ],
)
def test_bad_arguments_one_line_exit_2(args, tmp_path):
    res = _colony(*args, "--out", str(tmp_path / "o"))
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith("colony: error:")
    assert "Traceback" not in res.stderr
    assert not (tmp_path / "o").exists()


def test_argparse_errors_exit_2():
    res = _colony("continuum", "--lam", "0.1")  # neither --radius nor --time
    assert res.returncode == 2 and "Traceback" not in res.stderr
    res = _colony("particles", "--lam", "0.1", "--radius", "2", "--threads", "two")
    assert res.returncode == 2 and "expected auto or an integer, got 'two'" in res.stderr


def _header(path):
    return path.read_text().splitlines()[0].split(",")


def test_continuum_end_to_end(tmp_path):
    out = tmp_path / "c"
    res = _colony("continuum", "--lam", "1e-2", "--radius", "2", "--out", str(out), "--quiet")
    assert res.returncode == 0, res.stderr
    for name in (
        "history.csv",
        "profile.csv",
        "boundary.csv",
        "fields.pvd",
        "config.json",
        "mean_length.png",
        "rings.csv",
        "run.json",
    ):
        assert (out / name).is_file(), name
    assert {"k", "mean_radius", "min_radius", "max_radius", "length"} <= set(
        _header(out / "rings.csv"))
    assert {"G", "mean_length_phase", "mean_length_psi", "length_std_psi"} <= set(
        _header(out / "profile.csv"))
    assert {"t", "radius", "area", "max_pressure"} <= set(_header(out / "history.csv"))
    assert {"r", "mean_length", "pressure"} <= set(_header(out / "profile.csv"))
    assert _header(out / "boundary.csv") == ["x", "y"]
    assert not out.with_name("c.partial").exists()
    # a second run into the same folder is refused, the first is untouched
    res = _colony("continuum", "--lam", "1e-2", "--radius", "2", "--out", str(out), "--quiet")
    assert res.returncode == 2 and "exists" in res.stderr


def test_particles_end_to_end(tmp_path):
    out = tmp_path / "p"
    res = _colony(
        "particles", "--lam", "1e-2", "--radius", "3", "--seed", "3", "--out", str(out), "--quiet",
        "--step-control", "cost",
    )
    assert res.returncode == 0, res.stderr
    assert json.loads((out / "config.json").read_text())["step_control"] == "cost"
    for name in (
        "history.csv",
        "profile.csv",
        "particles.csv",
        "trajectory.gsd",
        "config.json",
        "colony.png",
    ):
        assert (out / name).is_file(), name
    assert {"t", "radius", "n_particles", "max_stress", "max_overlap", "iterations"} <= set(
        _header(out / "history.csv")
    )
    assert {"r", "mean_length", "stress"} <= set(_header(out / "profile.csv"))
    assert {"x", "y", "theta", "length", "stress"} <= set(_header(out / "particles.csv"))
    assert not list(out.glob("checkpoint*"))


def test_mean_length_image_applies_the_sawtooth_per_pixel():
    # G = 3 x on the unit square: lbar = 2^frac(3x / ln 2) exactly at every pixel centre
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    image, extent = draw.mean_length_image(pts, tri, 3.0 * pts[:, 0], pixels=50)
    x = np.linspace(0, 1, 50)
    q = 3.0 * x / np.log(2.0)
    np.testing.assert_allclose(image, np.broadcast_to(2.0 ** (q - np.floor(q)), (50, 50)),
                               rtol=1e-9)
    assert extent == (0.0, 1.0, 0.0, 1.0)


@pytest.mark.parametrize("data_set", ["medium", "paper"])
def test_case_from_committed_data(tmp_path, data_set):
    res = _colony("case", "fig3", "--from-data", "--data-set", data_set,
                  "--out", str(tmp_path / "f"))
    assert res.returncode == 0, res.stderr
    assert_drawn(tmp_path / "f" / "fig3.png")


def test_particles_resume_with_another_step_only_when_asked(tmp_path):
    """A stopped run (checkpoint in DIR.partial) given another --dt.

    It is refused with a one-line error naming --change-step-policy; with that option, resumed
    and the change recorded.
    """
    from particles import Config, run

    out = tmp_path / "p"
    partial = tmp_path / "p.partial"
    partial.mkdir()
    run(Config(lam=1e-2, radius=3.0, seed=3), partial, max_steps=20)
    args = ("particles", "--lam", "1e-2", "--radius", "3", "--seed", "3", "--dt", "0.005",
            "--out", str(out), "--quiet")
    res = _colony(*args)
    assert res.returncode == 2 and res.stderr.count("\n") == 1
    assert "differs in dt" in res.stderr and "--change-step-policy" in res.stderr
    res = _colony(*args, "--change-step-policy")
    assert res.returncode == 0, res.stderr
    config = json.loads((out / "config.json").read_text())
    assert config["dt"] == 0.005 and config["step_policy_changes"] == [
        {"step": 20, "dt": [0.02, 0.005]}]


def test_plot_and_movie_of_a_run(tmp_path):
    """``colony plot DIR`` and ``colony movie DIR`` redraw a finished run.

    The folder stays replaceable by --overwrite; a folder that is not a run is one line,
    exit 2.
    """
    out = tmp_path / "c"
    assert cli.main(["continuum", "--lam", "1e-2", "--radius", "1.5", "--out", str(out),
                     "--quiet", "--output-every", "0.2", "--set", "n_nodes=200"]) == 0
    assert cli.main(["plot", str(out)]) == 0
    assert_drawn(out / "radius.png")
    assert cli.main(["movie", str(out), "--max-frames", "3", "--quiet"]) == 0
    assert movie_frames(out / "movie.mp4") == 3
    assert cli.main(["continuum", "--lam", "1e-2", "--radius", "1.5", "--out", str(out),
                     "--quiet", "--overwrite", "--set", "n_nodes=200"]) == 0
    res = _colony("movie", str(tmp_path))
    assert res.returncode == 2 and res.stderr.count("\n") == 1


def test_continuum_element_flag(colony, tmp_path):
    """``--element P2`` reaches continuum.Config; another element is one line, exit 2."""
    status, err = colony("continuum", "--lam", "1e-2", "--radius", "1", "--element", "P3",
                         "--out", str(tmp_path / "bad"), "--quiet")
    assert status == 2 and err.count("\n") == 1 and "element must be 'P1' or 'P2'" in err
    out = tmp_path / "p2"
    assert colony("continuum", "--lam", "1e-2", "--radius", "0.8", "--element", "P2",
                  "--out", str(out), "--quiet", "--set", "n_nodes=100")[0] == 0
    assert json.loads((out / "config.json").read_text())["element"] == "P2"


def test_case_lams_select_some_lam_or_are_refused_before_any_work(tmp_path, capsys):
    from cases.sweep import select_lams

    needed = [("continuum", 0.0), ("particles", 0.0), ("continuum", 0.01)]
    assert select_lams(needed, [0]) == [("continuum", 0.0), ("particles", 0.0)]
    assert select_lams(needed, None) == needed
    out = tmp_path / "case"
    assert cli.main(["case", "fig3", "--scale", "smoke", "--lams", "0.5", "--out", str(out)]) == 2
    assert "lam 0.5 not among the lam of fig3 at this scale: 0, " in capsys.readouterr().err
    assert not out.exists()
    assert cli.main(["case", "stability", "--lams", "0", "--out", str(out)]) == 2
    assert "--lams applies to the figure cases" in capsys.readouterr().err
    assert cli.main(["case", "ensemble", "--lams", "0", "--out", str(out)]) == 2
    assert "lam 0 not among the lam of the smoke ensemble: 0.1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["case", "fig3", "--lams", "x"])
    assert not out.exists()


def test_the_command_starts_without_the_numerical_stack():
    """``colony --help`` imports neither engine nor scipy, meshio or matplotlib (it stays quick)."""
    code = ("import sys, cases.cli; heavy = ('scipy', 'meshio', 'matplotlib', 'numba', "
            "'continuum', 'particles', 'dask'); print([m for m in heavy if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("engine", ["continuum", "particles"])
def test_help_states_the_engine_defaults(engine):
    """Every ``(default V)`` in an engine option's help is the Config's default of that field.

    The help is written without importing the engines (``colony --help`` stays fast), so this
    test is what keeps the two in step; each engine option with a Config field says its default.
    """
    import importlib
    import re

    config = importlib.import_module(engine).Config
    defaults = {f.name: f.default for f in dataclasses.fields(config)}
    sub = next(a for a in cli.parser()._actions if isinstance(a, cli.argparse._SubParsersAction))
    checked = []
    for action in sub.choices[engine]._actions:
        field = action.dest
        if field not in defaults or field in ("lam", "radius", "time", "init", "shape",
                                              "threads", "strains", "layout", "max_hours",
                                              "nutrient_length", "monod_k", "dish_radius"):
            continue  # None: words ("none", "inf", "supply at the colony's edge")
        stated = re.search(r"(\S+) \(default\)|[(;] ?default:? ([^;,)\s]+)", action.help)
        assert stated, f"--{field}: the help states no default"
        value = stated.group(1) or stated.group(2)
        default = defaults[field]
        if isinstance(default, str):
            assert value == default, f"--{field}: help {value}, Config {default}"
        else:
            assert float(value) == pytest.approx(float(default)), f"--{field}: {value} vs {default}"
        checked.append(field)
    assert len(checked) >= 3, checked


def test_from_data_reads_a_given_data_folder(tmp_path):
    """--data FOLDER: the committed data from anywhere (the wheel carries none)."""
    import shutil

    data = tmp_path / "data"
    shutil.copytree(cli.DATA / "fig2", data / "fig2")
    assert cli.main(["case", "fig2", "--from-data", "--data", str(data),
                     "--out", str(tmp_path / "out")]) == 0
    res = _colony("case", "fig2", "--from-data", "--data", str(tmp_path / "none"),
                  "--out", str(tmp_path / "out2"))
    assert res.returncode == 2 and "no committed data for case fig2" in res.stderr


def test_the_solver_help_names_every_solver(capsys):
    from particles.config import SOLVERS

    with pytest.raises(SystemExit):
        cli.main(["particles", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert all(name in text for name in SOLVERS) and "bbpgd-cuda needs an NVIDIA GPU" in text
