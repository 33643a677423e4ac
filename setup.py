"""Build hook: record the git commit of the sources in the installed package.

``pip install .`` from a git checkout builds a wheel without the ``.git`` folder, so a run of
the installed package could not tell its commit. The build writes it (``git rev-parse HEAD``,
``+dirty`` when the engine or case sources differ from it) into ``cases/_build.json`` of the
build, where ``cases.rundir.git_commit`` reads it. Everything else is in pyproject.toml.
"""

import importlib.util
import json
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


def _commit() -> str | None:
    """``cases.rundir.git_commit`` of this checkout (rundir.py loaded alone: standard library)."""
    spec = importlib.util.spec_from_file_location(
        "_rundir", Path(__file__).resolve().parent / "cases" / "rundir.py")
    rundir = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rundir)
    return rundir.git_commit()


class BuildWithCommit(build_py):
    """build_py, then ``cases/_build.json`` with the commit in the build."""

    def run(self):
        """Build as setuptools does, then write the commit."""
        super().run()
        target = Path(self.build_lib) / "cases" / "_build.json"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(json.dumps({"git_commit": _commit()}) + "\n")


setup(cmdclass={"build_py": BuildWithCommit})
