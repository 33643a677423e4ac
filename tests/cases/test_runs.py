"""cases.runs.run: the command line's run folder from Python, the same bytes for either engine."""

from __future__ import annotations

import pytest

import continuum
import particles
from cases import cli
from cases.runs import run

RUNS = {
    "continuum": (continuum.Config(lam=1e-2, radius=1.5, n_nodes=200),
                  ["--lam", "1e-2", "--radius", "1.5", "--set", "n_nodes=200"]),
    "particles": (particles.Config(lam=1e-2, radius=3.0, seed=2),
                  ["--lam", "1e-2", "--radius", "3", "--seed", "2"]),
}


def files(folder):
    """Every file below ``folder`` (relative name: bytes), run.json (times, command) aside."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != "run.json"}


@pytest.mark.parametrize("engine", list(RUNS))
def test_python_run_is_the_command_lines(engine, tmp_path):
    config, flags = RUNS[engine]
    run(config, tmp_path / "py" / "run")  # parents created, as the command creates them
    assert cli.main([engine, *flags, "--out", str(tmp_path / "cli"), "--quiet"]) == 0
    py, command = files(tmp_path / "py" / "run"), files(tmp_path / "cli")
    assert py.keys() == command.keys() and {"profile.csv", "config.json"} <= py.keys()
    assert py == command
    with pytest.raises(Exception, match="exists"):  # a finished folder is never overwritten
        run(config, tmp_path / "py" / "run")


def test_another_config_is_refused():
    with pytest.raises(TypeError, match="continuum.Config or particles.Config"):
        run(object(), "nowhere")
