"""README.md, the front page: its example runs, its commands are CI's, its links resolve.

Its Python example runs as written, its set-up commands are the ones CI runs, and every file or
picture it (and each documentation page) links to exists, anchors included. The example is
every ```python block of README.md, run in order in one namespace inside a temporary folder
(so files it writes land there).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
# Pages linked from README whose own links are checked too (the pages this repository owns).
PAGES = [
    "README.md",
    "docs/index.md",
    "docs/tutorial.md",
    "docs/validation.md",
    "docs/benchmarks.md",
    "docs/results.md",
    "docs/run_folders.md",
    "docs/clusters.md",
    "CHANGELOG.md",
]

MAIN_JOB = (
    "python3 -m venv .venv && . .venv/bin/activate && pip install . && "
    "colony continuum --lam 1e-2 --radius 40 --out runs/continuum"
)
TEST_COMMAND = (
    "python3 -m venv .venv && . .venv/bin/activate && pip install -c .ci/constraints.txt "
    "'.[test]' && python -m pytest -q"
)

def code_blocks(text: str, language: str) -> list[str]:
    """The fenced code blocks of one language in a Markdown text, in order."""
    return re.findall(rf"^```{language}\n(.*?)^```", text, flags=re.M | re.S)


def run_blocks(blocks: list[str], name: str, folder: Path, monkeypatch) -> None:
    """Execute code blocks in order in one namespace, in ``folder``."""
    monkeypatch.chdir(folder)
    namespace: dict = {"__name__": "__main__"}
    for k, block in enumerate(blocks):
        exec(compile(block, f"{name}, python block {k + 1}", "exec"), namespace)  # noqa: S102


def github_slug(heading: str) -> str:
    """The anchor GitHub (and myst's ``heading_anchors``) gives a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Anchors of the headings of a Markdown file (outside code blocks)."""
    text = re.sub(r"^```.*?^```", "", path.read_text(), flags=re.M | re.S)
    return {github_slug(m) for m in re.findall(r"^#{1,6} (.+)$", text, flags=re.M)}


def local_links(path: Path) -> list[str]:
    """Targets of the Markdown links and images of a file that are not URLs."""
    text = re.sub(r"^```.*?^```", "", path.read_text(), flags=re.M | re.S)
    targets = re.findall(r"\]\(([^)\s]+)\)", text)
    return [t for t in targets if not re.match(r"[a-z]+:", t)]


def test_readme_python_example_runs(tmp_path, monkeypatch):
    blocks = code_blocks(README.read_text(), "python")
    assert blocks, "README.md has no ```python block"
    run_blocks(blocks, "README.md", tmp_path, monkeypatch)


def test_setup_commands_first_and_identical_to_ci():
    text = README.read_text()
    bash = code_blocks(text, "bash")
    assert [b.strip() for b in bash[:2]] == [MAIN_JOB, TEST_COMMAND]
    # Nothing but the title and its introduction before "Set up".
    assert re.findall(r"^## .*$", text, flags=re.M)[0] == "## Set up"
    assert text.index(TEST_COMMAND) < text.index("\n## ", text.index("## Set up"))
    # .ci/run runs the same command (pip quiet there).
    ci = (ROOT / ".ci" / "run").read_text()
    ci_test = "pip install -q -c .ci/constraints.txt '.[test]' && python -m pytest -q"
    assert ci_test in ci, "the test command of .ci/run changed: keep README's identical"
    assert TEST_COMMAND.endswith(ci_test.replace("pip install -q ", "pip install "))


@pytest.mark.parametrize("page", PAGES)
def test_links_and_pictures_exist(page):
    path = ROOT / page
    assert path.is_file(), f"{page} is listed in PAGES but does not exist"
    broken = []
    for target in local_links(path):
        file, _, fragment = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        if not dest.exists():
            broken.append(target)
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            broken.append(target)
    assert not broken, f"{page}: links to nothing: {broken}"


def test_readme_keeps_the_user_contract():
    text = README.read_text()
    for heading in (
        "### Run folders: safe, resumable, reproducible",
        "### Bad input and faults",
        "## Opening the outputs",
        "## What is validated",
    ):
        assert heading in text
    for page in ("docs/validation.md", "docs/benchmarks.md", "docs/results.md", "docs/tutorial.md"):
        assert f"]({page}" in text, f"README does not link {page}"
