"""Benchmark of the pressure's elements: hand-written P1, scikit-fem P1 and scikit-fem P2.

Names: "P1" the hand-written P1 assembly (continuum.pressure.P1Assembler, the simulation's
``element = "P1"``), "P1-skfem" P1 assembled by scikit-fem (continuum.fem.LagrangeSpace),
"P2" P2 assembled by scikit-fem (``element = "P2"``).

1. Seconds per pressure solve at about 1e3, 1e4 and 1e5 mesh nodes: a disc of radius 40 at
   lam = 1e-2, uniform mesh of the size giving N nodes (continuum.mesh.h_for_nodes). For each
   element the first solve (AMG setup included) and then the median of ``--repeats`` solves as
   in a time step: the nodes moved (the disc scaled by 1 + 1e-3 k), warm start from the previous
   pressure, AMG hierarchy reused. Beside them the accuracy against the exact radial solution
   (continuum.radial): the largest nodal pressure error and the RMS error of the boundary
   normal velocity (the velocity the nodes move with: P1 residual flux, P2 element gradients).
2. Ring radii of whole runs (lam = 1e-2, default continuum.Config, ``element`` and the mesh
   varied) to ``--radius`` (default 40) and, with ``--target``, to 150 (the target run): wall
   seconds, nodes, and the error of the ring radii (G = k ln 2, mean over 24 rays) against the 1D
   reference at the same radius (cases.bench.continuum.ring_errors), the outer two rings and
   all rings.
3. With ``--modes K ...``: the decay rate of a 1 % mode K on a disc of radius 3 at lam = 0
   over t in [0, 1] (:func:`mode_rate`) against the linearised exact rate K / 2, for the
   ``--mode-runs`` (default P1 and P2 on the default mesh).

scikit-fem's P1 (``PressureSolver(element=SKFEM_P1)``) is not a Config choice; for the runs of
part 2 the simulation's solver class is swapped for one that assembles P1 by scikit-fem
(:func:`scikit_fem_p1`). It solves the same discrete problem as the hand-written P1 to
round-off (tests/continuum/test_elements.py), so only its seconds differ (and, through
round-off, remeshing decisions late in a run).

Run: ``python docs/measurements/elements.py [--sizes 1000 10000 100000] [--repeats 5]
[--elements P1 P1-skfem P2] [--modes 2 4 6 8] [--radius 40] [--runs SPEC ...]
[--target [SPEC ...]]``, a SPEC being ``NAME[:KEY=VALUE,...]`` with continuum.Config
overrides (default runs: each element on the default mesh, and
``P2:h_max=1.1,n_nodes=500``, P2 at twice the mesh spacing).
Timings depend on the machine's load: compare the columns of one run.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import time

import numpy as np

ELEMENT_NAMES = ("P1", "P1-skfem", "P2")
RUNS = ("P1", "P1-skfem", "P2", "P2:h_max=1.1,n_nodes=500")
"""The runs of part 2: the default mesh for each element, and P2 at twice the spacing."""
DISC_RADIUS = 40.0
LAM = 1e-2


def disc_mesh(n_nodes: int, radius: float = DISC_RADIUS):
    """Boundary and uniform mesh (points, triangles) of the disc with about n_nodes nodes."""
    from continuum import mesh

    h = mesh.h_for_nodes(math.pi * radius**2, n_nodes)
    bnd = mesh.resample_polygon(mesh.circle_polygon(radius, 4096), spacing=h)
    pts, tri = mesh.triangulate(bnd, h)
    return bnd, pts, tri


def solve_costs(element: str, n_nodes: int, repeats: int = 5, lam: float = LAM) -> dict:
    """First and median warm solve seconds of ``element`` on the disc, and its errors."""
    from continuum import radial
    from continuum.darcy import darcy_flow
    from continuum.pressure import PressureSolver
    from continuum.velocity import boundary_normals

    bnd, pts, tri = disc_mesh(n_nodes)
    k = len(bnd)
    solver = PressureSolver(lam, element)
    t0 = time.perf_counter()
    solver.set_mesh(tri, len(pts), k)
    t_topology = time.perf_counter() - t0
    t0 = time.perf_counter()
    p, u, _ = darcy_flow(solver, pts)
    first = time.perf_counter() - t0
    warm, newton, krylov = [], [], []
    for j in range(1, repeats + 1):
        x = pts * (1.0 + 1e-3 * j)
        t0 = time.perf_counter()
        p, u, _ = darcy_flow(solver, x, p)
        warm.append(time.perf_counter() - t0)
        newton.append(solver.stats.newton_iterations)
        krylov.append(solver.stats.krylov_iterations)
    R = DISC_RADIUS * (1.0 + 1e-3 * repeats)
    r = np.hypot(*x.T)
    n, _ = boundary_normals(x[:k])
    un = np.sum(u[:k] * n, axis=1)
    return {
        "element": element, "nodes": len(pts), "dofs": solver.space.n,
        "topology_s": t_topology, "first_s": first, "solve_s": float(np.median(warm)),
        "newton": float(np.median(newton)), "krylov": float(np.median(krylov)),
        "p_err": float(np.max(np.abs(p - radial.pressure(r, R, lam)))),
        "un_err": float(np.sqrt(np.mean((un - radial.velocity(R, R, lam)) ** 2))),
    }


@contextlib.contextmanager
def scikit_fem_p1():
    """Within: ``continuum.Simulation`` assembles its P1 pressure by scikit-fem."""
    from continuum import simulation
    from continuum.pressure import SKFEM_P1, PressureSolver

    class SkfemSolver(PressureSolver):
        def __init__(self, lam, element="P1", **kw):
            if element != "P1":
                raise ValueError("scikit-fem's P1 replaces P1")
            super().__init__(lam, SKFEM_P1, **kw)

    saved = simulation.PressureSolver
    simulation.PressureSolver = SkfemSolver
    try:
        yield
    finally:
        simulation.PressureSolver = saved


def variant(spec: str) -> tuple[str, dict]:
    """``NAME[:KEY=VALUE,...]`` -> (element name, continuum.Config overrides).

    E.g. "P2:h_max=1.1,n_nodes=500": P2 on a mesh of twice the default spacing.
    """
    from continuum import Config

    name, _, rest = spec.partition(":")
    if name not in ELEMENT_NAMES:
        raise SystemExit(f"unknown element {name!r} in {spec!r}")
    over = {}
    for kv in filter(None, rest.split(",")):
        k, v = kv.split("=", 1)
        over[k] = type(getattr(Config, k))(float(v))
    return name, over


def ring_run(spec: str, radius: float, lam: float = LAM) -> dict:
    """Run to ``radius`` with the ``variant`` spec (cases.bench.continuum.target_run)."""
    from cases.bench.continuum import target_run

    element, over = variant(spec)
    if element == "P1-skfem":
        with scikit_fem_p1():
            return target_run(radius, lam, **over)
    return target_run(radius, lam, element=element, **over)


def mode_amplitude(boundary: np.ndarray, K: int) -> float:
    """Relative amplitude of mode K of the boundary radius about the centroid.

    Least-squares fit r(theta) = r0 + a cos K theta + b sin K theta over the boundary nodes;
    returns sqrt(a^2 + b^2) / r0 signed by a (the initial perturbation is a cosine).
    """
    x = boundary - boundary.mean(axis=0)
    th, r = np.arctan2(x[:, 1], x[:, 0]), np.hypot(x[:, 0], x[:, 1])
    A = np.column_stack([np.ones_like(th), np.cos(K * th), np.sin(K * th)])
    r0, a, b = np.linalg.lstsq(A, r, rcond=None)[0]
    return float(np.sign(a) * np.hypot(a, b) / r0)


def mode_rate(spec: str, K: int, t_end: float = 1.0, eps: float = 0.01, R: float = 3.0,
              folder=None) -> dict:
    """Measured decay of a mode-K perturbation of a disc at lam = 0 against the exact rate.

    Initial boundary r = R (1 + eps cos K theta) (a 1024-vertex polygon); at lam = 0 the
    linearised exact amplitude is eps exp(-K t / 2) (the mode's normal velocity (1 - K) delta / 2
    against the mean growth R / 2). Returns the measured rate -ln(a(t) / a(0)) / t (a(0)
    measured on the initial mesh's boundary) and the exact K / 2.
    """
    import tempfile
    from pathlib import Path

    from continuum import Config, Simulation

    element, over = variant(spec)
    th = np.linspace(0.0, 2 * np.pi, 1024, endpoint=False)
    r = R * (1.0 + eps * np.cos(K * th))
    folder = Path(folder or tempfile.mkdtemp())
    csv = folder / f"mode{K}.csv"
    xy = np.column_stack([r * np.cos(th), r * np.sin(th)])
    np.savetxt(csv, np.vstack([xy, xy[:1]]), delimiter=",", header="x,y", comments="")
    cfg = Config(lam=0.0, time=t_end, shape=f"polygon:{csv}", write_fields=False,
                 element="P1" if element == "P1-skfem" else element, **over)
    ctx = scikit_fem_p1() if element == "P1-skfem" else contextlib.nullcontext()
    with ctx:
        sim = Simulation(cfg)
        a0 = mode_amplitude(sim.state.boundary, K)
        c0 = time.process_time()
        sim.advance()
        cpu = time.process_time() - c0
    a1 = mode_amplitude(sim.state.boundary, K)
    rate = -math.log(a1 / a0) / t_end if a1 > 0 else float("nan")
    return {"K": K, "a0": a0, "a1": a1, "rate": rate, "exact": K / 2, "cpu_s": cpu,
            "nodes": len(sim.state.points)}


def main(argv=None) -> None:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000, 100000])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--elements", nargs="+", default=list(ELEMENT_NAMES), choices=ELEMENT_NAMES)
    ap.add_argument("--radius", type=float, default=40.0, help="ring-radius run (0: skip)")
    ap.add_argument("--runs", nargs="+", default=list(RUNS),
                    help="runs to --radius: NAME[:KEY=VALUE,...] (Config overrides)")
    ap.add_argument("--modes", type=int, nargs="*", default=[],
                    help="mode rates at lam = 0 for these K (disc radius 3, 1 %% mode, t = 1)")
    ap.add_argument("--mode-runs", nargs="+", default=["P1", "P2"], help="specs of the mode runs")
    ap.add_argument("--target", nargs="*", default=None,
                    help="also the target run to radius 150 of these runs (none given: --runs)")
    args = ap.parse_args(argv)
    from continuum.pressure import limit_blas_threads

    limit_blas_threads(1)
    if args.sizes:
        print("| element | nodes | dofs | first solve [s] | solve [s] (median) | Newton | CG "
              "| max nodal p error | RMS boundary u.n error |")
        print("|---|---|---|---|---|---|---|---|---|")
        for n in args.sizes:
            base = None
            for el in args.elements:
                c = solve_costs(el, n, args.repeats)
                base = c["solve_s"] if base is None else base
                print(f"| {el} | {c['nodes']} | {c['dofs']} | {c['first_s']:.4f} | "
                      f"{c['solve_s']:.4f} ({c['solve_s'] / base:.2f}x) | {c['newton']:.0f} | "
                      f"{c['krylov']:.0f} | {c['p_err']:.2e} | {c['un_err']:.2e} |", flush=True)
    if args.modes:
        print("| run | K | nodes | cpu [s] | amplitude t=0 | amplitude t=1 | rate | exact K/2 "
              "| rate error |")
        print("|---|---|---|---|---|---|---|---|---|")
        for K in args.modes:
            for spec in args.mode_runs:
                m = mode_rate(spec, K)
                print(f"| {spec} | {K} | {m['nodes']} | {m['cpu_s']:.1f} | {m['a0']:.5f} | "
                      f"{m['a1']:+.6f} | {m['rate']:.4f} | {m['exact']:.1f} | "
                      f"{(m['rate'] - m['exact']) / m['exact']:+.2%} |", flush=True)
    plan = [(args.radius, spec) for spec in args.runs] if args.radius > 0 else []
    if args.target is not None:
        plan += [(150.0, spec) for spec in (args.target or args.runs)]
    if plan:
        print("\n| element | radius | wall [s] | cpu [s] | steps | nodes | outer two rings: "
              "max abs err | max err / spacing | all rings: max err / spacing |")
        print("|---|---|---|---|---|---|---|---|---|")
    for radius, spec in plan:
        r = ring_run(spec, radius)
        print(f"| {spec} | {radius:g} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | {r['steps']} | "
              f"{r['n_nodes']} | {r['outer_max_abs_err']:.4f} | "
              f"{r['outer_max_rel_err']:.2%} | {r['all_max_rel_err']:.2%} |", flush=True)
        print("  rings: " + ", ".join(f"k={k} {e:+.4f}" for k, _, e, _ in r["rings"]),
              flush=True)


if __name__ == "__main__":
    main()
