"""The documentation site builds with warnings as errors, and the tutorial's code runs.

The build is ``sphinx-build -W --keep-going -b html docs OUT`` (the ``docs`` extra, also in the
``test`` extra so CI builds it); skipped where Sphinx is not installed. Warnings located in the
docstrings of the code fail it like any other (see ``docs/conf.py``).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
def code_blocks(text: str, language: str) -> list[str]:
    """The fenced code blocks of one language in a Markdown text, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```", text, flags=re.M | re.S)


def test_sphinx_build_without_warnings(tmp_path):
    pytest.importorskip("sphinx")
    pytest.importorskip("numpydoc")
    pytest.importorskip("myst_parser")
    out = tmp_path / "html"
    # A fresh doctree folder each time (-d): no state kept from an earlier build.
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-W",
            "--keep-going",
            "-b",
            "html",
            "-q",
            "-d",
            str(tmp_path / "doctrees"),
            str(DOCS),
            str(out),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-6000:]
    for page in (
        "index.html",
        "tutorial.html",
        "validation.html",
        "benchmarks.html",
        "results.html",
        "api/index.html",
        "api/generated/continuum.html",
        "api/generated/particles.html",
        "api/generated/cases.html",
    ):
        assert (out / page).exists(), page
    # Every module of the engines has its page.
    for package in ("continuum", "particles"):
        for module in sorted((ROOT / package).glob("[!_]*.py")):
            assert (out / "api" / "generated" / f"{package}.{module.stem}.html").exists(), module


def test_tutorial_code_runs(tmp_path, monkeypatch):
    blocks = code_blocks((DOCS / "tutorial.md").read_text(), "python")
    assert blocks
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__main__"}
    for k, block in enumerate(blocks):
        exec(compile(block, f"docs/tutorial.md, python block {k + 1}", "exec"), namespace)  # noqa: S102
