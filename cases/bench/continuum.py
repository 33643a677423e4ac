"""Benchmark of the continuum engine.

1. Cost per time step against node count (about 1e3 to 1e5 nodes): a disc at lam = 1e-2 is
   meshed at the size giving N nodes and advanced a few steps; the median per-step seconds of
   each stage are reported: meshing and remeshing (a forced remesh: Triangle + transfer of
   G, Psi and p), assembly (stiffness, load, residual flux, velocity recovery), AMG setup,
   Krylov (PCG iterations), transport (Psi in log2 l).
2. The target run: lam = 1e-2 from R0 to radius 150 with the default continuum.Config (the
   settings of ``colony continuum``): wall and CPU time, node count, and the error of the
   ring radii (where G = k ln 2, mean over 24 rays) against the 1D reference
   (continuum.radial.ring_radii), absolute and relative to the local ring spacing.

3. With ``--against DIR`` (a checkout of another commit, e.g. a ``git worktree``): the target
   run of this code and of DIR's, each in a fresh process, alternated ``--repeats`` times on the
   same machine; medians of wall and CPU seconds, their ratio, and both runs' ring errors
   (:func:`compare`). Speed claims are these ratios, never absolute seconds across machines.

Run: ``python -m cases.bench.continuum [--sizes 1000 10000 100000] [--radius 150]
[--against DIR --repeats 3]``. Timings depend on the machine's load: CPU seconds are printed
beside wall seconds.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from continuum.growth import LN2

STAGES = ("meshing", "assembly", "amg_setup", "krylov", "remeshing", "transport")


def step_costs(n_nodes: int, steps: int = 5, lam: float = 1e-2) -> dict:
    """Median seconds per step of each stage on a disc meshed with about n_nodes nodes."""
    from continuum import Config, Simulation

    R = 20.0
    cfg = Config(
        lam=lam, time=1.0, initial_radius=R, n_nodes=n_nodes, h_max=1e9, interior_coarsening=1.0
    )
    sim = Simulation(cfg)
    per_step = {k: [] for k in STAGES}
    for _ in range(steps):
        before = dict(sim.state.timings)
        sim.step()
        sim.remesh()  # forced, to time meshing + transfer
        for k in STAGES:
            per_step[k].append(sim.state.timings[k] - before[k])
    out = {k: float(np.median(v)) for k, v in per_step.items()}
    out["n_nodes"] = len(sim.state.points)
    out["step_without_remesh"] = sum(
        out[k] for k in ("assembly", "amg_setup", "krylov", "transport")
    )
    return out


def ring_errors(state, lam: float, same: str = "radius") -> list[tuple[int, float, float, float]]:
    """(k, reference radius, 2D - reference, local spacing) for every ring beyond r = 3.

    The 1D reference is taken at the run's final colony radius sqrt(area/pi) (``same`` =
    "radius", the natural comparison for a run to a radius) or at its final time ("time",
    which also counts the radius error R_h(t) - R(t) into the ring positions).
    """
    from continuum import radial

    if same == "radius":
        R_end = math.sqrt(abs(state.area) / math.pi)
        ref, ks = radial.ring_radii(lam, radius=R_end, with_index=True)
    else:
        ref, ks = radial.ring_radii(lam, t=state.t, with_index=True)
    R = float(np.max(np.hypot(*state.boundary.T)))
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rr = np.linspace(0.0, 0.999 * min(R, float(np.min(np.hypot(*state.boundary.T)))), 8000)
    rays = rr[None, :, None] * np.stack([np.cos(ang), np.sin(ang)], -1)[:, None, :]
    G = state.sample(rays.reshape(-1, 2))["G"].reshape(len(ang), len(rr))
    out = []
    for i, (r0, k) in enumerate(zip(ref, ks, strict=True)):
        if r0 < 3.0 or r0 > rr[-1]:
            continue
        cross = []
        for row in G:
            f = row - k * LN2
            j = np.flatnonzero(np.sign(f[:-1]) != np.sign(f[1:]))
            if len(j) == 0:
                continue
            j = j[np.argmin(np.abs(rr[j] - r0))]
            cross.append(rr[j] - f[j] * (rr[j + 1] - rr[j]) / (f[j + 1] - f[j]))
        spacing = ref[i] - ref[i - 1] if i > 0 else ref[i + 1] - ref[i]
        out.append((int(k), float(r0), float(np.mean(cross) - r0), float(spacing)))
    return out


def target_run(radius: float = 150.0, lam: float = 1e-2, **overrides) -> dict:
    """Default-settings run to ``radius``: times, size, ring-radius errors."""
    from continuum import Config, run

    cfg = Config(lam=lam, radius=radius, write_fields=False, **overrides)
    w0, c0 = time.perf_counter(), time.process_time()
    sim = run(cfg)
    state, history = sim.state, sim.history
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    rings = ring_errors(state, lam)
    rings_t = ring_errors(state, lam, same="time")
    outer = rings[-2:]
    return {
        "rings_same_time": rings_t,
        "radius_error_at_t": history[-1]["radius"]
        - float(__import__("continuum.radial", fromlist=["x"]).radius(state.t, lam)),
        "wall_s": wall,
        "cpu_s": cpu,
        "steps": len(history) - 1,
        "n_nodes": len(state.points),
        "n_remesh": history[-1]["n_remesh"],
        "timings": state.timings,
        "rings": rings,
        "outer_max_abs_err": max(abs(e) for _, _, e, _ in outer),
        "outer_max_rel_err": max(abs(e) / s for _, _, e, s in outer),
        "all_max_rel_err": max(abs(e) / s for _, _, e, s in rings),
    }


_CHILD = """
import json, sys
from cases.bench.continuum import target_run
r = target_run(float(sys.argv[1]))
keep = ("wall_s", "cpu_s", "steps", "n_nodes", "outer_max_abs_err", "radius_error_at_t")
out = {k: r[k] for k in keep}
out["outer4_max_abs_err"] = max(abs(e) for _, _, e, _ in r["rings"][-4:])
out["all_max_abs_err"] = max(abs(e) for _, _, e, _ in r["rings"])
print("RESULT " + json.dumps(out))
"""


def _child_run(code: Path, radius: float) -> dict:
    """The target run of the code checked out at ``code``, in a fresh process (its imports)."""
    env = dict(os.environ, PYTHONPATH=str(code))
    res = subprocess.run([sys.executable, "-c", _CHILD, str(radius)], cwd=code, env=env,
                         capture_output=True, text=True)
    if res.returncode:
        raise RuntimeError(f"target run of {code} failed:\n{res.stderr[-2000:]}")
    line = [ln for ln in res.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def compare(base: Path, radius: float = 150.0, repeats: int = 3) -> dict:
    """Target runs of this checkout and of ``base``, alternated, each ``repeats`` times.

    Returns {"this": [runs], "base": [runs], "wall_ratio", "cpu_ratio"}: the ratios of the
    medians (this / base).
    """
    here = Path(__file__).resolve().parents[2]
    runs = {"this": [], "base": []}
    for i in range(repeats):
        for name, code in (("base", Path(base).resolve()), ("this", here)):
            r = _child_run(code, radius)
            runs[name].append(r)
            print(f"  {name} run {i + 1}: wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, "
                  f"{r['steps']} steps, {r['n_nodes']} nodes, outer four rings "
                  f"{r['outer4_max_abs_err']:.4f}, all rings {r['all_max_abs_err']:.4f}",
                  flush=True)
    med = {n: {k: float(np.median([r[k] for r in v])) for k in ("wall_s", "cpu_s")}
           for n, v in runs.items()}
    return dict(runs, wall_ratio=med["this"]["wall_s"] / med["base"]["wall_s"],
                cpu_ratio=med["this"]["cpu_s"] / med["base"]["cpu_s"], medians=med)


def main(argv=None) -> None:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000, 100000])
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--radius", type=float, default=150.0, help="target run radius (0: skip)")
    ap.add_argument("--set", nargs="*", default=[], help="continuum.Config overrides KEY=VALUE")
    ap.add_argument("--against", type=Path, default=None,
                    help="checkout of another commit: compare the target runs (no --sizes)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each code with --against")
    args = ap.parse_args(argv)
    if args.against is not None:
        if not (args.against / "continuum" / "__init__.py").is_file():
            sys.exit(f"bench: {args.against} is not a checkout of this project")
        c = compare(args.against, args.radius, args.repeats)
        m = c["medians"]
        print(f"median wall: this {m['this']['wall_s']:.1f} s, base {m['base']['wall_s']:.1f} s "
              f"(ratio {c['wall_ratio']:.3f}); median CPU: this {m['this']['cpu_s']:.1f} s, "
              f"base {m['base']['cpu_s']:.1f} s (ratio {c['cpu_ratio']:.3f})")
        return
    if args.sizes:
        print("nodes  " + "  ".join(f"{k:>10s}" for k in STAGES) + "  step(no remesh) [s]")
        for n in args.sizes:
            c = step_costs(n, args.steps)
            print(
                f"{c['n_nodes']:6d} "
                + "  ".join(f"{c[k]:10.4f}" for k in STAGES)
                + f"  {c['step_without_remesh']:10.4f}",
                flush=True,
            )
    if args.radius > 0:
        over = {}
        for kv in args.set:
            k, v = kv.split("=", 1)
            over[k] = type(
                getattr(__import__("continuum").Config, k, 0.0)
            )(float(v))
        r = target_run(args.radius, **over)
        print(
            f"target run to R={args.radius}: wall {r['wall_s']:.1f} s, cpu {r['cpu_s']:.1f} s, "
            f"{r['steps']} steps, {r['n_nodes']} nodes, {r['n_remesh']} remeshes"
        )
        print("stage seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in r["timings"].items()))
        for k, r0, e, s in r["rings"]:
            print(f"  ring k={k:3d} r_ref={r0:9.4f} err={e:+.4f} ({e / s:+.2%} of spacing {s:.3f})")
        print(
            f"outer two rings (reference at the same radius): max |err| "
            f"{r['outer_max_abs_err']:.4f}, max |err|/spacing {r['outer_max_rel_err']:.2%}"
        )
        print(
            f"radius error at the final time R_h(t) - R(t) = {r['radius_error_at_t']:+.4f}; "
            "outer rings against the reference at the same time: "
            + ", ".join(f"{e:+.4f}" for _, _, e, _ in r["rings_same_time"][-2:])
        )


if __name__ == "__main__":
    main()
