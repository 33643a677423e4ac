"""The import graph of ``continuum``, ``particles`` and ``cases`` has no cycle (issue 43).

Every ``import x`` / ``from x import y`` of every module of the three packages counts, at the top
of the file or inside a function alike (a function-level import only hides a cycle until the
function runs). Relative imports are resolved; ``from pkg import name`` where ``pkg.name`` is a
module counts as importing that module. An import of a package is an import of its
``__init__`` only (``from cases import analysis as A`` imports ``cases.analysis``, not each of
its submodules), and a package ``__init__`` importing its own submodules (re-exporting them) is
left out, so a submodule importing its package's ``__init__`` is no false cycle.

The layers: the two engines do not import each other, and neither imports ``cases``.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("continuum", "particles", "cases")


def modules() -> dict[str, Path]:
    """Dotted name -> source file of every module of the three packages (``pkg`` = __init__)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The modules among ``known`` that module ``name`` (at ``path``) imports anywhere."""
    is_package = path.name == "__init__.py"
    targets = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: from the module's package (its own name, for __init__)
                base = name.split(".")
                drop = node.level - 1 if is_package else node.level
                base = base[:len(base) - drop] if drop else base
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            targets.add(module)
            targets |= {f"{module}.{alias.name}" for alias in node.names
                        if f"{module}.{alias.name}" in known}
    found = {t for t in targets if t in known and t != name}
    if is_package:  # a package's __init__ re-exporting its own submodules
        found = {t for t in found if not t.startswith(name + ".")}
    return found


def graph() -> dict[str, set[str]]:
    """Module -> the modules of the three packages it imports."""
    files = modules()
    return {name: imports_of(name, path, set(files)) for name, path in files.items()}


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``edges`` as ``[a, b, ..., a]``, or None (depth-first, iterative)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    for start in sorted(edges):
        if start in state:
            continue
        path = [start]
        stack = [iter(sorted(edges[start]))]
        state[start] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            elif nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(sorted(edges[nxt])))
    return None


def all_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Cycles of ``edges``, one at a time: each found cycle's closing edge removed, then again."""
    edges = {k: set(v) for k, v in edges.items()}
    cycles = []
    while (cycle := find_cycle(edges)) is not None:
        cycles.append(cycle)
        edges[cycle[-2]].discard(cycle[-1])
    return cycles


def test_the_graph_is_read():
    """The walk sees known edges: function-level, relative, ``from pkg import module``."""
    edges = graph()
    assert "cases.analysis" in edges["cases.datasets"]  # from cases import analysis as A
    assert "cases.handoff" in edges["cases.cli"]  # inside a function: from cases import handoff
    assert "particles.geometry" in edges["particles.measures"]  # from .geometry import B
    assert "particles.solvers.bbpgd" in edges["particles.simulation"]  # from .solvers import
    assert not any(t.startswith("cases.analysis.") for t in edges["cases.analysis"])


def test_no_import_cycle():
    cycles = all_cycles(graph())
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_layers():
    """The engines import neither ``cases`` nor each other."""
    wrong = [f"{a} -> {b}" for a, targets in graph().items() for b in sorted(targets)
             if (a.split(".")[0], b.split(".")[0]) in {("continuum", "cases"),
                                                        ("particles", "cases"),
                                                        ("continuum", "particles"),
                                                        ("particles", "continuum")}]
    assert not wrong, "engine imports across layers:\n" + "\n".join(wrong)


def test_figures_import_no_study():
    """``cases.figures`` import no study, ``analysis`` and ``datasets`` neither figure nor study.

    What figures and studies share (the 1D reference's rings: ``cases.analysis.rings``; the
    ensemble's data and its merge: ``cases.datasets``) lies below both, so a study may draw with
    ``cases.figures.draw`` without a cycle.
    """
    below = ("cases.analysis", "cases.datasets")
    wrong = [f"{a} -> {b}" for a, targets in graph().items() for b in sorted(targets)
             if (a.startswith("cases.figures") and b.startswith("cases.studies"))
             or (a.startswith(below) and b.startswith(("cases.figures", "cases.studies")))]
    assert not wrong, "imports against the layers of cases:\n" + "\n".join(wrong)
