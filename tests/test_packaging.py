"""What ``pip install .`` gives is enough for every command: the runtime imports are core.

Every third-party module that ``continuum``, ``particles`` or ``cases`` imports (at the top of a
module or inside a function) must come from a distribution among pyproject's core
``dependencies``, except the viewers of the ``viz`` extra, which are imported where used and
named in their error. So ``colony case`` works after the README's install.
"""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OURS = {"continuum", "particles", "cases", "tests"}
OPTIONAL = {"ovito", "pyvista"}  # the viz extra


def imported_modules(package: str) -> set[str]:
    """Top-level names of every module imported anywhere in ``package``'s source."""
    names = set()
    for path in (ROOT / package).rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return names


def core_distributions() -> set[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return {re.split(r"[\[<>=!~ ;]", d)[0].lower().replace("_", "-")
            for d in project["dependencies"]}


def test_every_runtime_import_is_a_core_dependency():
    third_party = set().union(*(imported_modules(p) for p in ("continuum", "particles", "cases")))
    third_party -= OURS | OPTIONAL | set(sys.stdlib_module_names) | {"__future__"}
    providers = packages_distributions()
    core = core_distributions()
    missing = {m: providers.get(m) for m in sorted(third_party)
               if not {d.lower().replace("_", "-") for d in providers.get(m, [])} & core}
    assert not missing, f"imported but not core dependencies (module: distributions): {missing}"
    assert "dask" in third_party  # the check sees the sweep's imports


def test_an_installed_package_knows_its_commit(tmp_path):
    """Outside a git checkout, rundir.git_commit reads the commit setup.py's build recorded."""
    import importlib.util
    import json
    import shutil

    from cases import rundir

    (tmp_path / "cases").mkdir()
    shutil.copy(rundir.__file__, tmp_path / "cases" / "rundir.py")
    (tmp_path / "cases" / "_build.json").write_text(json.dumps({"git_commit": "abc123"}))
    spec = importlib.util.spec_from_file_location("installed_rundir",
                                                  tmp_path / "cases" / "rundir.py")
    installed = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(installed)
    assert installed.git_commit() == "abc123"


def test_the_wheel_ships_the_library_not_the_measurements():
    """The wheel holds the benches users run on their machine, not the one-off measurements.

    Those behind docs/benchmarks.md and docs/validation.md are scripts in docs/measurements/,
    outside pyproject's package patterns and in no package, and nothing in the package imports
    one.
    """
    from fnmatch import fnmatch

    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    include = find["packages"]["find"]["include"]
    assert any(fnmatch("cases.bench", pattern) for pattern in include)
    assert not any(fnmatch(name, pattern) for name in ("docs", "docs.measurements")
                   for pattern in include)
    kept = {"__init__", "continuum", "particles"}
    assert {p.stem for p in (ROOT / "cases" / "bench").glob("*.py")} == kept
    for moved in ("records", "cost_growth", "ensemble_paper", "stability_radius"):
        assert not list((ROOT / "cases").rglob(f"{moved}.py")), moved
        assert (ROOT / "docs" / "measurements" / f"{moved}.py").is_file(), moved
    measurements = ROOT / "docs" / "measurements"
    assert {"contact_solvers", "timestep", "elements", "handoff"} <= {
        p.stem for p in measurements.glob("*.py")}
    assert not (measurements / "__init__.py").exists()
    for package in ("continuum", "particles", "cases"):
        for path in (ROOT / package).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.ImportFrom) and node.module == "cases.bench":
                    modules = [f"cases.bench.{a.name}" for a in node.names]
                elif isinstance(node, ast.ImportFrom):
                    modules = [node.module or ""]
                elif isinstance(node, ast.Import):
                    modules = [a.name for a in node.names]
                else:
                    continue
                names = {m.split(".")[2] for m in modules if m.startswith("cases.bench.")}
                assert names <= kept, (path, names - kept)
