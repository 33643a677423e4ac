"""Strict configuration (issue 28, "Configuration types").

Every field of both engines' ``Config`` is checked against its type (``Config.type_mismatch``:
a bool is no number, a string no bool, an int where an int is needed, finite floats), with one
line naming the key and where it came from (``--config FILE: key lam: ...``, ``--set lam``,
``--lam``). Property-based tests (hypothesis) drive ``cases.cli.build_config`` with random TOML
values for random keys and random ``--set`` strings: a valid configuration or a one-line
ValueError, never another exception.
"""

import dataclasses
import datetime
import json
import math
import string
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import continuum
import particles
from cases import cli

from .test_faults import one_line_error

ENGINES = {"continuum": continuum.Config, "particles": particles.Config}


def build(cls, toml_text: str | None = None, sets=(), flags=None, folder: Path | None = None):
    """``cli.build_config`` of a TOML text (written to ``folder``/c.toml) and ``--set`` items."""
    path = None
    if toml_text is not None:
        path = folder / "c.toml"
        path.write_text(toml_text, encoding="utf-8")
    return cli.build_config(cls, None if path is None else str(path), list(sets), flags or {})


def one_line(err: BaseException) -> str:
    text = str(err)
    assert text.strip() and "\n" not in text, repr(text)
    return text


# --------------------------------------------------------------------------- the cases


@pytest.mark.parametrize("engine,toml,expected", [
    ("particles", "lam = true", "key lam: expected a number, got true"),
    ("continuum", "lam = true", "key lam: expected a number, got true"),
    ("continuum", 'lam = 0.01\nwrite_fields = "yes"',
     'key write_fields: expected true or false, got "yes"'),
    ("continuum", "lam = 0.01\nwrite_fields = 1",
     "key write_fields: expected true or false, got 1"),
    ("particles", "lam = 0.01\nshape = 5", "key shape: expected a string, got 5"),
    ("continuum", "lam = 0.01\nshape = 5", "key shape: expected a string, got 5"),
    ("particles", "lam = 0.01\ninit = 5", "key init: expected a string, got 5"),
    ("particles", "lam = 0.01\nseed = 1.5", "key seed: expected an integer, got 1.5"),
    ("particles", "lam = 0.01\nseed = true", "key seed: expected an integer, got true"),
    ("particles", "lam = 0.01\nthreads = 2.0",
     "key threads: expected an integer or a string, got 2.0"),
    ("continuum", "lam = 0.01\nn_nodes = 1e3", "key n_nodes: expected an integer, got 1000.0"),
    ("particles", "lam = inf", "key lam: expected a finite number, got inf"),
    ("continuum", "lam = nan", "key lam: expected a finite number, got nan"),
    ("particles", "lam = 0.01\nradius = 1979-05-27", "key radius: expected a number, got "
                                                      "datetime.date(1979, 5, 27)"),
    ("continuum", "lam = [1, 2]", "key lam: expected a number, got [1, 2]"),
    ("continuum", "lam = 1" + "0" * 400, "key lam: expected a number, got 1000"),
    ("particles", 'lam = 0.01\nsolver = "bbpgd\\nsecond line"', "unknown solver"),
])
def test_toml_value_of_the_wrong_type_names_the_file_and_key(tmp_path, engine, toml, expected):
    with pytest.raises(ValueError) as err:
        build(ENGINES[engine], toml, flags={"radius": 4.0}, folder=tmp_path)
    message = one_line(err.value)
    assert expected in message, message
    if "key" in expected:
        assert message.startswith(f"--config {tmp_path / 'c.toml'}: key "), message
        assert len(message) < 200, message  # long values are cut


@pytest.mark.parametrize("engine,toml,expected", [
    ("continuum", "lam = 0.01\nwrite_fields = false", {"write_fields": False}),
    ("particles", "lam = 1\nseed = 3", {"lam": 1, "seed": 3}),
    ("particles", 'lam = 0.01\nthreads = "auto"\nsolver_tol = 1e-4', {"solver_tol": 1e-4}),
])
def test_toml_values_of_the_right_type(tmp_path, engine, toml, expected):
    config = build(ENGINES[engine], toml, flags={"radius": 4.0}, folder=tmp_path)
    assert {k: getattr(config, k) for k in expected} == expected


def test_unknown_toml_key_names_the_file(tmp_path):
    with pytest.raises(cli.UsageError, match=r"^--config .*c\.toml: unknown setting\(s\) "
                                             r"write_fields; known: "):
        build(particles.Config, "lam = 0.01\nwrite_fields = true", flags={"radius": 4.0},
              folder=tmp_path)


def test_toml_not_utf8(tmp_path):
    (tmp_path / "c.toml").write_bytes(b"lam = \xff\n")
    with pytest.raises(cli.UsageError, match="can.t decode byte"):
        cli.build_config(particles.Config, str(tmp_path / "c.toml"), [], {"radius": 4.0})


@pytest.mark.parametrize("engine,sets,expected", [
    ("particles", ["seed=1.5"], "--set seed: expected an integer, got '1.5'"),
    ("particles", ["lam=abc"], "--set lam: expected a number, got 'abc'"),
    ("particles", ["lam=inf"], "--set lam: expected a finite number, got 'inf'"),
    ("particles", ["lam=true"], "--set lam: expected a number, got 'true'"),
    ("continuum", ["write_fields=maybe"], "--set write_fields: expected true or false"),
    ("continuum", ["n_nodes=2.5e3"], "--set n_nodes: expected an integer, got '2.5e3'"),
    ("particles", ["threads=two"], "--set threads: expected auto or an integer"),
    ("particles", ["init=5"], "init file not found: 5"),
])
def test_set_value_of_the_wrong_type(engine, sets, expected):
    with pytest.raises(ValueError) as err:
        build(ENGINES[engine], sets=["lam=0.01", *sets], flags={"radius": 4.0})
    assert expected in one_line(err.value)


@pytest.mark.parametrize("engine,sets,expected", [
    ("continuum", ["write_fields=no"], {"write_fields": False}),
    ("continuum", ["write_fields=1"], {"write_fields": True}),
    ("continuum", ["lam=1", "n_nodes=300"], {"lam": 1.0, "n_nodes": 300}),
    ("particles", ["shape=5"], {"shape": "5"}),  # a string: the shape parser refuses it
    ("particles", ["seed=7", "threads=auto", "step_control=fixed"],
     {"seed": 7, "threads": "auto", "step_control": "fixed"}),
])
def test_set_values_parsed_to_the_type_of_the_field(engine, sets, expected):
    config = build(ENGINES[engine], sets=["lam=0.01", *sets], flags={"radius": 4.0})
    got = {k: getattr(config, k) for k in expected}
    assert got == expected and all(type(got[k]) is type(v) for k, v in expected.items())


def test_flag_of_the_wrong_type_is_named():
    with pytest.raises(cli.UsageError, match=r"^--seed: expected an integer, got 1\.5$"):
        build(particles.Config, flags={"lam": 0.01, "radius": 4.0, "seed": 1.5})


# --------------------------------------------------------------------------- the Python API


VALID = {"continuum": {"lam": 0.01, "radius": 2.0}, "particles": {"lam": 0.01, "radius": 2.0}}


@pytest.mark.parametrize("engine", ENGINES)
def test_every_field_checked_against_its_type(engine):
    cls = ENGINES[engine]
    for field in dataclasses.fields(cls):
        default = field.default if field.default is not dataclasses.MISSING else 0.01
        assert cls.type_mismatch(field.name, default) is None, field.name
        for wrong in (object(), [1.0], b"x"):
            with pytest.raises(ValueError, match=f"^{field.name} must be "):
                cls(**{**VALID[engine], field.name: wrong}).validate()
        if "float" in field.type:  # a bool is no number, inf no finite number
            infinite = () if field.name == "monod_k" else ((math.inf, "a finite number"),)
            for wrong, what in ((True, "a number"), *infinite):  # monod_k = inf: first order
                with pytest.raises(ValueError, match=f"^{field.name} must be {what}, got"):
                    cls(**{**VALID[engine], field.name: wrong}).validate()
        if field.type == "bool":
            with pytest.raises(ValueError, match=f"^{field.name} must be true or false"):
                cls(**{**VALID[engine], field.name: "yes"}).validate()
        if field.type == "int":
            with pytest.raises(ValueError, match=f"^{field.name} must be an integer"):
                cls(**{**VALID[engine], field.name: 3.0}).validate()


# --------------------------------------------------------------------------- end to end


@pytest.mark.parametrize("engine,toml,needle", [
    ("particles", "lam = true\n", "key lam: expected a number, got true"),
    ("continuum", 'lam = 0.01\nwrite_fields = "yes"\n', "key write_fields: expected true or"),
    ("particles", "lam = 0.01\ninit = 5\n", "key init: expected a string, got 5"),
    ("continuum", "lam = 0.01\nshape = 5\n", "key shape: expected a string, got 5"),
])
def test_colony_reports_the_file_and_key(colony, tmp_path, engine, toml, needle):
    f = tmp_path / "bad.toml"
    f.write_text(toml)
    status, err = colony(engine, "--radius", "2", "--config", str(f), "--quiet",
                         "--out", str(tmp_path / "run"))
    one_line_error(status, err, f"--config {f}: ", needle)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


# --------------------------------------------------------------------------- properties


def toml_value(value) -> str:
    """``value`` written as a TOML value (strings as JSON strings, which TOML reads alike)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else {math.inf: "inf", -math.inf: "-inf"}.get(
            value, repr(value))
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (datetime.date, datetime.datetime)):
        return value.isoformat()
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    return str(value)


SCALARS = (st.booleans() | st.integers() | st.integers(-3, 300) | st.floats()
           | st.floats(min_value=1e-3, max_value=1e3) | st.text(max_size=12)
           | st.sampled_from(["auto", "fixed", "P2", "bbpgd", "rows", "circle:2", "star:5,0.2",
                              "line:3", "polygon:missing.csv", "birth", "finite-volume"])
           | st.dates() | st.datetimes())
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
    st.text(string.ascii_letters, min_size=1, max_size=4), inner, max_size=2), max_leaves=4)


def keys(cls):
    return (st.sampled_from([f.name for f in dataclasses.fields(cls)] + ["nope", "lam", "Lam"])
            | st.text(max_size=6))


def assert_config_or_one_line(cls, call):
    """``call()`` gives a configuration of ``cls`` or a ValueError of one line, nothing else."""
    try:
        config = call()
    except ValueError as err:
        one_line(err)
    else:
        assert isinstance(config, cls)


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_random_toml_values_never_a_traceback(engine, data):
    cls = ENGINES[engine]
    table = data.draw(st.dictionaries(keys(cls), VALUES, max_size=4), label="toml")
    flags = data.draw(st.sampled_from([{}, {"radius": 4.0}, {"lam": 0.01, "time": 1.0}]))
    text = "".join(f"{json.dumps(k)} = {toml_value(v)}\n" for k, v in table.items())
    with tempfile.TemporaryDirectory() as folder:
        assert_config_or_one_line(cls, lambda: build(cls, text, flags=flags, folder=Path(folder)))


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_random_toml_text_never_a_traceback(engine, data):
    cls = ENGINES[engine]
    text = data.draw(st.text(max_size=60) | st.builds(
        lambda k, v: f"{k} = {v}\n", keys(cls), st.text(max_size=20)))
    with tempfile.TemporaryDirectory() as folder:
        assert_config_or_one_line(
            cls, lambda: build(cls, text, flags={"lam": 0.01, "radius": 4.0}, folder=Path(folder)))


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=80, deadline=None)
@given(data=st.data())
def test_random_set_strings_never_a_traceback(engine, data):
    cls = ENGINES[engine]
    item = st.text(max_size=30) | st.builds(
        lambda k, v: f"{k}={v}", keys(cls),
        st.text(max_size=15) | st.floats().map(repr) | st.integers().map(str)
        | st.sampled_from(["true", "no", "auto", "inf", "-0", "1e400", "1_000", " 2 "]))
    sets = data.draw(st.lists(item, max_size=4), label="sets")
    flags = data.draw(st.sampled_from([{}, {"radius": 4.0}, {"lam": 0.01, "radius": 4.0}]))
    assert_config_or_one_line(cls, lambda: build(cls, sets=sets, flags=flags))
