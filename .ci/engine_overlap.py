#!/usr/bin/env python3
"""The lines the two engines hold in common: a maintainer's measure of copies (issue 43).

For every module name that both ``continuum/`` and ``particles/`` have at a commit (default
HEAD), the lines of the blocks of six or more consecutive equal lines (at least six of them not
blank) that ``difflib.SequenceMatcher`` matches between the two files, summed. A module that is a
symbolic link to the other engine's (``particles/runfiles.py``) is one source and not counted.
Usage, from the repository root::

    python .ci/engine_overlap.py [REV]

Measured: 441 lines at 4931671 (the run files and controls copied into both checkpoint.py and
simulation.py), 78 after (the contract's shared docstrings, import lists and a few lines).
"""

from __future__ import annotations

import difflib
import subprocess
import sys

MIN_BLOCK = 6


def files(rev: str, package: str) -> dict[str, str]:
    """{module path inside the package: path in the repository} of the Python files at ``rev``."""
    out = subprocess.run(["git", "ls-tree", "-r", "--name-only", rev, f"{package}/"],
                         capture_output=True, text=True, check=True).stdout.split()
    return {f.split("/", 1)[1]: f for f in out if f.endswith(".py")}


def lines(rev: str, path: str) -> list[str]:
    """The lines of ``path`` at ``rev`` (a symbolic link: its target's name)."""
    return subprocess.run(["git", "show", f"{rev}:{path}"], capture_output=True, text=True,
                          check=True).stdout.splitlines()


def overlap(a: list[str], b: list[str]) -> int:
    """Lines in matching blocks of >= MIN_BLOCK lines, MIN_BLOCK of them not blank."""
    blocks = difflib.SequenceMatcher(None, a, b, autojunk=False).get_matching_blocks()
    return sum(m.size for m in blocks
               if sum(bool(x.strip()) for x in a[m.a:m.a + m.size]) >= MIN_BLOCK)


def main(rev: str = "HEAD") -> int:
    """Print the overlap per module and in all; return the total."""
    c, p = files(rev, "continuum"), files(rev, "particles")
    total = 0
    for name in sorted(set(c) & set(p)):
        a, b = lines(rev, c[name]), lines(rev, p[name])
        if len(b) == 1 and b[0].startswith("../continuum/"):  # a link: one source
            print(f"{name}: one source (particles/{name} links to continuum/{name})")
            continue
        n = overlap(a, b)
        total += n
        if n:
            print(f"{name}: {n}")
    print(f"in all: {total} lines")
    return total


if __name__ == "__main__":
    main(*sys.argv[1:])
