"""How much a better warm start would save the contact solver, measured on a run's own steps.

From a checkpoint (``--checkpoint``, a particle run's checkpoint.npz with its history.csv
beside it) the run goes on by the engine's own step for ``--steps`` steps. Before each step
the step's main problem (its contacts, lengths, dt) is solved by the run's solver from several
starts, and the solver iterations are counted; the run itself then takes its step as it
would. Every start is tried on the same problem, so the counts are paired:

- ``matched``: the engine's warm start (the previous step's forces matched by contact
  identity, 0 for new contacts);
- ``new exact``: matched, but the new contacts (after divisions and new touches) start from the
  converged solution: a bound on what any better guess for new contacts can save;
- ``extrapolated``: gamma_prev + f (dt_prev / dt_prev2) (gamma_prev - gamma_prev2) on the
  contacts of the last two steps (f = 1: linear extrapolation in time; f = 1/2), clipped at 0,
  matched elsewhere;
- ``extrapolated + new exact``.

Prints one row per step and the mean iterations of each start over the steps, and its ratio to
``matched``. Iterations only (no timings): they do not depend on the machine.

    python -m cases.bench.warm_start --checkpoint RUN.partial/checkpoint.npz [--steps 14]
"""

from __future__ import annotations

import argparse

import numba
import numpy as np

from particles.simulation import Simulation
from particles.solvers import BY_NAME
from particles.stepping import detect, warm_start


def _iterations(solver, problem, gamma0) -> int:
    c, length, dt, lam, tol = problem
    return len(solver(c, length, dt, lam, gamma0, tol, 10**6, True)[1]) - 1


def starts(problem, solver, matched, new, gamma_exact, before) -> dict[str, int]:
    """Iterations of the solve of ``problem`` from each start (module docstring).

    ``matched`` the engine's start, ``new`` the mask of the contacts without a previous force,
    ``gamma_exact`` the converged forces, ``before`` (gamma of two steps back matched to these
    contacts, mask of the contacts present in both previous steps, dt ratio) or None.
    """
    out = {"matched": _iterations(solver, problem, matched),
           "new exact": _iterations(solver, problem, np.where(new, gamma_exact, matched))}
    if before is not None:
        gamma2, both, ratio = before
        for name, f in (("extrapolated", 1.0), ("extrapolated 1/2", 0.5)):
            g = np.where(both, np.maximum(0.0, matched + f * ratio * (matched - gamma2)), matched)
            out[name] = _iterations(solver, problem, g)
            out[name + " + new exact"] = _iterations(solver, problem, np.where(new, gamma_exact, g))
    return out


def main_problem(sim: Simulation):
    """The main contact problem of ``sim``'s next step and the engine's warm start for it.

    Returns ((contacts, lengths, dt, lam, solver tolerance), matched start, contact keys), as
    the engine's step would pose it (stepping.step).  One strain only (the benchmarks pose the
    problem with the colony's one lam).
    """
    st, cfg = sim.state, sim.config
    if cfg.strains:
        raise ValueError("the solver benchmarks take one-strain runs; this run has "
                         f"{len(cfg.strains)} strains")
    c = detect(st, cfg.contact_margin, None, sim._detections)
    keys = c.keys(st.ids)
    problem = (c, st.length, st.dt_next, cfg.lam, cfg.effective_solver_tol)
    return problem, warm_start(keys, *st.warm), keys


def main(argv: list[str] | None = None) -> dict[str, float]:
    """Run the experiment of the module docstring; the mean iterations of each start."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", required=True, help="a particle run's checkpoint.npz")
    ap.add_argument("--steps", type=int, default=14)
    args = ap.parse_args(argv)
    if args.steps < 1:
        ap.error(f"--steps must be >= 1, got {args.steps}")
    numba.set_num_threads(1)
    sim = Simulation.load(args.checkpoint)
    cfg = sim.config
    solver = BY_NAME[cfg.solver]
    previous, dts, rows = None, [], []
    for _ in range(args.steps):
        st = sim.state
        problem, matched, keys = main_problem(sim)
        c = problem[0]
        warm_keys, warm_gamma = st.warm
        new = ~np.isin(keys, warm_keys)
        gamma_exact = solver(*problem[:4], matched, problem[4], 10**6, True)[0]
        before = None
        if previous is not None and len(dts) >= 2:
            both = ~new & np.isin(keys, previous[0])
            before = (warm_start(keys, *previous), both, dts[-1] / dts[-2])
        row = starts(problem, solver, matched, new, gamma_exact, before)
        previous = (warm_keys.copy(), warm_gamma.copy())
        record = sim.step()
        dts.append(record.dt)
        rows.append(row)
        print(f"step {record.step}: N = {st.n}, contacts {len(c)}, new {int(new.sum())}, "
              f"divisions {record.divisions}, " + ", ".join(f"{n} {v}" for n, v in row.items()),
              flush=True)
    means = {}
    for name in rows[-1]:
        have = [r for r in rows if name in r]
        means[name] = float(np.mean([r[name] for r in have]))
        ratio = means[name] / np.mean([r["matched"] for r in have])
        print(f"{name:28s} mean iterations {means[name]:8.1f}  ratio to matched {ratio:.3f} "
              f"({len(have)} steps)")
    return means


if __name__ == "__main__":
    main()
