"""The engine flags of ``colony continuum`` and ``colony particles``, read from the Configs.

Each command line's Config, as the command builds it (``cli.main`` down to the engine's run,
which is replaced by a recorder), equals a Config made directly with the expected values; every
Config field has a flag or is in ``cli.NO_FLAG``; each engine flag's help states its default.
"""

import dataclasses
import math
import re

import pytest

import continuum
import particles
from cases import cli, runs
from particles.config import FILL_ORIENTATIONS, SOLVERS, STEP_CONTROLS

CONFIGS = {"continuum": continuum.Config, "particles": particles.Config}

C = ["continuum", "--lam", "0.01", "--radius", "5"]
P = ["particles", "--lam", "0.01", "--radius", "3"]

#: (command line, expected Config keywords, expected keywords of the engine's run).
CASES = [
    (C, {"lam": 0.01, "radius": 5.0}, {}),
    (["continuum", "--lam", "0", "--time", "2"], {"lam": 0.0, "time": 2.0}, {}),
    (["continuum", "--lam", "-0.01", "--radius", "3"], {"lam": -0.01, "radius": 3.0}, {}),
    (C + ["--shape", "ellipse:2,1"], {"lam": 0.01, "radius": 5.0, "shape": "ellipse:2,1"}, {}),
    (C + ["--shape", "star:5,0.2"], {"lam": 0.01, "radius": 5.0, "shape": "star:5,0.2"}, {}),
    (C + ["--h-max", "0.4", "--n-nodes", "500"],
     {"lam": 0.01, "radius": 5.0, "h_max": 0.4, "n_nodes": 500}, {}),
    (C + ["--element", "P2"], {"lam": 0.01, "radius": 5.0, "element": "P2"}, {}),
    (C + ["--output-every", "0.5"], {"lam": 0.01, "radius": 5.0, "output_every": 0.5}, {}),
    (C + ["--output-every", "0"], {"lam": 0.01, "radius": 5.0, "output_every": 0.0}, {}),
    (C + ["--max-hours", "1.5"], {"lam": 0.01, "radius": 5.0, "max_hours": 1.5}, {}),
    (["continuum", "--radius", "5", "--strains", "1e-2,0", "--layout", "core:2"],
     {"lam": 0.01, "radius": 5.0, "strains": [[0.01, 1.0], [0.0, 1.0]], "layout": "core:2"},
     {}),
    (C + ["--strains", "1e-2:1,0:0.5", "--layout", "sector:1.5"],
     {"lam": 0.01, "radius": 5.0, "strains": [[0.01, 1.0], [0.0, 0.5]],
      "layout": "sector:1.5"}, {}),
    (C + ["--nutrient-length", "10"], {"lam": 0.01, "radius": 5.0, "nutrient_length": 10.0}, {}),
    (C + ["--nutrient-length", "10", "--monod-k", "0.5"],
     {"lam": 0.01, "radius": 5.0, "nutrient_length": 10.0, "monod_k": 0.5}, {}),
    (C + ["--nutrient-length", "10", "--monod-k", "inf"],
     {"lam": 0.01, "radius": 5.0, "nutrient_length": 10.0}, {}),
    (C + ["--set", "n_nodes=800", "--set", "courant=0.5", "--h-max", "0.45"],
     {"lam": 0.01, "radius": 5.0, "n_nodes": 800, "courant": 0.5, "h_max": 0.45}, {}),
    (["continuum", "--set", "lam=0.02", "--time", "1"], {"lam": 0.02, "time": 1.0}, {}),
    (["continuum", "--config", "{tmp}/cc.toml", "--radius", "6", "--n-nodes", "900",
      "--verbose"], {"lam": 0.02, "radius": 6.0, "n_nodes": 900, "q_min": 0.3}, {}),
    (C + ["--out", "{tmp}/c", "--overwrite", "--other-engine", "--quiet"],
     {"lam": 0.01, "radius": 5.0},
     {"out": "{tmp}/c", "overwrite": True, "other_engine": True, "progress": False}),
    (P, {"lam": 0.01, "radius": 3.0}, {}),
    (["particles", "--lam", "0", "--time", "1", "--dt", "0.01"],
     {"lam": 0.0, "time": 1.0, "dt": 0.01}, {}),
    (P + ["--seed", "7", "--division-noise", "0.1"],
     {"lam": 0.01, "radius": 3.0, "seed": 7, "division_noise": 0.1}, {}),
    (P + ["--init", "{tmp}/init.csv"], {"lam": 0.01, "radius": 3.0, "init": "{tmp}/init.csv"},
     {}),
    (P + ["--shape", "circle:3", "--fill-orientation", "rows"],
     {"lam": 0.01, "radius": 3.0, "shape": "circle:3", "fill_orientation": "rows"}, {}),
    (P + ["--shape", "line:4"], {"lam": 0.01, "radius": 3.0, "shape": "line:4"}, {}),
    (P + ["--solver", "apgd"], {"lam": 0.01, "radius": 3.0, "solver": "apgd"}, {}),
    (P + ["--solver", "bbpgd-cuda"], {"lam": 0.01, "radius": 3.0, "solver": "bbpgd-cuda"}, {}),
    (P + ["--step-control", "fixed"], {"lam": 0.01, "radius": 3.0, "step_control": "fixed"}, {}),
    (P + ["--step-control", "cost", "--dt", "0.05"],
     {"lam": 0.01, "radius": 3.0, "step_control": "cost", "dt": 0.05}, {}),
    (P + ["--threads", "1"], {"lam": 0.01, "radius": 3.0, "threads": 1}, {}),
    (P + ["--threads", "auto"], {"lam": 0.01, "radius": 3.0, "threads": "auto"}, {}),
    (P + ["--output-every", "0.1"], {"lam": 0.01, "radius": 3.0, "output_every": 0.1}, {}),
    (P + ["--output-every", "0"], {"lam": 0.01, "radius": 3.0, "output_every": 0.0}, {}),
    (P + ["--max-hours", "2"], {"lam": 0.01, "radius": 3.0, "max_hours": 2.0}, {}),
    (["particles", "--radius", "3", "--strains", "0,1e-2:0.5", "--layout", "mixture:0.5,0.5"],
     {"lam": 0.0, "radius": 3.0, "strains": [[0.0, 1.0], [0.01, 0.5]],
      "layout": "mixture:0.5,0.5"}, {}),
    (P + ["--nutrient-length", "5", "--monod-k", "2"],
     {"lam": 0.01, "radius": 3.0, "nutrient_length": 5.0, "monod_k": 2.0}, {}),
    (P + ["--nutrient-length", "3", "--dish-radius", "8"],
     {"lam": 0.01, "radius": 3.0, "nutrient_length": 3.0, "dish_radius": 8.0}, {}),
    (P + ["--change-step-policy", "--quiet"], {"lam": 0.01, "radius": 3.0},
     {"change_step_policy": True, "progress": False}),
    (P + ["--out", "{tmp}/p", "--overwrite", "--other-engine", "--verbose"],
     {"lam": 0.01, "radius": 3.0},
     {"out": "{tmp}/p", "overwrite": True, "other_engine": True}),
    (["particles", "--time", "1", "--config", "{tmp}/c.toml", "--set", "seed=3", "--seed", "4"],
     {"lam": 0.02, "time": 1.0, "seed": 4, "tol": 5e-4}, {}),
    (["particles", "--time", "1", "--config", "{tmp}/c.toml", "--set", "max_passes=5"],
     {"lam": 0.02, "time": 1.0, "seed": 1, "tol": 5e-4, "max_passes": 5}, {}),
    (["continuum", "--lam", "0", "--radius", "4", "--from-particles", "{tmp}/prun"],
     {"lam": 0.0, "radius": 4.0, "initial_sizes": "histogram"},
     {"start": ("{tmp}/prun", 1.0, 2.0)}),
    (["continuum", "--radius", "4", "--from-particles", "{tmp}/prun", "--alpha", "0.7",
      "--bandwidth", "3"],
     {"lam": 0.003, "radius": 4.0, "initial_sizes": "histogram"},
     {"start": ("{tmp}/prun", 0.7, 3.0)}),
]


def _filled(value, tmp):
    """``value`` with ``{tmp}`` replaced in its strings (in lists, tuples and dicts too)."""
    if isinstance(value, dict):
        return {k: _filled(v, tmp) for k, v in value.items()}
    if isinstance(value, str):
        return value.replace("{tmp}", str(tmp))
    if isinstance(value, (list, tuple)):
        return type(value)(_filled(v, tmp) for v in value)
    return value


@pytest.fixture
def recorded(monkeypatch, tmp_path):
    """``recorded(argv) -> (config, run keywords)``: the command's Config, the run not done."""
    from cases import handoff

    (tmp_path / "init.csv").write_text("x,y,theta,length\n0,0,0,1\n")
    (tmp_path / "c.toml").write_text("lam = 0.02\nseed = 1\ntol = 5e-4\n")
    (tmp_path / "cc.toml").write_text("lam = 0.02\nn_nodes = 700\nq_min = 0.3\n")
    monkeypatch.setattr(handoff, "final_particles", lambda run_dir: None)
    monkeypatch.setattr(handoff, "particle_lam", lambda run_dir: 0.003)
    monkeypatch.setattr(cli, "_handoff_start", lambda config, *rest: rest)
    calls = []
    for name in CONFIGS:
        engine = runs.Engine(name, lambda config, out, **kw: calls.append((config, out, kw)))
        monkeypatch.setitem(cli.ENGINES, name, engine)

    def run(argv):
        assert cli.main(_filled(argv, tmp_path)) == 0
        (config, out, kw), = calls
        calls.clear()
        return config, {"out": str(out), **kw}

    return run


@pytest.mark.parametrize("argv,fields,run_keywords", CASES, ids=[" ".join(c[0]) for c in CASES])
def test_a_command_line_makes_the_config_of_its_flags(recorded, tmp_path, argv, fields,
                                                      run_keywords):
    config, kw = recorded(argv)
    expected = CONFIGS[argv[0]](**_filled(fields, tmp_path))
    assert config == expected
    default_out = f"runs/{argv[0]}"
    want = {"out": default_out, "overwrite": False, "other_engine": False, "progress": True,
            **({"change_step_policy": False} if argv[0] == "particles" else {"start": None}),
            **_filled(run_keywords, tmp_path)}
    assert {k: kw[k] for k in want} == want


def test_every_flag_of_both_engines_is_exercised():
    for engine in CONFIGS:
        given = {a for argv, _, _ in CASES if argv[0] == engine for a in argv
                 if a.startswith("--")}
        options = {o for a in _actions(engine) for o in a.option_strings if o.startswith("--")}
        assert options - given == {"--help"}, engine


@pytest.mark.parametrize("argv,needle", [
    (P + ["--dt", "inf"], "--dt must be finite, got inf"),
    (C + ["--h-max", "nan"], "--h-max must be finite, got nan"),
    (P + ["--division-noise", "inf"], "--division-noise must be finite"),
    (P + ["--solver", "twolevel"], "twolevel was removed"),
    (C + ["--element", "P3"], "element must be"),
    (P + ["--threads", "0"], "threads must be auto or an integer"),
    (P + ["--strains", "1e-2,0"], "2 strains need --layout"),
    (C + ["--alpha", "1"], "--alpha needs --from-particles"),
    (C + ["--nutrient-length", "inf"], "--nutrient-length: expected a finite number, got inf"),
    (P + ["--monod-k", "2"], "monod_k = 2 needs nutrient_length"),
    (P + ["--dish-radius", "6"], "dish_radius = 6 needs nutrient_length"),
    (P + ["--nutrient-length", "3", "--dish-radius", "0.4"], "dish_radius 0.4 is not larger"),
    (["particles", "--radius", "3"], "lam is required"),
])
def test_a_bad_flag_ends_in_one_line(colony, argv, needle):
    status, err = colony(*argv)
    assert status == 2 and err.count("\n") == 1 and needle in err, err


@pytest.mark.parametrize("argv,needle", [
    (P + ["--step-control", "x"], "choose from overlap, fixed, cost"),
    (P + ["--seed", "1.5"], "invalid int value"),
    (P + ["--threads", "x"], "expected auto or an integer"),
    (["particles", "--lam", "0"], "one of the arguments --radius --time is required"),
    (C + ["--time", "1"], "not allowed with argument --radius"),
])
def test_argparse_refuses_in_one_line(capsys, argv, needle):
    with pytest.raises(SystemExit) as stop:
        cli.main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.count("\n") == 1, err
    assert needle in err.replace("'", ""), err  # Python 3.12 quotes the choices


def _actions(engine):
    sub = next(a for a in cli.parser()._actions if isinstance(a, cli.argparse._SubParsersAction))
    return sub.choices[engine]._actions


@pytest.mark.parametrize("engine", list(CONFIGS))
def test_every_config_field_has_a_flag_or_is_listed_without(engine):
    dests = {a.dest for a in _actions(engine)}
    for field in dataclasses.fields(CONFIGS[engine]):
        flagged = field.name in dests
        assert flagged != (field.name in cli.NO_FLAG[engine]), field.name
    assert set(cli.NO_FLAG[engine]) <= {f.name for f in dataclasses.fields(CONFIGS[engine])}


@pytest.mark.parametrize("engine", list(CONFIGS))
def test_each_engine_flag_states_the_config_default(engine):
    """The help of a flag of a Config field names that field's default, read from the class."""
    fields = {f.name: f for f in dataclasses.fields(CONFIGS[engine])}
    checked = 0
    for action in _actions(engine):
        field = fields.get(action.dest)
        if field is None or field.name in ("lam", "radius", "time"):  # required, not defaulted
            continue
        text = " ".join(action.help.split())
        assert "default" in text, f"--{action.dest}: {text}"
        default = field.default
        if isinstance(default, str):
            assert re.search(rf"(^|[\s(:\"]){re.escape(default)}\b", text), (default, text)
        elif isinstance(default, (int, float)):
            assert re.search(rf"default:? {default:g}\b", text), (default, text)
        else:  # None or (): the command line's word for it
            assert cli.DEFAULT_WORDS.get(field.name, "none") in text, (field.name, text)
        checked += 1
    assert checked >= (10 if engine == "continuum" else 15), checked


def test_the_choices_of_a_table_are_all_named():
    from continuum.fem import ELEMENTS

    helps = {(engine, a.dest): " ".join(a.help.split())
             for engine in CONFIGS for a in _actions(engine)}
    for key, table in ((("particles", "solver"), SOLVERS),
                       (("particles", "step_control"), STEP_CONTROLS),
                       (("particles", "fill_orientation"), FILL_ORIENTATIONS),
                       (("continuum", "element"), ELEMENTS)):
        for name in table:
            assert re.search(rf"(^|[\s(:\"]){re.escape(name)}\b", helps[key]), (key, name)
    assert "bbpgd-cuda needs an NVIDIA GPU" in helps["particles", "solver"]


def test_the_defaults_match_the_config_numbers():
    """The continuum's --shape names the initial radius of the Config, 0.40 (sqrt(b/pi))."""
    text = " ".join(next(a for a in _actions("continuum") if a.dest == "shape").help.split())
    assert f"{continuum.Config.initial_radius:.2f}" in text
    assert math.isclose(continuum.Config.initial_radius, math.sqrt(0.5 / math.pi))
