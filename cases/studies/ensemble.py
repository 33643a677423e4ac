"""Seed ensembles of particle colonies: how far one colony lies from the continuum.

Every particle number of Fig 3 and Fig 4 comes from one colony; another seed (or the same seed
summed in another order, cases/data/fig3/README.md) grows another colony. This case grows
``seeds`` colonies per lam to the same radius (the seeds 0, 1, ...; seed 0 is the figure cases'
run, so a shared ``runs`` folder reuses it), reduces each with :mod:`cases.analysis` and writes
the mean and spread over the seeds (:func:`cases.analysis.seed_spread`: standard deviation, 95 %
t-interval of the mean, 95 % prediction interval of one more colony, the 2.5-97.5 % quantiles of
the seeds) beside the continuum run of the same lam and radius and the 1D radial reference
(:mod:`continuum.radial`).

Per seed (``seeds.csv``): final time and late dR/dt; the central stress by the largest annulus
mean (``central_max``, the figures' "max stress") and by the fit p0 - c r^2 over r < R/2
(``central_fit`` and its standard error, :func:`cases.analysis.central_value`); the final ring
wavelength, outermost ring radius and ring coherence z (Fig 4). Over the seeds (one file per
lam): the final stress and mean-length profiles on common equal-area annuli
(``profile_lam=*.csv``), R(t) on a common time grid (``radius_lam=*.csv``), the time to reach
each radius against the continuum's (``time_lam=*.csv``) and, frame by frame as the colony grows
from R/4 to R, the central stress, outermost ring and wavelength against the 1D reference at
the same radius (``growth_lam=*.csv``, relative differences; ``growth_rates.csv`` fits
abs(difference) ~ R^a). ``numerics.csv``: the first seed of ``numerics_lam`` again with the time
step halved, with the overlap tolerance halved (the solver tolerance follows it) and, at medium
scale, with the solver's tolerance doubled (tol / 2 -> tol, the engine's default since issue
18), against the seed spread.

Scales (:data:`ENSEMBLES`): "smoke" (radius 8, lam = 0.1, 2 seeds; about 40 s of CPU) and "medium"
(radius 40, the lam of the medium figure cases and 1e-4, 8 seeds each; about 60 particle runs of
30-80 s CPU each). Committed data: cases/data/ensemble (``colony case ensemble --from-data``).
Some lam only (``compute(lams=...)``, ``colony case ensemble --lams L,...``), merged into earlier
data by :func:`cases.datasets.merge` (``python -m cases.figures.merge ensemble NEW OLD OUT``);
the figures find the ensemble's data beside theirs by :func:`cases.datasets.ensemble_data`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from cases import analysis as A
from cases.sweep import ENGINES, _engine_params, is_done, run_engine, run_name, scale_config, sweep
from continuum import radial
from particles.config import Config, upgrade
from particles.geometry import B
from particles.measures import centroid, enclosing_radius

__all__ = ["ENSEMBLES", "particle_params", "continuum_params", "compute", "reduce", "plot",
           "QUANTITIES", "central_packing", "continuum_mean_pressure",
           "cycle_mean", "mean_stress_ratio", "history_growth", "trailing_rate",
           "DIVISION_PERIOD", "markdown_tables"]

#: Ensemble sizes. medium: the lam of the medium figure cases (Fig 3, Fig 4) and 1e-4 (a paper
#: panel's) at radius 40, 8 seeds each (the lam of the figures' curves first); "numerics": one
#: run per changed setting at the first seed of ``numerics_lam`` (dt and tol halved; medium:
#: also the contact solver's residual tolerance doubled, from tol / 2 to tol). Engine settings
#: of the figure scale ``scale`` (cases.sweep.SCALES) with the radius replaced, and particle
#: frames every ``frames`` of time: 20 and 50 of the ensemble's steps of 0.01 (STEP), the
#: cadence its committed data were made with when output_every counted steps (until issue 43).
ENSEMBLES: dict[str, dict[str, Any]] = {
    "smoke": {"scale": "smoke", "radius": 8.0, "lams": (0.1,), "seeds": 2, "frames": 0.2,
              "numerics_lam": 0.1, "numerics": ({"dt": 0.005}, {"tol": 5e-4})},
    "medium": {"scale": "medium", "radius": 40.0, "frames": 0.5,
               "lams": (0.0, 1e-3, 1e-2, 3e-2, 3e-3, 1e-1, 1e-4),
               "seeds": 8, "numerics_lam": 1e-3,
               "numerics": ({"dt": 0.005}, {"tol": 5e-4}, {"solver_tol": 1e-3})},
}

#: Per-seed numbers of ``seeds.csv`` reduced over the seeds in ``summary.csv``.
QUANTITIES = ("t_final", "slope", "central_max", "central_fit", "mean_stress_now",
              "mean_stress_cycle", "wavelength", "outer_ring", "ring_z", "packing")
#: Late dR/dt: linear fit over this last fraction of the run (as Fig 3D).
LATE_FRACTION = 0.2
#: Particle profiles: outermost annulus about one particle diameter wide (as the figures).
EDGE_WIDTH = 0.5
#: Points of the common time grid of R(t) and of the radius grid of t(R).
GRID_POINTS = 200
#: Radii (fractions of the final radius, geometric) at which the growing colony is compared.
GROWTH_FRACTIONS = np.geomspace(0.25, 1.0, 7)


#: The step policy and solver tolerance of every particle run of the ensemble: fixed steps of
#: 0.01 and the solver's residual tolerance tol / 2, with which its committed data were made
#: (the engine's defaults before issue 18: the "overlap" step control, tolerance tol), so that
#: the numerics runs' dt = 0.005 is the halved step and tol = 5e-4 takes the solver along.
STEP = {"step_control": "fixed", "dt": 0.01, "solver_tol_factor": 0.5}


def _ensemble(scale: str) -> dict[str, Any]:
    if scale not in ENSEMBLES:
        raise ValueError(f"scale must be one of {tuple(ENSEMBLES)}, got {scale!r}")
    return ENSEMBLES[scale]


def particle_params(lam: float, seed: int, scale: str, **settings: Any) -> dict[str, Any]:
    """Sweep parameters of one particle colony of the ensemble.

    The figure scale's particle settings at the ensemble's radius and frames with fixed steps
    (STEP), the seed (left out for seed 0, the engine's default) and ``settings`` (e.g.
    dt=0.005 for the numerics runs).
    """
    ens = _ensemble(scale)
    params = _engine_params("particles", lam, scale_config(ens["scale"]))
    params["radius"], params["output_every"] = ens["radius"], ens["frames"]
    if seed:
        params["seed"] = int(seed)
    return params | STEP | settings


def continuum_params(lam: float, scale: str) -> dict[str, Any]:
    """Sweep parameters of the continuum run of ``lam`` at the ensemble's radius."""
    ens = _ensemble(scale)
    return _engine_params("continuum", lam, scale_config(ens["scale"])) | {
        "radius": ens["radius"]}


def _run_list(scale: str, lams: Sequence[float] | None = None) -> tuple[dict, dict, dict]:
    """({(lam, seed): params}, {lam: params}, {setting: params}) of the ensemble at ``scale``.

    Particle runs seed by seed (all lam of seed 0, then of seed 1, ...), the figures' curve lam
    first, so that a stopped sweep leaves whole seeds; the numerics runs after the first half.
    ``lams``: only these lam of the ensemble (ValueError for others); the numerics runs only
    if ``numerics_lam`` is one of them.
    """
    ens = _ensemble(scale)
    chosen = [float(lam) for lam in ens["lams"]]
    if lams is not None:
        bad = sorted({float(lam) for lam in lams} - set(chosen))
        if bad or not lams:
            raise ValueError(f"lam {', '.join(f'{lam:g}' for lam in bad) or 'none'} not among "
                             f"the lam of the {scale} ensemble: "
                             f"{', '.join(f'{lam:g}' for lam in sorted(chosen))}")
        chosen = [lam for lam in chosen if lam in {float(v) for v in lams}]
    curves = [lam for lam in chosen if lam in scale_config(ens["scale"])["lams"]
              or lam == 0.0]
    others = [lam for lam in chosen if lam not in curves]
    order = ([(lam, s) for s in range(ens["seeds"]) for lam in curves]
             + [(lam, s) for s in range(ens["seeds"]) for lam in others])
    particles = {(float(lam), s): particle_params(lam, s, scale) for lam, s in order}
    continuum = {float(lam): continuum_params(lam, scale) for lam in chosen}
    numerics = {_setting_name(kw): particle_params(ens["numerics_lam"], 0, scale, **kw)
                for kw in ens["numerics"] if float(ens["numerics_lam"]) in chosen}
    return particles, continuum, numerics


def _setting_name(settings: dict[str, Any]) -> str:
    return ",".join(f"{k}={v:g}" for k, v in sorted(settings.items()))


def compute(scale: str = "smoke", out: str | Path = "runs/case-ensemble-smoke",
            scheduler: str | None = None, n_workers: int = 2,
            runs: str | Path | None = None, engines: tuple[str, ...] = ENGINES,
            finished_only: tuple[str, ...] = (),
            lams: Sequence[float] | None = None) -> Path:
    """Run (or reuse) the ensemble's runs under ``runs`` (default ``out/runs``); reduce to data.

    ``engines`` must hold both engines (the ensemble compares them). ``finished_only``: engines
    whose runs are only reused where finished (``--engines finished``: the particle seeds
    finished so far; a lam without any is left out, ``n_seeds`` in summary.csv says how many
    each lam has). ``lams``: only these lam of the ensemble (``colony case ensemble --lams``),
    e.g. a new lam, to add to the committed data with :func:`cases.datasets.merge`;
    numerics.csv only if ``numerics_lam`` is one of them.
    """
    if set(engines) != set(ENGINES):
        raise ValueError("the ensemble compares particles with the continuum: it needs both "
                         "engines (--engines both or finished)")
    bad = [e for e in finished_only if e not in ENGINES]
    if bad:
        raise ValueError(f"finished_only must be a subset of {ENGINES}, got {bad!r}")
    root = Path(runs) if runs else Path(out) / "runs"
    particles, continuum, numerics = _run_list(scale, lams)
    todo = []
    if "continuum" not in finished_only:
        todo += list(continuum.values())
    if "particles" not in finished_only:
        todo += list(particles.values()) + list(numerics.values())
    if todo:
        sweep(run_engine, todo, root, scheduler=scheduler, n_workers=n_workers)

    def done(params: dict[str, dict]) -> dict:
        return {k: root / run_name(p) for k, p in params.items() if is_done(root / run_name(p), p)}

    pf, cf = done(particles), done(continuum)
    lams = [lam for lam in cf if any(k[0] == lam for k in pf)]
    if not lams:
        raise ValueError(f"no lam has finished runs of both engines under {root}")
    return reduce(pf, {lam: cf[lam] for lam in lams}, done(numerics), Path(out) / "data",
                  _ensemble(scale)["radius"], _ensemble(scale)["numerics_lam"])


# --------------------------------------------------------------------------- reductions


def _seed_numbers(folder: Path) -> tuple[dict[str, float], dict, dict, dict]:
    """(numbers of seeds.csv, final profile, history, growth series) of one particle run."""
    hist = A.read_csv(folder / "history.csv")
    profile = A.final_particle_profile(folder, growth_window=1.0, edge_width=EDGE_WIDTH)
    R_f = float(hist["radius"][-1])
    row = {"radius_final": R_f, "t_final": float(hist["t"][-1]),
           "slope": A.late_slope(hist["t"], hist["radius"], LATE_FRACTION)}
    row |= A.profile_central_stress(profile, R_f)
    ratio = mean_stress_ratio(hist, float(json.loads((folder / "config.json").read_text())["lam"]))
    row |= {"mean_stress_now": float(ratio["now"][-1]),
            "mean_stress_cycle": float(ratio["cycle"][-1])}
    growth = A.particle_growth_series(folder, edge_width=EDGE_WIDTH,
                                      min_radius=0.2 * R_f)
    row["wavelength"] = float(growth["wavelength"][-1])
    row["outer_ring"] = float(growth["outer_ring"][-1])
    row["ring_z"] = A.final_ring_coherence(folder)[1]
    row |= central_packing(folder)
    return row, profile, hist, growth


def central_packing(folder: Path, fraction: float = 0.5) -> dict[str, float]:
    """Length packing b rho_l and area fraction of the last frame within fraction x R.

    rho_l = sum l_n / (pi r_c^2) over the particles whose centres lie within r_c = fraction R
    of the centroid, phi = sum a_n / (pi r_c^2) with a_n = (l_n - b) b + pi b^2 / 4. The
    continuum's p is the contact pressure P divided by rho_l (friction xi l_n per particle:
    -grad P = rho_l v, u = -grad p), while a rod's load sigma_n is b times the stress along its
    axis (mean of its two end forces over the cap width b); under an isotropic P they agree when
    b rho_l = 1, which a brick packing of rods has exactly.
    """
    ((_, fr),) = A.particle_frames(folder, last_only=True)
    cx, cy = centroid(fr["x"], fr["y"], fr["length"])
    R = enclosing_radius(fr["x"], fr["y"], fr["theta"], fr["length"])
    rc = fraction * R
    inside = np.hypot(fr["x"] - cx, fr["y"] - cy) < rc
    area = math.pi * rc * rc
    length = fr["length"][inside]
    return {"packing": float(B * length.sum() / area),
            "area_fraction": float(((length - B) * B + math.pi * B * B / 4).sum() / area)}


def _common_profile(profiles: list[dict], radius: float, name: str) -> tuple[np.ndarray, ...]:
    """Each seed's profile column ``name`` interpolated onto the equal-area annuli of radius R.

    The seeds end at slightly different radii (within a particle length), hence slightly
    different annuli; r_mid = R sqrt((k + 1/2) / N) of the target radius is the common grid.
    """
    n = A.annuli_for_edge_width(radius, EDGE_WIDTH)
    r = radius * np.sqrt((np.arange(n) + 0.5) / n)
    rows = []
    for p in profiles:
        ok = np.isfinite(p[name]) & (p["count"] > 0)
        rows.append(np.interp(r, p["r"][ok], p[name][ok], right=np.nan))
    return r, np.array(rows)


def _stats_columns(prefix: str, values: np.ndarray) -> dict[str, np.ndarray]:
    """Columns ``prefix_mean``, ``prefix_std``, ... of :func:`cases.analysis.seed_spread`."""
    s = A.seed_spread(values, axis=0)
    return {f"{prefix}_{k}": np.atleast_1d(v) for k, v in s.items() if k != "n"}


def _relative(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(ref) > 0, x / ref - 1.0, np.nan)


def _exact_rings(lam: float, R: float) -> tuple[float, float]:
    """(outermost ring radius, wavelength) of the 1D radial reference at colony radius R.

    By the rule of both models (cases.analysis.exact_ring_measure).
    """
    rings = A.exact_ring_measure(lam, R)
    return (float(rings.radii[-1]) if rings.count else math.nan), rings.outer_pair


def _continuum_numbers(folder: Path, lam: float) -> dict[str, float]:
    """Final numbers of the continuum run and of the 1D radial reference at its radius."""
    hist = A.read_csv(folder / "history.csv")
    R = float(hist["radius"][-1])
    rings = A.contour_rings(A.continuum_rings(folder), R)  # rings.csv, else the last frame
    wavelength = rings.outer_pair
    outer = float(rings.radii[-1]) if rings.count else math.nan
    outer_exact, wavelength_exact = _exact_rings(lam, R)
    return {"radius_continuum": R, "t_final_continuum": float(hist["t"][-1]),
            "slope_continuum": A.late_slope(hist["t"], hist["radius"], LATE_FRACTION),
            "max_pressure_continuum": float(hist["max_pressure"][-1]),
            "p0_exact": radial.max_pressure(R, lam),
            "wavelength_continuum": wavelength, "wavelength_exact": wavelength_exact,
            "outer_ring_continuum": outer, "outer_ring_exact": outer_exact}


def reduce(particles: dict[tuple[float, int], Path], continuum: dict[float, Path],
           numerics: dict[str, Path], data: Path, radius: float,
           numerics_lam: float | None = None) -> Path:
    """Reduce the runs {(lam, seed): folder}, {lam: folder}, {setting: folder} to the CSVs.

    See the module docstring for the files; every lam needs its continuum run and at least one
    particle seed.
    """
    data = Path(data)
    lams = sorted(continuum)
    seeds_rows: dict[str, list] = {}
    summary: dict[str, list] = {}
    diffs: dict[str, list] = {}
    growth_rates: dict[str, list] = {}
    for lam in lams:
        folders = {s: f for (lm, s), f in sorted(particles.items()) if lm == lam}
        per_seed = {s: _seed_numbers(f) for s, f in folders.items()}
        for s, (row, *_) in per_seed.items():
            _append(seeds_rows, {"lam": lam, "seed": s} | row)
        cont = _continuum_numbers(continuum[lam], lam)
        values = {q: np.array([per_seed[s][0][q] for s in per_seed]) for q in QUANTITIES}
        srow = {"lam": lam, "n_seeds": len(per_seed), "radius": radius} | cont
        for q in QUANTITIES:
            srow |= {k: float(v[0]) for k, v in _stats_columns(q, values[q][:, None]).items()}
        _append(summary, srow)
        refs = {"t_final": cont["t_final_continuum"], "slope": cont["slope_continuum"],
                "central_max": cont["p0_exact"], "central_fit": cont["p0_exact"],
                "wavelength": cont["wavelength_continuum"],
                "outer_ring": cont["outer_ring_continuum"]}
        drow = {"lam": lam}
        for q, ref in refs.items():
            rel = _relative(values[q], np.full(values[q].shape, ref))
            drow |= {k: float(v[0]) for k, v in _stats_columns(f"rel_{q}", rel[:, None]).items()}
        _append(diffs, drow)
        _write_profiles(data, lam, radius, [p for _, p, _, _ in per_seed.values()])
        hist_c = A.read_csv(continuum[lam] / "history.csv")
        _write_radius(data, lam, radius, [h for _, _, h, _ in per_seed.values()], hist_c)
        rates = _write_growth(data, lam, radius, [g for *_, g in per_seed.values()],
                              [h for _, _, h, _ in per_seed.values()], hist_c)
        _append(growth_rates, {"lam": lam} | rates)
    A.write_csv(data / "seeds.csv", seeds_rows)
    A.write_csv(data / "summary.csv", summary)
    A.write_csv(data / "differences.csv", diffs)
    A.write_csv(data / "growth_rates.csv", growth_rates)
    if numerics and numerics_lam is not None:
        _write_numerics(data, numerics, particles, numerics_lam)
    return data


def _append(table: dict[str, list], row: dict[str, float]) -> None:
    for k, v in row.items():
        table.setdefault(k, []).append(v)


def _write_profiles(data: Path, lam: float, radius: float, profiles: list[dict]) -> None:
    """profile_lam=*.csv: the seeds' stress and mean-length profiles, mean and spread."""
    cols: dict[str, np.ndarray] = {}
    for name in ("stress", "mean_length"):
        r, values = _common_profile(profiles, radius, name)
        cols["r"] = r
        cols |= _stats_columns(name, values)
    A.write_csv(data / f"profile_lam={lam:g}.csv", cols)


def _write_radius(data: Path, lam: float, radius: float, hists: list[dict], hist_c: dict
                  ) -> None:
    """radius_lam=*.csv (R on a common t grid) and time_lam=*.csv (t to reach each radius)."""
    t_end = min(float(h["t"][-1]) for h in hists)
    t = np.linspace(0.0, t_end, GRID_POINTS)
    R = np.array([np.interp(t, h["t"], h["radius"]) for h in hists])
    A.write_csv(data / f"radius_lam={lam:g}.csv",
                {"t": t} | _stats_columns("radius", R)
                | {"radius_continuum": np.interp(t, hist_c["t"], hist_c["radius"])})
    r = np.linspace(1.0, radius, GRID_POINTS)
    times = np.array([A.time_at_radius(h["t"], h["radius"], r) for h in hists])
    t_c = A.time_at_radius(hist_c["t"], hist_c["radius"], r)
    A.write_csv(data / f"time_lam={lam:g}.csv",
                {"radius": r} | _stats_columns("t", times) | {"t_continuum": t_c}
                | _stats_columns("rel_t", _relative(times, t_c[None, :])))


def _write_growth(data: Path, lam: float, radius: float, series: list[dict], hists: list[dict],
                  hist_c: dict) -> dict[str, float]:
    """growth_lam=*.csv: the growing colony against the continuum at the same radius.

    Per seed and frame: central stress (both estimators) / p(0) of the 1D reference at the
    frame's radius - 1; outermost ring and wavelength / the reference's - 1. From the histories
    (every step, :func:`history_growth`): the colony's mean stress over the continuum's mean
    pressure - 1 (averaged over one division period) and the time to reach the radius / the
    continuum run's - 1. Each is interpolated in log R onto radii GROWTH_FRACTIONS x R and
    reduced over the seeds. Returns the exponents a of abs(mean relative difference) ~ R^a over
    the radii where it keeps its final sign (:func:`trailing_rate`).
    """
    grid = GROWTH_FRACTIONS * radius
    cols: dict[str, np.ndarray] = {"radius": grid}
    rates: dict[str, float] = {}
    rel: dict[str, list] = {k: [] for k in ("central_max", "central_fit", "outer_ring",
                                            "wavelength", "mean_stress", "t")}
    for g, h in zip(series, hists, strict=True):
        logR = np.log(g["radius"])
        p0 = radial.max_pressure(g["radius"], lam)
        exact = np.array([_exact_rings(lam, R) for R in g["radius"]]).reshape(-1, 2)
        frame_rel = {"central_max": _relative(g["central_max"], p0),
                     "central_fit": _relative(g["central_fit"], p0),
                     "outer_ring": _relative(g["outer_ring"], exact[:, 0]),
                     "wavelength": _relative(g["wavelength"], exact[:, 1])}
        for k, v in frame_rel.items():
            rel[k].append(_interp_log(grid, logR, v))
        for k, v in history_growth(h, hist_c["t"], hist_c["radius"], lam, grid).items():
            rel[k].append(v)
    for k, v in rel.items():
        values = np.array(v)
        cols |= _stats_columns(f"rel_{k}", values)
        rates[f"rate_{k}"] = trailing_rate(grid, cols[f"rel_{k}_mean"])
    A.write_csv(data / f"growth_lam={lam:g}.csv", cols)
    return rates


def trailing_rate(radii: np.ndarray, diff: np.ndarray, min_points: int = 3) -> float:
    """Exponent a of abs(diff) ~ R^a over the largest radii where diff keeps its final sign.

    The fit (:func:`cases.analysis.power_law_fit`) takes the trailing run of finite values of
    ``diff`` with the sign of the last one (a difference that changes sign has no power law);
    nan when that run has fewer than ``min_points`` radii.
    """
    radii, diff = np.asarray(radii, float), np.asarray(diff, float)
    ok = np.isfinite(diff)
    if not ok.any():
        return math.nan
    r, d = radii[ok], diff[ok]
    sign = np.sign(d[-1])
    start = len(d)
    while start > 0 and np.sign(d[start - 1]) == sign and sign != 0:
        start -= 1
    if len(d) - start < min_points:
        return math.nan
    return A.power_law_fit(r[start:], np.abs(d[start:]))[0]


def _interp_log(grid: np.ndarray, logR: np.ndarray, values: np.ndarray) -> np.ndarray:
    """values(log R) at ``grid`` by linear interpolation over finite frames; nan outside."""
    ok = np.isfinite(values) & np.isfinite(logR)
    if ok.sum() < 2:
        return np.full(grid.shape, np.nan)
    x, y = logR[ok], values[ok]
    order = np.argsort(x)
    return np.interp(np.log(grid), x[order], y[order], left=np.nan, right=np.nan)


#: Division period of a particle growing at the free rate (l doubles in ln 2).
DIVISION_PERIOD = math.log(2.0)


def continuum_mean_pressure(R: np.ndarray, lam: float, points: int = 400) -> np.ndarray:
    """Area mean of the radial pressure over the disc of radius R: (2 / R^2) int_0^R p r dr.

    R^2 / 8 at lam = 0; for lam > 0 by the trapezoidal rule in r over ``points`` nodes of
    continuum.radial.pressure (relative error below 1e-5 at 400 nodes).
    """
    R = np.atleast_1d(np.asarray(R, dtype=float))
    if lam == 0:
        return R * R / 8.0
    x = np.linspace(0.0, 1.0, points)
    out = np.empty_like(R)
    for i, Ri in enumerate(R):
        p = radial.pressure(x * Ri, Ri, lam)
        out[i] = 2.0 * np.trapezoid(p * x, x)
    return out


def cycle_mean(t: np.ndarray, y: np.ndarray, period: float = DIVISION_PERIOD) -> np.ndarray:
    """Trailing mean of y(t) over one division period [t - period, t] (trapezoidal in t).

    A colony at lam = 0 divides in synchronous waves (every particle at once, every ln 2): its
    stress collapses at each wave and recovers over ~0.1 time units, so an instantaneous value
    depends on the phase of the wave; the mean over a period does not. nan for t < t_0 + period.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])
    start = t - period
    out = np.full(t.shape, np.nan)
    ok = start >= t[0]
    cum_start = np.interp(start[ok], t, cum)
    out[ok] = (cum[ok] - cum_start) / period
    return out


def mean_stress_ratio(hist: dict[str, np.ndarray], lam: float) -> dict[str, np.ndarray]:
    """The colony's mean particle stress over the continuum's mean pressure at the same radius.

    ``now``: mean_stress(t) / pbar(R(t)) at every history row (pbar:
    :func:`continuum_mean_pressure`, R the enclosing radius), ``cycle``: its
    :func:`cycle_mean`. The whole colony's mean carries far less noise than a central value.
    """
    R = hist["radius"]
    grid = np.geomspace(max(float(R.min()), 0.1), float(R.max()), 200)
    pbar = np.interp(R, grid, continuum_mean_pressure(grid, lam))
    with np.errstate(invalid="ignore", divide="ignore"):
        now = np.where(pbar > 0, hist["mean_stress"] / pbar, np.nan)
    return {"now": now, "cycle": cycle_mean(hist["t"], now)}


def history_growth(hist: dict[str, np.ndarray], t_c: np.ndarray, R_c: np.ndarray, lam: float,
                   grid: np.ndarray) -> dict[str, np.ndarray]:
    """Relative differences at the radii ``grid`` from a particle history and a continuum R(t).

    ``mean_stress``: cycle-mean :func:`mean_stress_ratio` - 1 when the colony first reaches
    each radius; ``t``: time to reach it over the continuum's (t_c, R_c) - 1.
    """
    ratio = mean_stress_ratio(hist, lam)["cycle"]
    t_p = A.time_at_radius(hist["t"], hist["radius"], grid)
    ok = np.isfinite(t_p)
    at = np.full(grid.shape, np.nan)
    at[ok] = np.interp(t_p[ok], hist["t"], ratio)
    return {"mean_stress": at - 1.0,
            "t": _relative(t_p, A.time_at_radius(t_c, R_c, grid))}


def _write_numerics(data: Path, numerics: dict[str, Path],
                    particles: dict[tuple[float, int], Path], lam: float) -> None:
    """numerics.csv: the first seed of ``lam`` at the default and at each halved setting."""
    base = particles.get((lam, 0))
    rows: dict[str, list] = {}
    for folder in ([base] if base is not None else []) + [numerics[k] for k in sorted(numerics)]:
        saved = upgrade(json.loads((folder / "config.json").read_text()))
        config = Config(**{f.name: saved[f.name] for f in fields(Config) if f.name in saved})
        row, *_ = _seed_numbers(folder)
        _append(rows, {"lam": lam, "seed": 0, "dt": config.dt, "tol": config.tol,
                       "solver_tol": config.effective_solver_tol} | row)
    A.write_csv(data / "numerics.csv", rows)


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Draw the ensemble figure (PNG and PDF in ``out``) from the CSVs in ``data`` only.

    (A) final stress profiles: seed mean (solid) and 2.5-97.5 % seed band, continuum pressure of
    the 1D reference (dashed); (B) R(t): seed band, continuum dashed; (C) central stress / p(0)
    against lam, both estimators, seed mean with the seed band (2.5-97.5 %) and the t-interval
    of the mean; (D) the growing colony: relative difference of the colony's mean stress
    (averaged over one division period) from the continuum's mean pressure and of the time to
    reach each radius, against the radius, seed bands.
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import plain_log_ticks, save_figure

    data, out = Path(data), Path(out)
    s = A.read_csv(data / "summary.csv")
    lams = s["lam"]
    colors = {lam: plt.cm.plasma(i / max(1, len(lams))) for i, lam in enumerate(lams)}
    fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
    n_seeds = int(np.max(s["n_seeds"]))

    a = ax[0, 0]
    for i, lam in enumerate(lams):
        p = A.read_csv(data / f"profile_lam={lam:g}.csv")
        a.plot(p["r"], p["stress_mean"], "-", color=colors[lam], label=rf"$\lambda$ = {lam:g}")
        a.fill_between(p["r"], p["stress_q025"], p["stress_q975"], color=colors[lam],
                       alpha=0.2, lw=0)
        a.plot(p["r"], radial.pressure(p["r"], s["radius_continuum"][i], lam), "--",
               color=colors[lam], lw=0.8)
    a.set(xlabel="r", ylabel=r"$\langle\sigma_n\rangle$, $p$ (dashed)",
          title=f"(A) final stress, {n_seeds} seeds: mean and 2.5-97.5 % band")
    a.legend(fontsize=8)

    a = ax[0, 1]
    for lam in lams:
        h = A.read_csv(data / f"radius_lam={lam:g}.csv")
        a.plot(h["t"], h["radius_mean"], "-", color=colors[lam], label=rf"$\lambda$ = {lam:g}")
        a.fill_between(h["t"], h["radius_q025"], h["radius_q975"], color=colors[lam],
                       alpha=0.25, lw=0)
        a.plot(h["t"], h["radius_continuum"], "--", color=colors[lam], lw=0.8)
    a.set(xlabel="t", ylabel="R(t)", yscale="log", title="(B) R(t): seeds band, continuum dashed")
    a.legend(fontsize=8)

    a = ax[1, 0]
    pos = lams > 0
    x = np.where(pos, lams, np.nan)
    xs = np.where(pos, x, np.min(lams[pos]) / 3 if pos.any() else 1e-4)
    for key, marker, shift, label in (("central_max", "o", 0.93, "largest annulus mean"),
                                      ("central_fit", "s", 1.07, r"fit $p_0 - c r^2$")):
        ratio = s[f"{key}_mean"] / s["p0_exact"]
        lo = s[f"{key}_q025"] / s["p0_exact"]
        hi = s[f"{key}_q975"] / s["p0_exact"]
        ci = s[f"{key}_ci95"] / s["p0_exact"]
        a.errorbar(xs * shift, ratio, yerr=[ratio - lo, hi - ratio], fmt=marker, mfc="none",
                   capsize=3, label=f"{label}: seeds 2.5-97.5 %")
        a.errorbar(xs * shift, ratio, yerr=ci, fmt="none", ecolor="k", elinewidth=2.5,
                   alpha=0.5)
    a.axhline(1.0, color="k", lw=0.8, ls=":")
    a.set(xscale="log", xlabel=r"$\lambda$ (leftmost: $\lambda$ = 0)",
          ylabel=r"central stress / continuum $p(0)$",
          title="(C) thick bars: 95 % t-interval of the mean")
    a.legend(fontsize=8)

    a = ax[1, 1]
    for lam in lams:
        g = A.read_csv(data / f"growth_lam={lam:g}.csv")
        a.plot(g["radius"], 100 * g["rel_mean_stress_mean"], "-o", ms=3, color=colors[lam],
               label=rf"$\lambda$ = {lam:g}")
        a.fill_between(g["radius"], 100 * g["rel_mean_stress_q025"],
                       100 * g["rel_mean_stress_q975"], color=colors[lam], alpha=0.15, lw=0)
        a.plot(g["radius"], 100 * g["rel_t_mean"], ":", color=colors[lam])
    a.axhline(0.0, color="k", lw=0.8)
    a.set(xlabel="colony radius R", xscale="log",
          ylabel="particles / continuum - 1 (%)",
          title="(D) mean stress, cycle mean (solid); time to R (dotted)")
    a.legend(fontsize=8)
    plain_log_ticks(fig)
    fig.tight_layout()
    (out / "tables.md").write_text(markdown_tables(data))
    return save_figure(fig, out / "ensemble")


def _pm(mean: float, std: float, scale: float = 100.0, digits: int = 1) -> str:
    """'mean +- std' (percent by default); '-' for nan."""
    if not math.isfinite(mean):
        return "-"
    text = f"{scale * mean:+.{digits}f}"
    return text + (f" +- {scale * std:.{digits}f}" if math.isfinite(std) else "")


def markdown_tables(data: str | Path) -> str:
    """The ensemble's tables (docs/results.md) from its CSVs: differences with the seed spread.

    Relative differences particles / continuum - 1 in percent, seed mean +- standard deviation
    over the seeds (n per lam); then the numerics runs against the seed spread; then the growing
    colony's differences at the radii of growth_lam=*.csv.
    """
    data = Path(data)
    s = A.read_csv(data / "summary.csv")
    d = A.read_csv(data / "differences.csv")
    rows = []
    for i, lam in enumerate(s["lam"]):
        cycle = s["mean_stress_cycle_mean"][i] - 1, s["mean_stress_cycle_std"][i]
        rows.append([f"{lam:g}", f"{int(s['n_seeds'][i])}",
                     _pm(d["rel_t_final_mean"][i], d["rel_t_final_std"][i]),
                     _pm(d["rel_slope_mean"][i], d["rel_slope_std"][i]),
                     _pm(d["rel_central_max_mean"][i], d["rel_central_max_std"][i]),
                     _pm(d["rel_central_fit_mean"][i], d["rel_central_fit_std"][i]),
                     _pm(*cycle),
                     _pm(d["rel_wavelength_mean"][i], d["rel_wavelength_std"][i]),
                     f"{s['packing_mean'][i]:.3f}"])
    out = [A.markdown_rows(
        ["lam", "seeds", "t to final R", "late dR/dt", "central stress: largest annulus",
         "central stress: fit", "mean stress (cycle mean)", "wavelength", "b rho_l (r < R/2)"],
        rows)]
    if (data / "numerics.csv").exists():
        num = A.read_csv(data / "numerics.csv")
        lam = float(num["lam"][0])
        i = int(np.flatnonzero(s["lam"] == lam)[0]) if lam in s["lam"] else None
        nrows = []
        for j in range(len(num["dt"])):
            row = [f"{num['dt'][j]:g}", f"{num['tol'][j]:g}",
                   f"{num['solver_tol'][j]:g}" if "solver_tol" in num else "tol / 2"]
            for q in ("t_final", "slope", "central_fit", "mean_stress_cycle"):
                base = num[q][0]
                rel = num[q][j] / base - 1 if j else math.nan
                spread = s[f"{q}_std"][i] / s[f"{q}_mean"][i] if i is not None else math.nan
                row.append(f"{num[q][j]:.4g}" + (f" ({100 * rel:+.1f} %)" if j else "")
                           + (f" [seeds +- {100 * spread:.1f} %]" if j == 0 else ""))
            nrows.append(row)
        out.append(A.markdown_rows(["dt", "tol", "solver tol", "t to final R", "late dR/dt",
                                    "central stress (fit)", "mean stress / continuum"],
                                   nrows))
    grows = []
    radii = None
    for lam in s["lam"]:
        g = A.read_csv(data / f"growth_lam={lam:g}.csv")
        radii = g["radius"]
        for key, name in (("mean_stress", "mean stress (cycle)"), ("central_fit",
                                                                   "central stress (fit)"),
                          ("t", "time to reach R")):
            grows.append([f"{lam:g}", name, *[_pm(m, e) for m, e in zip(
                g[f"rel_{key}_mean"], g[f"rel_{key}_std"], strict=True)]])
    if radii is not None:
        out.append(A.markdown_rows(["lam", "quantity", *[f"R = {R:.3g}" for R in radii]],
                                   grows))
    return "\n\n".join(out) + "\n"
