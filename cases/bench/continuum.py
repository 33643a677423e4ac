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

Run: ``python -m cases.bench.continuum [--sizes 1000 10000 100000] [--radius 150]``.
Timings depend on the machine's load: CPU seconds are printed beside wall seconds.
"""

from __future__ import annotations

import argparse
import math
import time

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


def main(argv=None) -> None:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000, 100000])
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--radius", type=float, default=150.0, help="target run radius (0: skip)")
    ap.add_argument("--set", nargs="*", default=[], help="continuum.Config overrides KEY=VALUE")
    args = ap.parse_args(argv)
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
