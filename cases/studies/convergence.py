"""Convergence study (issue 17): how far each numerical setting moves both models' results.

Every study refines ONE setting of the base configuration of its engine and measures how the
results move (``colony case convergence [--scale smoke|medium|paper]``).

Continuum (``continuum.Config``), disc colonies from R0 at lam in ``lams`` to the time
t_end = radial.time_to_radius(radius, lam), and the lam = 0 ellipse ``ellipse`` to the time at
which its area is pi radius^2. Errors against the converged references:

- ``radius``: max over the history rows of ``|R(t) / R_ref(t) - 1|``, R_ref = radial.radius;
- ``max_pressure``: ``|max p / p_ref(0) - 1|`` at t_end, p_ref(0) = radial.max_pressure(R_ref);
- ``G``: max over the nodes of ``|G - G_ref(r)|``, G_ref = radial.growth_phase at r = ``|x|``
  (capped at R_ref); zero at lam = 0 (G = t exactly), so not fitted there; ``G_rms``: the
  root mean square over the nodes of the same difference (the max is set by a few nodes near
  the edge);
- ``ring_radii``: max over the rings k of both of ``|rbar_k - r_k|``, rbar_k the mean radius of
  the contour G = k ln 2 (:func:`cases.analysis.continuum_rings`, continuum.rings), r_k of
  radial.ring_radii;
- ``mean_length``: median over the nodes away from the ring jumps of
  ``|lbar_Psi - 2^frac(G / ln 2)|``, the transported mean length against its delta limit
  (nodes whose phase frac(G / ln 2 + w) is more than 2 w from a division, w the largest bump
  width of the study);
- ``mean_length_transport``: the same median against the exact shift of the run's own initial
  bump (``continuum.sizes.CharacteristicSizes`` on ``REFERENCE_CELLS`` cells advanced by the
  node's G in one exact step): the error of the Psi transport alone;
- ``semi_axes`` (ellipse): ``max(|a / a_ref - 1|, |b / b_ref - 1|)``, a, b the semi-axes of the
  boundary's area moments (I_xx = a^2 / 4, I_yy = b^2 / 4), a_ref, b_ref of the exact lam = 0
  ellipse da/dt = a b^2 / (a^2 + b^2), db/dt = b a^2 / (a^2 + b^2) (model.md).

The studies (``Family``): ``mesh`` (n_nodes, uniform meshes h_max = 100, no interior coarsening:
h ~ R / sqrt(n_nodes) at every time, no remeshing; x = the initial boundary spacing h0),
``time_step`` (courant at a fixed mesh sequence: dt = courant h / u_edge, so dt is decoupled from
the mesh below the CFL bound courant <= 1; the errors there are dominated by the mesh, so they are
measured as differences from the run at the smallest courant, ``reference = finest``),
``length_cells`` (n_length_cells, for each psi_transport: the one by labels), ``bump_width``
(at 128 length cells), ``q_min`` and ``stretch`` (the remeshing thresholds, on meshes capped at
h_max so that the colony is remeshed as it grows).

Particles (``particles.Config``), one colony at lam ``particle_lam`` grown to ``particle_radius``:
dt, solver_tol and tol refined one at a time (the others at the base), each run compared with
the finest of its sequence (same seed), and ``seeds`` runs at the base setting for the seed
spread. Quantities: ``t_final`` (time at the radius), ``radius_t`` (max over t of
``|R(t) - R_ref(t)|``), ``stress_profile`` and ``length_profile`` (RMS over the equal-area annuli
of the difference of the final pooled profiles, :func:`cases.analysis.final_particle_profile`;
stress relative to the mean reference stress), ``outer_ring`` (the outermost peak of the
mean-length profile, :func:`cases.analysis.ring_peaks`). The seed spread of a quantity is the
RMS over the seeds k > 0 of the same difference between seed k and seed 0 at the base: the size
of a difference that a change of seed alone makes.

Outputs (``out/data``): ``orders.csv`` (study, engine, parameter, quantity, case, reference,
observed_order, expected_order, smallest and largest error, seed_spread, resolved: whether the
smallest difference exceeds the seed spread, note: "unchanged" where the setting changed no
error by more than 1e-9 relative, e.g. a threshold never reached), one CSV per
curve ``continuum_STUDY_CASE.csv`` / ``particles_STUDY.csv`` (parameter, x, one column per
quantity) and ``particles_seeds.csv``; ``plot`` draws convergence_continuum.png and
convergence_particles.png from them.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cases import analysis as A
from cases.sweep import ENGINES, is_done, run_engine, run_name, sweep
from continuum import ellipse, radial
from continuum.growth import LN2, mean_length
from continuum.sizes import TRANSPORTS

__all__ = ["SCALES", "Family", "families", "compute", "reduce", "plot", "continuum_errors",
           "particle_quantities", "ellipse_reference", "fit_order", "order_tables",
           "ORDER_COLUMNS"]

#: Cells of the fine length grid of the exact shift of the initial bump (``mean_length_transport``).
REFERENCE_CELLS = 2048
#: Expected orders. mesh: R(t), p by the P1 pressure and Heun's motion of the nodes (2), G and its
#: contours by the nodal velocity, O(h) on unstructured meshes (1); time_step: Heun's RK2 (2);
#: length_cells: the exact shift of cell averages (the moments of the cell-averaged bump, 2);
#: bump_width: the mean of the bump sits at s ~ w (1); particles dt: explicit first-order
#: stepping (1). None: no order expected.
EXPECTED: dict[tuple[str, str], float] = {
    ("mesh", "radius"): 2, ("mesh", "max_pressure"): 2, ("mesh", "G"): 1,
    ("mesh", "G_rms"): 1, ("mesh", "ring_radii"): 1, ("mesh", "semi_axes"): 2,
    ("time_step", "radius"): 2, ("time_step", "max_pressure"): 2, ("time_step", "G"): 2,
    ("time_step", "G_rms"): 2,
    ("time_step", "ring_radii"): 2, ("time_step", "semi_axes"): 2,
    ("length_cells:characteristics-labels", "mean_length_transport"): 2,
    ("bump_width", "mean_length"): 1,
    ("dt", "t_final"): 1, ("dt", "radius_t"): 1,
}
CONTINUUM_QUANTITIES = ("radius", "max_pressure", "G", "G_rms", "ring_radii", "semi_axes",
                        "mean_length", "mean_length_transport")
PARTICLE_QUANTITIES = ("t_final", "radius_t", "stress_profile", "length_profile", "outer_ring")
ORDER_COLUMNS = ("study", "engine", "parameter", "quantity", "case", "reference",
                 "observed_order", "expected_order", "smallest_error", "largest_error",
                 "seed_spread", "resolved", "note")


@dataclass(frozen=True)
class Family:
    """One study: ``parameter`` refined over ``values`` from ``base`` (engine settings).

    ``cases``: the lam of the disc colonies (float) and/or "ellipse"; ``x``: how a value maps to
    the abscissa of the log-log plot (``"value"``, ``"inverse"`` 1/value, ``"minus_one"``
    value - 1, ``"h"`` the run's initial boundary spacing h0, proportional to h at every later
    time when the mesh is not capped); ``reference``: "exact" (the references of the module
    docstring) or "finest" (the run at ``values[-1]``, not fitted);
    ``quantities``: those measured.
    """

    study: str
    engine: str
    parameter: str
    values: tuple
    base: dict[str, Any] = field(default_factory=dict)
    cases: tuple = (0.0,)
    x: str = "value"
    reference: str = "exact"
    quantities: tuple = CONTINUUM_QUANTITIES


#: Run sizes of the study (see :func:`families`).
SCALES: dict[str, dict[str, Any]] = {
    "smoke": {
        "radius": 5.0, "lams": (1e-2,), "ellipse": (2.0, 1.0),
        "n_nodes": (150, 300, 600), "courant": (0.6, 0.3, 0.15), "time_nodes": 150,
        "length_cells": (32, 64), "bump_width": (0.16, 0.08), "q_min": (0.3, 0.7),
        "stretch": (1.5, 1.25), "remesh_mesh": {"n_nodes": 100, "h_max": 0.5},
        "particle_lam": 1e-2, "particle_radius": 6.0, "dt": (0.02, 0.01),
        "solver_tol": (5e-4, 2.5e-4), "tol": (2e-3, 1e-3), "seeds": 3,
    },
    "medium": {
        "radius": 20.0, "lams": (0.0, 1e-3, 1e-2), "ellipse": (2.0, 1.0),
        "n_nodes": (500, 1000, 2000, 4000), "courant": (0.8, 0.4, 0.2, 0.1),
        "time_nodes": 1000, "length_cells": (32, 64, 128, 256),
        "bump_width": (0.16, 0.08, 0.04, 0.02), "q_min": (0.2, 0.4, 0.6, 0.7, 0.8),
        "stretch": (2.0, 1.5, 1.25, 1.15), "remesh_mesh": {"n_nodes": 500, "h_max": 0.5},
        # particles: eight runs at radius 40 (each 35-90 s of CPU on the shared 2-core machine)
        "particle_lam": 1e-2, "particle_radius": 40.0, "dt": (0.04, 0.02, 0.01),
        "solver_tol": (1e-3, 5e-4), "tol": (4e-3, 1e-3),
        "seeds": 4, "time_step_cases": "few", "remesh_cases": "few",
    },
    "paper": {
        "radius": 40.0, "lams": (0.0, 1e-3, 1e-2), "ellipse": (2.0, 1.0),
        "n_nodes": (1000, 2000, 4000, 8000, 16000),
        "courant": (0.8, 0.4, 0.2, 0.1, 0.05, 0.025), "time_nodes": 2000,
        "length_cells": (32, 64, 128, 256, 512), "bump_width": (0.16, 0.08, 0.04, 0.02, 0.01),
        "q_min": (0.2, 0.4, 0.6, 0.7, 0.8), "stretch": (2.0, 1.5, 1.25, 1.15),
        "remesh_mesh": {"n_nodes": 2000, "h_max": 0.5},
        "particle_lam": 1e-2, "particle_radius": 40.0, "dt": (0.04, 0.02, 0.01, 0.005, 0.0025),
        "solver_tol": (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5),
        "tol": (4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4), "seeds": 10,
    },
}
#: Settings shared by every continuum run of the study: uniform meshes, first and last frames.
CONTINUUM_BASE = {"h_max": 100.0, "interior_coarsening": 1.0, "output_every": 0.0,
                  "write_fields": True}
#: The particle base: dt, tol and the solver tolerance (default tol / 2) written out, so that the
#: base run has one name (one folder) in every sequence; fixed steps, so that dt is the step.
PARTICLE_BASE = {"dt": 0.01, "tol": 1e-3, "solver_tol": 5e-4, "step_control": "fixed"}
PARTICLE_FRAME_TIME = 0.5  # time between particle trajectory frames, whatever dt


def scale_config(scale: str) -> dict[str, Any]:
    """The run sizes of ``scale``; ValueError for an unknown one."""
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {tuple(SCALES)}, got {scale!r}")
    return SCALES[scale]


def families(scale: str) -> list[Family]:
    """The studies of ``scale``.

    Continuum: mesh, time_step, length_cells (per transport), bump_width, q_min, stretch;
    particles: dt, solver_tol, tol.
    """
    cfg = scale_config(scale)
    cases = (*cfg["lams"], "ellipse")
    remesh = dict(cfg["remesh_mesh"])
    lam_psi = max(cfg["lams"])
    remesh_cases = (lam_psi,) if cfg.get("remesh_cases") == "few" else (0.0, lam_psi)
    exact_q = ("radius", "max_pressure", "G", "G_rms", "ring_radii", "semi_axes")
    out = [
        Family("mesh", "continuum", "n_nodes", cfg["n_nodes"], {}, cases, "h",
               quantities=exact_q),
        Family("time_step", "continuum", "courant", cfg["courant"],
               {"n_nodes": cfg["time_nodes"]},
               (lam_psi, "ellipse") if cfg.get("time_step_cases") == "few" else cases,
               reference="finest", quantities=exact_q),
    ]
    out += [Family(f"length_cells:{t}", "continuum", "n_length_cells", cfg["length_cells"],
                   remesh | {"initial_sizes": "bump", "psi_transport": t}, (lam_psi,), "inverse",
                   quantities=("mean_length", "mean_length_transport"))
            for t in TRANSPORTS]
    out += [
        Family("bump_width", "continuum", "bump_width", cfg["bump_width"],
               remesh | {"initial_sizes": "bump", "n_length_cells": 128}, (lam_psi,),
               quantities=("mean_length", "mean_length_transport")),
        Family("q_min", "continuum", "q_min", cfg["q_min"], remesh, remesh_cases,
               quantities=exact_q),
        Family("stretch", "continuum", "stretch", cfg["stretch"], remesh, remesh_cases,
               "minus_one", quantities=exact_q),
    ]
    out += [Family(p, "particles", p, cfg[p], {}, (cfg["particle_lam"],), reference="finest",
                   quantities=PARTICLE_QUANTITIES) for p in ("dt", "solver_tol", "tol")]
    return out


# ----------------------------------------------------------------------------- run parameters


def ellipse_shape(cfg: dict[str, Any]) -> str:
    a, b = cfg["ellipse"]
    return f"ellipse:{a:g},{b:g}"


def ellipse_time(cfg: dict[str, Any]) -> float:
    """Time at which the lam = 0 ellipse has the area pi radius^2 (area grows as exp(t))."""
    a, b = cfg["ellipse"]
    return 2.0 * math.log(cfg["radius"] / math.sqrt(a * b))


def continuum_params(cfg: dict[str, Any], fam: Family, case, value) -> dict[str, Any]:
    """Sweep parameters of one continuum run: the case's colony, the family's base and value."""
    settings = CONTINUUM_BASE | fam.base | {fam.parameter: value}
    if case == "ellipse":
        return {"engine": "continuum", "lam": 0.0, "time": ellipse_time(cfg),
                "shape": ellipse_shape(cfg), **settings}
    lam = float(case)
    return {"engine": "continuum", "lam": lam,
            "time": float(radial.time_to_radius(cfg["radius"], lam)), **settings}


def particle_params(cfg: dict[str, Any], parameter: str | None = None, value=None,
                    seed: int = 0) -> dict[str, Any]:
    """Sweep parameters of one particle run: the base with ``parameter = value``, ``seed``."""
    settings = dict(PARTICLE_BASE)
    if parameter is not None:
        settings[parameter] = value
    return {"engine": "particles", "lam": float(cfg["particle_lam"]),
            "radius": float(cfg["particle_radius"]), "seed": int(seed),
            "output_every": PARTICLE_FRAME_TIME, **settings}


def _all_params(scale: str, engines: tuple[str, ...]) -> dict[str, dict]:
    """{run name: sweep parameters} of every run of ``scale`` for ``engines`` (no duplicates)."""
    cfg = scale_config(scale)
    params = []  # the seed runs first: without them no particle difference can be judged
    if "particles" in engines:
        params += [particle_params(cfg, seed=s) for s in range(cfg["seeds"])]
    for fam in families(scale):
        if fam.engine not in engines:
            continue
        for value in fam.values:
            if fam.engine == "continuum":
                params += [continuum_params(cfg, fam, case, value) for case in fam.cases]
            else:
                params.append(particle_params(cfg, fam.parameter, value))
    return {run_name(p): p for p in params}


# ----------------------------------------------------------------------------- references


def ellipse_reference(a0: float, b0: float, t: float) -> tuple[float, float]:
    """Exact semi-axes at t of the lam = 0 ellipse (continuum.ellipse.semi_axes)."""
    a, b = ellipse.semi_axes(a0, b0, t)
    return float(a), float(b)


def _exact_bump_shift(config: dict, G: np.ndarray) -> np.ndarray:
    """Mean length of the run's initial bump shifted exactly by G (on REFERENCE_CELLS cells)."""
    from continuum.sizes import CharacteristicSizes, LengthGrid

    exact = CharacteristicSizes.bump(LengthGrid(REFERENCE_CELLS), len(G),
                                     width=config["bump_width"])
    exact.advance(G, 1.0)
    return exact.mean_length()


def _away_from_jumps(G: np.ndarray, width: float) -> np.ndarray:
    """Nodes whose phase frac(G / ln 2 + w) is more than 2 w from a division."""
    phase = np.mod(G / LN2 + width, 1.0)
    return np.minimum(phase, 1.0 - phase) > 2 * width


def continuum_errors(folder: str | Path, mask_width: float | None = None,
                     psi: bool = True) -> dict[str, float]:
    """Errors of one continuum run folder against the references (module docstring).

    Reads its config.json, history.csv, boundary.csv, last VTU frame and rings (rings.csv or the
    contours of the last frame's G). ``mask_width``: the bump width of the node mask of the
    mean-length errors (default the run's); ``psi=False`` skips the mean-length errors (nan).
    Quantities without a reference are nan; also
    returns the run's initial boundary spacing ``h0``, its final ``t``, ``radius_final``,
    ``max_pressure_final``, ``n_remesh``, the worst triangle quality of the run
    ``min_quality``, ``lam``, the outermost ring's mean radius ``outer_ring`` and
    the semi-axes ``a``, ``b``.
    """
    folder = Path(folder)
    config = json.loads((folder / "config.json").read_text())
    hist = A.read_csv(folder / "history.csv")
    pts, _, data = A.read_continuum_frame(A.continuum_frames(folder)[-1][1])
    lam, t = float(config["lam"]), float(hist["t"][-1])
    out = dict.fromkeys(CONTINUUM_QUANTITIES, math.nan)
    out |= {"h0": float(hist["h"][0]), "t": t, "radius_final": float(hist["radius"][-1]),
            "max_pressure_final": float(hist["max_pressure"][-1]),
            "n_remesh": float(hist["n_remesh"][-1]),
            "min_quality": float(np.min(hist["min_quality"])), "lam": lam, "outer_ring": math.nan,
            "a": math.nan, "b": math.nan}
    G, width = data["G"], config["bump_width"]
    away = _away_from_jumps(G, width if mask_width is None else mask_width)
    if psi and away.any():
        lpsi = data["mean_length_psi"][away]
        out["mean_length"] = float(np.median(np.abs(lpsi - mean_length(G[away]))))
        out["mean_length_transport"] = float(np.median(np.abs(
            lpsi - _exact_bump_shift(config, G[away]))))
    rings = A.continuum_rings(folder)
    if len(rings["k"]):
        out["outer_ring"] = float(rings["mean_radius"][np.argmax(rings["k"])])
    if config["shape"].startswith("ellipse:"):
        a0, b0 = (float(v) for v in config["shape"].split(":")[1].split(","))
        a, b = ellipse.moment_axes(np.loadtxt(folder / "boundary.csv", delimiter=",", skiprows=1))
        a_ref, b_ref = ellipse_reference(a0, b0, t)
        out |= {"a": a, "b": b, "semi_axes": max(abs(a / a_ref - 1), abs(b / b_ref - 1))}
        return out
    R_ref = radial.radius(hist["t"], lam)
    out["radius"] = float(np.max(np.abs(hist["radius"] / R_ref - 1)))
    out["max_pressure"] = abs(out["max_pressure_final"] / radial.max_pressure(R_ref[-1], lam) - 1)
    if lam != 0:
        r = np.minimum(np.hypot(pts[:, 0], pts[:, 1]), R_ref[-1])
        dG = G - radial.growth_phase(lam, r, t)
        out["G"], out["G_rms"] = float(np.max(np.abs(dG))), float(np.sqrt(np.mean(dG * dG)))
        ref, k = radial.ring_radii(lam, t=t, with_index=True)
        common, i, j = np.intersect1d(rings["k"], k, return_indices=True)
        if common.size:
            out["ring_radii"] = float(np.max(np.abs(rings["mean_radius"][i] - ref[j])))
    return out


def _continuum_differences(runs: list[dict], folders: list[Path]) -> list[dict]:
    """Self-convergence: each run's scalar results against those of the last (finest) run.

    radius: ``|R_end / R_ref - 1|``, max_pressure: ``|p_max / p_ref - 1|`` at t_end, G: max
    nodal difference and G_rms its RMS (same node count, i.e. the same mesh; else nan),
    ring_radii: the outermost ring's mean radius, semi_axes: max of the relative differences of
    a and b.
    """
    ref, ref_folder = runs[-1], folders[-1]
    G_ref = A.read_continuum_frame(A.continuum_frames(ref_folder)[-1][1])[2]["G"]
    out = []
    for run, folder in zip(runs, folders, strict=True):
        G = A.read_continuum_frame(A.continuum_frames(folder)[-1][1])[2]["G"]
        row = dict.fromkeys(CONTINUUM_QUANTITIES, math.nan)
        row["radius"] = abs(run["radius_final"] / ref["radius_final"] - 1)
        row["max_pressure"] = abs(run["max_pressure_final"] / ref["max_pressure_final"] - 1)
        if G.shape == G_ref.shape and run["lam"] != 0:  # lam = 0: G = t exactly
            row["G"] = float(np.max(np.abs(G - G_ref)))
            row["G_rms"] = float(np.sqrt(np.mean((G - G_ref) ** 2)))
        row["ring_radii"] = abs(run["outer_ring"] - ref["outer_ring"])
        if math.isfinite(run["a"]):
            row["semi_axes"] = max(abs(run["a"] / ref["a"] - 1), abs(run["b"] / ref["b"] - 1))
            row["radius"] = math.nan  # the ellipse: its axes, not a disc radius
            row["max_pressure"] = math.nan
        out.append(row)
    return out


# ----------------------------------------------------------------------------- particles


def particle_quantities(folder: str | Path) -> dict[str, Any]:
    """The measured results of one particle run: t_final, R(t), final profiles, outer ring.

    Profiles pooled over the frames within one length of the final radius
    (:func:`cases.analysis.final_particle_profile`); the outer ring is the outermost peak of the
    mean-length profile (:func:`cases.analysis.ring_peaks`, annulus standard errors as noise;
    nan without a peak).
    """
    hist = A.read_csv(Path(folder) / "history.csv")
    prof = A.final_particle_profile(folder, growth_window=1.0)
    keep = prof["count"] >= 10
    se = prof["mean_length_std"][keep] / np.sqrt(prof["count"][keep])
    peaks = A.ring_peaks(prof["r"][keep], prof["mean_length"][keep], stderr=se)
    return {"t": hist["t"], "R": hist["radius"], "t_final": float(hist["t"][-1]),
            "profile": prof, "outer_ring": float(peaks[-1]) if peaks.size else math.nan}


def particle_difference(q: dict[str, Any], ref: dict[str, Any]) -> dict[str, float]:
    """Differences of the quantities of two particle runs (module docstring)."""
    t_end = min(q["t"][-1], ref["t"][-1])
    grid = np.linspace(0.0, t_end, 400)
    dR = np.interp(grid, q["t"], q["R"]) - np.interp(grid, ref["t"], ref["R"])
    out = {"t_final": abs(q["t_final"] - ref["t_final"]), "radius_t": float(np.max(np.abs(dR))),
           "outer_ring": abs(q["outer_ring"] - ref["outer_ring"])}
    p, pr = q["profile"], ref["profile"]
    for name, key, scale in (("stress_profile", "stress", float(np.nanmean(pr["stress"]))),
                             ("length_profile", "mean_length", 1.0)):
        d = p[key] - np.interp(p["r"], pr["r"], pr[key])
        out[name] = float(np.sqrt(np.nanmean(d * d))) / scale
    return out


# ----------------------------------------------------------------------------- reduction


def fit_order(x, err) -> float:
    """Observed order: the slope of log(err) against log(x) by least squares.

    Only positive finite pairs; nan with fewer than two distinct x (cases.analysis.power_law_fit).
    """
    try:
        return A.power_law_fit(np.asarray(x, float), np.asarray(err, float))[0]
    except ValueError:
        return math.nan


def _x(fam: Family, value, row: dict) -> float:
    if fam.x == "h":
        return row["h0"]
    if fam.x == "inverse":
        return 1.0 / value
    if fam.x == "minus_one":
        return value - 1.0
    return float(value)


def _case_name(case) -> str:
    return "ellipse" if case == "ellipse" else f"lam={float(case):g}"


def _order_rows(fam: Family, case: str, x: np.ndarray, errors: dict[str, np.ndarray],
                spread: dict[str, float] | None = None) -> list[dict]:
    rows = []
    fit = slice(0, -1) if fam.reference == "finest" else slice(None)
    for qn in fam.quantities:
        e = np.asarray(errors[qn], float)[fit]
        if not np.isfinite(e).any():
            continue
        s = math.nan if spread is None else spread.get(qn, math.nan)
        fin = e[np.isfinite(e)]
        # the setting changes nothing: equal errors, or none at all (runs identical bit for bit)
        same = (fin.size > 1 and bool(np.ptp(fin) <= 1e-9 * fin.max())) or not np.any(fin > 0)
        rows.append({
            "study": fam.study, "engine": fam.engine, "parameter": fam.parameter,
            "quantity": qn, "case": case, "reference": fam.reference,
            "observed_order": 0.0 if same else fit_order(x[fit], e),
            "expected_order": EXPECTED.get((fam.study, qn), math.nan),
            "smallest_error": float(fin.min()), "largest_error": float(fin.max()),
            "seed_spread": s,
            "resolved": "" if spread is None else ("yes" if fin.min() > s else "no"),
            "note": "unchanged" if same else ""})
    return rows


def _write_orders(path: Path, rows: list[dict]) -> Path:
    """orders.csv: text columns as they are, numbers as %.4g, nan as an empty cell."""
    with path.open("w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(ORDER_COLUMNS)
        for r in rows:
            w.writerow(["" if isinstance(r[c], float) and not math.isfinite(r[c])
                        else f"{r[c]:.4g}" if isinstance(r[c], float) else r[c]
                        for c in ORDER_COLUMNS])
    return path


def reduce(scale: str, folders: dict[str, Path], data: str | Path) -> Path:
    """Reduce the run folders {run name: folder} of ``scale`` to the CSVs in ``data``.

    A family whose runs are missing (an engine not computed) is left out.
    """
    cfg = scale_config(scale)
    data = Path(data)
    data.mkdir(parents=True, exist_ok=True)
    orders: list[dict] = []
    spread = _particle_seeds(cfg, folders, data)
    for fam in families(scale):
        if fam.engine == "continuum":
            orders += _reduce_continuum(cfg, fam, folders, data)
        elif spread is not None:
            orders += _reduce_particles(cfg, fam, folders, data, spread)
    _write_orders(data / "orders.csv", orders)
    return data


def _reduce_continuum(cfg: dict, fam: Family, folders: dict[str, Path], data: Path
                      ) -> list[dict]:
    rows = []
    mask = max(cfg["bump_width"])
    for case in fam.cases:
        names = [run_name(continuum_params(cfg, fam, case, v)) for v in fam.values]
        if not all(n in folders for n in names):
            continue
        psi = any(q.startswith("mean_length") for q in fam.quantities)
        runs = [continuum_errors(folders[n], mask_width=mask, psi=psi) for n in names]
        errors = runs if fam.reference == "exact" else _continuum_differences(
            runs, [folders[n] for n in names])
        x = np.array([_x(fam, v, r) for v, r in zip(fam.values, runs, strict=True)])
        cols = {fam.parameter: np.asarray(fam.values, float), "x": x}
        cols |= {q: np.array([e[q] for e in errors]) for q in fam.quantities}
        cols["n_remesh"] = np.array([r["n_remesh"] for r in runs])
        cols["min_quality"] = np.array([r["min_quality"] for r in runs])
        name = _case_name(case)
        A.write_csv(data / f"continuum_{fam.study.replace(':', '_')}_{name}.csv", cols)
        rows += _order_rows(fam, name, x, cols)
    return rows


def _particle_seeds(cfg: dict, folders: dict[str, Path], data: Path) -> dict[str, float] | None:
    """The seed spread of every particle quantity (module docstring); writes particles_seeds.csv.

    None with fewer than two seed runs (particles not computed); the seeds whose runs are
    missing (``--engines finished``) are left out.
    """
    names = [run_name(particle_params(cfg, seed=s)) for s in range(cfg["seeds"])]
    names = [n for n in names if n in folders]
    if len(names) < 2:
        return None
    qs = [particle_quantities(folders[n]) for n in names]
    diffs = [particle_difference(q, qs[0]) for q in qs[1:]]
    cols = {"seed": np.arange(len(qs), dtype=float),
            "t_final": np.array([q["t_final"] for q in qs]),
            "outer_ring": np.array([q["outer_ring"] for q in qs])}
    cols |= {k: np.array([0.0] + [d[k] for d in diffs]) for k in PARTICLE_QUANTITIES
             if k not in cols}
    A.write_csv(data / "particles_seeds.csv", cols)
    return {k: _rms([d[k] for d in diffs]) for k in PARTICLE_QUANTITIES}


def _rms(values) -> float:
    """Root mean square of the finite values (nan if none)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v * v))) if v.size else math.nan


def _reduce_particles(cfg: dict, fam: Family, folders: dict[str, Path], data: Path,
                      spread: dict[str, float]) -> list[dict]:
    """One particle sequence against its finest run present (at least two runs)."""
    values = [v for v in fam.values
              if run_name(particle_params(cfg, fam.parameter, v)) in folders]
    if len(values) < 2:
        return []
    qs = [particle_quantities(folders[run_name(particle_params(cfg, fam.parameter, v))])
          for v in values]
    diffs = [particle_difference(q, qs[-1]) for q in qs]
    x = np.asarray(values, float)
    cols = {fam.parameter: x, "x": x, "t_final": np.array([q["t_final"] for q in qs]),
            "outer_ring_radius": np.array([q["outer_ring"] for q in qs])}
    cols |= {f"diff_{k}": np.array([d[k] for d in diffs]) for k in PARTICLE_QUANTITIES}
    cols |= {f"spread_{k}": np.full(x.size, spread[k]) for k in PARTICLE_QUANTITIES}
    A.write_csv(data / f"particles_{fam.study}.csv", cols)
    errors = {k: cols[f"diff_{k}"] for k in PARTICLE_QUANTITIES}
    return _order_rows(fam, f"lam={cfg['particle_lam']:g}", x, errors, spread)


# ----------------------------------------------------------------------------- compute, plot


def compute(scale: str = "smoke", out: str | Path = "runs/case-convergence-smoke",
            scheduler: str | None = None, n_workers: int = 2,
            runs: str | Path | None = None, engines: tuple[str, ...] = ENGINES,
            finished_only: tuple[str, ...] = ()) -> Path:
    """Run (or reuse) every run of ``scale`` under ``runs`` (default out/runs), reduce to out/data.

    One sweep (cases.sweep, Dask) for all of them. ``engines``: a subset of ENGINES;
    ``finished_only``: engines whose runs are only reused where finished under ``runs``.
    """
    scale_config(scale)
    bad = [e for e in (*engines, *finished_only) if e not in ENGINES]
    if bad or not engines:
        raise ValueError(f"engines must be a non-empty subset of {ENGINES}, got {engines!r}")
    root = Path(runs) if runs else Path(out) / "runs"
    params = _all_params(scale, tuple(engines))
    folders = {n: root / n for n, p in params.items()
               if p["engine"] in finished_only and is_done(root / n, p)}
    todo = {n: p for n, p in params.items() if p["engine"] not in finished_only}
    folders |= dict(zip(todo, sweep(run_engine, list(todo.values()), root,
                                    scheduler=scheduler, n_workers=n_workers), strict=True))
    return reduce(scale, folders, Path(out) / "data")


def _orders(data: Path) -> list[dict[str, str]]:
    with (data / "orders.csv").open() as fh:
        return list(csv.DictReader(fh))


def order_tables(data: str | Path) -> str:
    """Markdown tables of orders.csv: continuum (observed vs expected) and particles.

    Continuum: one row per study, quantity and case with the fitted and the expected order and
    the error range; particles: the differences from the finest setting beside the seed spread.
    """
    rows = _orders(Path(data))

    def num(v: str) -> str:
        return "" if v == "" else f"{float(v):.3g}"

    def order(r: dict) -> str:
        return "unchanged" if r["note"] == "unchanged" else num(r["observed_order"]) or "-"

    cont = [[r["study"], r["quantity"], r["case"], r["reference"], order(r),
             r["expected_order"] or "-", f"{num(r['largest_error'])} .. {num(r['smallest_error'])}"]
            for r in rows if r["engine"] == "continuum"]
    part = [[r["parameter"], r["quantity"], order(r),
             r["expected_order"] or "-",
             f"{num(r['largest_error'])} .. {num(r['smallest_error'])}", num(r["seed_spread"]),
             r["resolved"]] for r in rows if r["engine"] == "particles"]
    out = A.markdown_rows(("study", "quantity", "case", "against", "observed order",
                           "expected order", "error (largest .. smallest)"), cont)
    if part:
        out += "\n\n" + A.markdown_rows(
            ("parameter", "quantity", "observed order", "expected order",
             "difference from the finest (largest .. smallest)", "seed spread",
             "above the seed spread"), part)
    return out + "\n"


def _slope_label(orders: list[dict], study: str, case: str, quantity: str) -> str:
    for r in orders:
        if (r["study"], r["case"], r["quantity"]) == (study, case, quantity):
            exp = f", expected {r['expected_order']}" if r["expected_order"] else ""
            return f" (slope {float(r['observed_order']):.2f}{exp})" if r["observed_order"] \
                else ""
    return ""


CONTINUUM_PANELS = (("mesh", "boundary spacing h"), ("time_step", "courant (dt at fixed mesh)"),
                    ("length_cells", "length cell width 1/n_length_cells"),
                    ("bump_width", "bump width w"), ("q_min", "q_min"),
                    ("stretch", "stretch - 1"))


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Draw convergence_continuum and convergence_particles (PNG, PDF) from the CSVs in ``data``.

    Also writes ``orders.md``, the tables of :func:`order_tables`.
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    data, out = Path(data), Path(out)
    orders = _orders(data)
    paths = []
    fig, axes = plt.subplots(2, 3, figsize=(15, 9))
    for ax, (study, xlabel) in zip(axes.ravel(), CONTINUUM_PANELS, strict=True):
        for path in sorted(data.glob(f"continuum_{study}*.csv")):
            tab = A.read_csv(path)
            stem = path.stem[len("continuum_"):]
            case = stem.split("_")[-1]
            fam = stem[: -len(case) - 1].replace("length_cells_", "length_cells:")
            tag = case if study != "length_cells" else fam.split(":")[1]
            for q in CONTINUUM_QUANTITIES:
                pos = np.isfinite(tab[q]) & (tab[q] > 0) if q in tab else [False]
                if np.any(pos):
                    ax.loglog(tab["x"][pos], tab[q][pos], "o-", ms=3,
                              label=f"{q} {tag}{_slope_label(orders, fam, case, q)}")
        ax.set(xlabel=xlabel, ylabel="error", title=study)
        ax.legend(fontsize=5.5)
    fig.suptitle("continuum: errors against the references (time_step: against the smallest "
                 "courant)")
    fig.tight_layout()
    paths += save_figure(fig, out / "convergence_continuum")
    particle = [(p, data / f"particles_{p}.csv") for p in ("dt", "solver_tol", "tol")]
    particle = [(p, f) for p, f in particle if f.exists()]
    if particle:
        fig, axes = plt.subplots(1, len(particle), figsize=(5 * len(particle), 4.5), squeeze=False)
        for ax, (p, path) in zip(axes[0], particle, strict=True):
            tab = A.read_csv(path)
            drawn = 0
            for q in PARTICLE_QUANTITIES:
                y = tab[f"diff_{q}"][:-1] / tab[f"spread_{q}"][:-1]
                pos = np.isfinite(y) & (y > 0)  # an exact 0 (the same bits) has no logarithm
                if np.any(pos):
                    ax.loglog(tab["x"][:-1][pos], y[pos], "o-", ms=3, label=q)
                    drawn += 1
            if not drawn:
                ax.text(0.5, 0.6, "no positive difference to draw\n(zero, or no seed spread)",
                        ha="center", transform=ax.transAxes, fontsize=8)
                ax.set_xscale("log")
                ax.set_yscale("log")
            ax.axhline(1.0, color="k", ls="--", lw=0.8, label="seed spread")
            ax.set(xlabel=p, ylabel="difference from the finest / seed spread", title=p)
            ax.legend(fontsize=7)
        fig.suptitle("particles: differences from the finest setting, in units of the seed spread")
        fig.tight_layout()
        paths += save_figure(fig, out / "convergence_particles")
    (out / "orders.md").write_text(order_tables(data))
    return [*paths, out / "orders.md"]
