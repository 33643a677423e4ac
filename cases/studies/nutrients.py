"""Colonies fed at their edge: nutrient against stress limitation in both models (issue 56).

``colony case nutrients [--scale smoke|medium|paper]``. At every (ell, lam) of the scale
(:data:`SCALES`) a continuum colony and particle colonies (seeds 0, 1, ...) grow to the radius
``radius`` with the nutrient fed at the colony's edge (c = 1 there; first-order uptake, K = inf:
f(c) = c; model.md, "Nutrient limitation"), through the sweep of every case (``cases.sweep``:
one run folder each under ``runs``, finished runs reused, Dask workers). Against the 1D radial
reference (:mod:`continuum.radial_nutrients`: exact for lam = 0, the Bessel solution), by the
same measures for every model:

- the front speed dR/dt at the radii :func:`radius_grid` (:func:`front_speed`: central
  differences of the first times the colony reaches R (1 -+ SPEED_WINDOW); R the radius by
  area, :func:`area_radius`, sqrt(A / pi) and for particles sqrt(b L / pi)) and the time to
  grow from ``start`` to each radius;
- at the final radius: the growth rate g = exp(-lam p) f(c) in equal-area annuli (the
  particles' c solved from the last frame by the engine's own :func:`particles.nutrients.
  nutrient_at_cells`, g_n = exp(-lam sigma_n) f(c_n)), the growth layer's width
  (:func:`layer_width`: the colony's outer band where g > 1/2, half the rate at the edge, where
  c = 1 and p = 0), the stress profile (particles: the mean axial stress sigma with its annulus
  spread; continuum: p) and the central stress (particles: the fit p0 - c r^2 over r < R/2,
  :func:`cases.analysis.profile_central_stress`; continuum: the largest nodal p), the
  roughness: the enclosing radius (the farthest cell or node from the centroid) over R, and
  the rings by the rule of both models (:mod:`cases.analysis.rings`: their number and the
  distance of the two outermost, the wavelength; particles: the final frame's mean-length
  profile; continuum: the contours G = k ln 2), beside ``wavelength_unfed``, the 1D
  reference's without the nutrient at the same radius; for the continuum ``core_drift``, how
  fast its rings deeper than CORE_DEPTH ell still move between the last two frames
  (:func:`core_drift`: 0 where the starved core has frozen its pattern).

Outputs in ``out/data``: ``speed.csv`` (model 0 continuum / 1 particles / 2 reference, ell,
lam, seed, R, dR/dt, time from ``start``), ``profiles.csv`` (model, ell, lam, seed, the final
radius by area, r, stress, stress_std, c, g, g_std; the reference on the annuli of the
continuum at its radius), ``summary.csv`` (per (ell, lam): each model's speed at the last grid
radius ``R_speed``, time from ``start`` to it, layer width, central stress, roughness, rings;
particles as seed mean and standard deviation) and from :func:`plot` ``nutrients.png`` and
``results.md``.

Scales: "smoke" (radius 8, ell 2 and 4, lam 0 and 0.1, one seed; about a minute on 2 cores),
"medium" (radius 40, ell 5, 10, 20, 40 at lam 0, 1e-3, 1e-2, one seed; about 20 minutes on
2 cores: the continuum runs take seconds, the particle runs one to two minutes each),
"paper" (radius 100, the medium grid, three seeds; hours).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from cases import analysis as A
from cases.sweep import ENGINES, is_done, run_engine, run_name, scale_config, sweep

__all__ = ["SCALES", "MODELS", "run_params", "radius_grid", "crossing_times", "front_speed",
           "layer_width", "particle_growth_profile", "continuum_growth_profile",
           "reference_profile", "compute", "reduce", "plot", "markdown_table"]

SCALES: dict[str, dict[str, Any]] = {
    "smoke": {"figure_scale": "smoke", "radius": 8.0, "start": 2.0, "ells": (2.0, 4.0),
              "lams": (0.0, 0.1), "seeds": 1, "frames": {"continuum": 1.0, "particles": 1.0}},
    "medium": {"figure_scale": "medium", "radius": 40.0, "start": 4.0,
               "ells": (5.0, 10.0, 20.0, 40.0), "lams": (0.0, 1e-3, 1e-2), "seeds": 1,
               "frames": {"continuum": 2.0, "particles": 2.0}},
    "paper": {"figure_scale": "paper", "radius": 100.0, "start": 4.0,
              "ells": (5.0, 10.0, 20.0, 40.0), "lams": (0.0, 1e-3, 1e-2), "seeds": 3,
              "frames": {"continuum": 2.0, "particles": 2.0}},
}
"""radius: the final radius; start: the radius from which times are counted; ells, lams: the
grid; seeds: particle colonies per (ell, lam); frames: each engine's output_every (the case reads
the last frame and the histories, which hold every step). The engines' other settings are the
figure scale's (cases.sweep.SCALES)."""

MODELS = ("continuum", "particles", "reference")
"""The ``model`` column of the CSVs: 0, 1, 2."""
SPEED_WINDOW = 0.05
"""Relative half-width in R of the central difference of :func:`front_speed`."""
GRID_POINTS = 12
"""Radii of :func:`radius_grid`."""
EDGE_WIDTH = 0.5
"""Width of the outermost annulus of the profiles (about a cell's diameter, as the figures)."""
FINALS = ("speed", "time", "layer", "central", "roughness", "rings", "wavelength")
"""Each run's final numbers in ``summary.csv`` (``Q_continuum``, ``Q_particles``)."""
CORE_DEPTH = 3.0
"""The starved core: deeper than this many ell below the edge (c < ~e^-3 of the edge's)."""
HALF = 0.5
"""The growth layer: where g exceeds this fraction of the rate at the edge (c = 1, p = 0)."""


def _scale(scale: str) -> dict[str, Any]:
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {tuple(SCALES)}, got {scale!r}")
    return SCALES[scale]


def run_params(engine: str, ell: float, lam: float, scale: str, seed: int = 0) -> dict[str, Any]:
    """Sweep parameters of one run: the figure scale's engine settings, the nutrient, the radius.

    The seed is left out for seed 0 (the engine's default), so that a run's name is the one
    ``colony ENGINE --nutrient-length ELL`` gives.
    """
    s = _scale(scale)
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    params = {"engine": engine, "lam": float(lam), **scale_config(s["figure_scale"])[engine],
              "radius": s["radius"], "nutrient_length": float(ell),
              "output_every": s["frames"][engine]}
    if seed:
        params["seed"] = int(seed)
    return params


def _runs(scale: str) -> dict[tuple[str, float, float, int], dict[str, Any]]:
    """{(engine, ell, lam, seed): params} of the scale: the continuum, then seed by seed."""
    s = _scale(scale)
    grid = [(ell, lam) for ell in s["ells"] for lam in s["lams"]]
    out = {("continuum", ell, lam, 0): run_params("continuum", ell, lam, scale)
           for ell, lam in grid}
    for seed in range(s["seeds"]):
        out |= {("particles", ell, lam, seed): run_params("particles", ell, lam, scale, seed)
                for ell, lam in grid}
    return out


def radius_grid(start: float, radius: float, n: int = GRID_POINTS) -> np.ndarray:
    """Radii of the speed measures: ``n``, geometric from ``start`` to radius / (1 + w).

    ``radius``: the smallest final radius (by area) of the runs compared, so that a central
    difference of :func:`front_speed` fits inside every run at each.
    """
    return np.geomspace(start, radius / (1.0 + SPEED_WINDOW), n)


def crossing_times(t: np.ndarray, R: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """The first time R(t) reaches each of ``radii`` (linear between the samples; nan if never).

    R may fluctuate (a particle colony's enclosing radius): the first crossing is taken.
    """
    t, R = np.asarray(t, float), np.asarray(R, float)
    out = np.full(len(radii), np.nan)
    for k, r in enumerate(np.asarray(radii, float)):
        i = int(np.argmax(R >= r))
        if R[i] < r:
            continue
        if i == 0:
            out[k] = t[0]
        else:
            out[k] = t[i - 1] + (t[i] - t[i - 1]) * (r - R[i - 1]) / (R[i] - R[i - 1])
    return out


def front_speed(t: np.ndarray, R: np.ndarray, radii: np.ndarray,
                window: float = SPEED_WINDOW) -> np.ndarray:
    """dR/dt at each of ``radii``: 2 w R_k / (t(R_k (1 + w)) - t(R_k (1 - w))).

    t(.) the first crossing times (:func:`crossing_times`); second order in w where R(t) is
    smooth: for R(t) = a t^2 the error is 0 for w -> 0 beyond w^2 terms.
    """
    radii = np.asarray(radii, float)
    hi = crossing_times(t, R, radii * (1.0 + window))
    lo = crossing_times(t, R, radii * (1.0 - window))
    return 2.0 * window * radii / (hi - lo)


def layer_width(r: np.ndarray, g: np.ndarray, radius: float, half: float = HALF) -> float:
    """Width R - r_h of the growth layer, r_h where g last rises through ``half`` toward the edge.

    ``g`` on increasing radii ``r`` (annulus means or a 1D solution; nan entries skipped); r_h
    by linear interpolation between the innermost point of the outer run of g > half and the
    point before it. 0 if g <= half at the outermost point; ``radius`` if g > half everywhere.
    """
    r, g = np.asarray(r, float), np.asarray(g, float)
    ok = np.isfinite(g)
    r, g = r[ok], g[ok]
    if g.size == 0:
        return math.nan
    if g[-1] <= half:
        return 0.0
    below = np.flatnonzero(g <= half)
    if below.size == 0:
        return float(radius)
    i = below[-1]
    r_h = r[i] + (r[i + 1] - r[i]) * (half - g[i]) / (g[i + 1] - g[i])
    return float(radius - r_h)


def particle_growth_profile(frame: dict[str, np.ndarray], config: dict[str, Any]
                            ) -> dict[str, np.ndarray]:
    """Annulus profile of one particle frame: stress, the nutrient c and the growth rate g.

    c at each cell from the frame's positions, lengths and stresses by the engine's own solver
    (:func:`particles.nutrients.nutrient_at_cells` on the run's grid), g_n = exp(-lam sigma_n)
    f(c_n); annuli of equal area about the centroid (outermost EDGE_WIDTH wide) with each
    column's spread (``_std``) and ``count``; ``enclosing`` the colony's enclosing radius
    (its ``radius`` is set by :func:`_run_measures`: :func:`area_radius`).
    """
    from particles import Config as ParticleConfig
    from particles.measures import centroid, enclosing_radius
    from particles.nutrients import nutrient_at_cells, uptake

    cfg = ParticleConfig(**{k: config[k] for k in ("lam", "nutrient_length", "monod_k",
                                                   "nutrient_grid") if k in config})
    ell, K, h = cfg.nutrient
    x, y, length, stress = frame["x"], frame["y"], frame["length"], frame["stress"]
    damping = np.exp(-cfg.lam * stress)
    c = nutrient_at_cells(x, y, length, damping, ell, K, h)
    g = damping * uptake(c, K)
    cx, cy = centroid(x, y, length)
    r = np.hypot(x - cx, y - cy)
    radius = enclosing_radius(x, y, frame["theta"], length)
    out: dict[str, np.ndarray] = {}
    for name, v in (("stress", stress), ("c", c), ("g", g), ("mean_length", length)):
        out["r"], out[name], out[f"{name}_std"], out["count"] = A.equal_area_annuli(
            r, v, radius=max(radius, r.max()), edge_width=EDGE_WIDTH)
    return out | {"enclosing": np.array([radius])}


def continuum_growth_profile(folder: Path, lam: float, K: float = math.inf
                             ) -> dict[str, np.ndarray]:
    """Annulus profile of a continuum run's last frame: p (as ``stress``), c and g.

    g = exp(-lam p) f(c) at the nodes; :func:`cases.analysis.field_profile` (outermost annulus
    EDGE_WIDTH wide); ``enclosing`` the largest distance of a node from the area centroid.
    """
    from continuum.growth import uptake
    from continuum.rings import area_centroid

    pts, tri, data = A.read_continuum_frame(A.continuum_frames(folder)[-1][1])
    p, c = data["p"], data["c"]
    g = np.exp(-lam * p) * uptake(c, K)
    prof = A.field_profile(pts, tri, {"stress": p, "c": c, "g": g}, edge_width=EDGE_WIDTH)
    centre = area_centroid(pts, tri)
    return prof | {"enclosing": np.array([np.hypot(*(pts - centre).T).max()])}


def reference_profile(r: np.ndarray, radius: float, lam: float, ell: float,
                      K: float = math.inf) -> dict[str, np.ndarray]:
    """The 1D radial reference at ``radius`` on the radii ``r``: p (as ``stress``), c, g.

    With its growth layer's width (``layer``) and central pressure p(0) (``p0``).
    """
    from continuum import radial_nutrients

    state = radial_nutrients.solve(radius, lam, ell, K, n=2001)
    g = state.growth(lam, K)
    return {"r": np.asarray(r, float), "stress": np.interp(r, state.r, state.p),
            "c": np.interp(r, state.r, state.c), "g": np.interp(r, state.r, g),
            "layer": np.array([layer_width(state.r, g, radius)]),
            "p0": np.array([state.p[0]])}


# --------------------------------------------------------------------------- compute, reduce


def compute(scale: str = "smoke", out: str | Path = "runs/case-nutrients-smoke",
            scheduler: str | None = None, n_workers: int = 2,
            runs: str | Path | None = None, engines: tuple[str, ...] = ENGINES,
            finished_only: tuple[str, ...] = ()) -> Path:
    """Run (or reuse) the case's runs under ``runs`` (default ``out/runs``); reduce to out/data.

    ``engines``: both (default) or the continuum alone; ``finished_only``: engines whose runs
    are only reused where finished (``--engines finished``).
    """
    bad = [e for e in (*engines, *finished_only) if e not in ENGINES]
    if bad or "continuum" not in engines:
        raise ValueError(f"engines must include the continuum and be among {ENGINES}, "
                         f"got {tuple(engines)!r}")
    root = Path(runs) if runs else Path(out) / "runs"
    wanted = {k: p for k, p in _runs(scale).items() if k[0] in engines}
    todo = [p for k, p in wanted.items() if k[0] not in finished_only]
    if todo:
        sweep(run_engine, todo, root, scheduler=scheduler, n_workers=n_workers)
    folders = {k: root / run_name(p) for k, p in wanted.items()
               if is_done(root / run_name(p), p)}
    return reduce(folders, Path(out) / "data", scale)


def _append(table: dict[str, list], row: dict[str, Any]) -> None:
    for k, v in row.items():
        table.setdefault(k, []).append(v)


def _append_profile(table: dict[str, list], keys: dict[str, float], prof: dict) -> None:
    for i in range(len(prof["r"])):
        _append(table, keys | {name: float(prof[name][i]) if name in prof else math.nan
                               for name in ("r", "stress", "stress_std", "c", "g", "g_std")})


def _run_measures(engine: str, folder: Path, hist: dict[str, np.ndarray], lam: float,
                  radii: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    """(front speed, time from radii[0], final profile, final numbers) of one run.

    ``hist``: the run's history.csv. Final numbers: central stress, rings, wavelength and, for
    the continuum, the core drift.
    """
    import json

    config = json.loads((folder / "config.json").read_text())
    R = area_radius(hist)
    t_cross = crossing_times(hist["t"], R, radii)
    u = front_speed(hist["t"], R, radii)
    finals: dict[str, float] = {}
    if engine == "continuum":
        prof = continuum_growth_profile(folder, lam)
        central = float(hist["max_pressure"][-1])
        rings = A.contour_rings(A.continuum_rings(folder), float(R[-1]))
        finals["core_drift"] = core_drift(folder, float(R[-1]), config["nutrient_length"])
    else:
        ((_, frame),) = A.particle_frames(folder, last_only=True)
        prof = particle_growth_profile(frame, config)
        central = A.profile_central_stress(prof, float(R[-1]))["central_fit"]
        rings = A.profile_rings(prof, float(prof["enclosing"][0]))
    finals |= {"central": central, "rings": rings.count, "wavelength": rings.outer_pair}
    return u, t_cross - t_cross[0], prof | {"radius": np.array([R[-1]])}, finals


def core_drift(folder: Path, radius: float, ell: float, depth: float = CORE_DEPTH) -> float:
    """How fast the continuum's rings still move in the starved core, at the end of the run.

    The largest |r_k(t1) - r_k(t0)| / (t1 - t0) over the rings G = k ln 2 of the last two
    frames (matched by k, mean radii) lying deeper than ``depth`` ell below the edge; nan
    without such a ring or with fewer than two frames. 0: the core's pattern is frozen.
    """
    frames = A.continuum_frames(folder)
    if len(frames) < 2:
        return math.nan
    (t0, f0), (t1, f1) = frames[-2:]
    a, b = A.frame_rings(f0), A.frame_rings(f1)
    before = dict(zip(a["k"].astype(int).tolist(), a["mean_radius"].tolist(), strict=True))
    moved = [abs(r - before[k]) / (t1 - t0)
             for k, r in zip(b["k"].astype(int).tolist(), b["mean_radius"].tolist(), strict=True)
             if k in before and r < radius - depth * ell]
    return max(moved) if moved else math.nan


def area_radius(history: dict[str, np.ndarray]) -> np.ndarray:
    """The colony's radius by its area: sqrt(A / pi); for particles sqrt(b L / pi).

    The continuum's history has it (``radius``; ``area``). A particle colony's cells of total
    length L = sum l_n cover the area b L at the continuum's packing b rho_l = 1, so both
    models start at R0 = sqrt(b / pi) (one cell of length 1) and grow by the same biomass:
    time origins and radii compare directly, and a ragged colony (nutrient-limited colonies
    roughen) is not measured by its farthest cell.
    """
    from particles import B

    if "total_length" in history:
        return np.sqrt(B * history["total_length"] / math.pi)
    return np.asarray(history["radius"], float)


def reduce(folders: dict[tuple[str, float, float, int], Path], data: Path,
           scale: str) -> Path:
    """Reduce the runs {(engine, ell, lam, seed): folder} to the CSVs of the module docstring.

    A (ell, lam) without its continuum run is left out; without particle runs its particle
    columns are nan (``seeds`` 0).
    """
    from continuum import radial_nutrients

    s = _scale(scale)
    data = Path(data)
    data.mkdir(parents=True, exist_ok=True)
    speed: dict[str, list] = {}
    profiles: dict[str, list] = {}
    summary: dict[str, list] = {}
    for ell in s["ells"]:
        for lam in s["lams"]:
            runs = {(e, seed): f for (e, el, lm, seed), f in folders.items()
                    if el == ell and lm == lam}
            if ("continuum", 0) not in runs:
                continue
            hists = {k: A.read_csv(f / "history.csv") for k, f in runs.items()}
            top = min(float(area_radius(h)[-1]) for h in hists.values())
            radii = radius_grid(s["start"], top)
            t_ref = radial_nutrients.time_to_radius(radii, lam, ell)
            series = [(2, 0, radial_nutrients.radius_rate(radii, lam, ell), t_ref - t_ref[0])]
            finals: dict[str, list[dict[str, float]]] = {"continuum": [], "particles": []}
            R = math.nan
            for engine, seed in sorted(runs):
                u, dt, prof, final = _run_measures(engine, runs[engine, seed],
                                                   hists[engine, seed], lam, radii)
                series.append((MODELS.index(engine), seed, u, dt))
                radius = float(prof["radius"][0])
                keys = {"model": MODELS.index(engine), "ell": ell, "lam": lam, "seed": seed,
                        "radius": radius}
                _append_profile(profiles, keys, prof)
                finals[engine].append({"speed": float(u[-1]), "time": float(dt[-1]),
                                       "layer": layer_width(prof["r"], prof["g"], radius),
                                       "roughness": float(prof["enclosing"][0]) / radius,
                                       **final})
                if engine == "continuum":
                    R = radius
                    ref = reference_profile(prof["r"], R, lam, ell)
                    _append_profile(profiles, keys | {"model": 2}, ref)
            for model, seed, u, dt in series:
                for k in range(len(radii)):
                    _append(speed, {"model": model, "ell": ell, "lam": lam, "seed": seed,
                                    "R": radii[k], "speed": u[k], "time": dt[k]})
            row: dict[str, Any] = {
                "ell": ell, "lam": lam, "radius": R, "R_speed": radii[-1],
                "speed_reference": float(series[0][2][-1]),
                "time_reference": float(series[0][3][-1]),
                "layer_reference": float(ref["layer"][0]),
                "central_reference": float(ref["p0"][0]),
                "wavelength_unfed": A.exact_ring_measure(lam, R).outer_pair}
            for engine, values in finals.items():
                for q in FINALS + (("core_drift",) if engine == "continuum" else ()):
                    v = np.array([x[q] for x in values], float)
                    row[f"{q}_{engine}"] = float(np.mean(v)) if v.size else math.nan
                    if engine == "particles":
                        row[f"{q}_particles_std"] = (float(np.std(v, ddof=1)) if v.size > 1
                                                     else math.nan)
            row["seeds"] = len(finals["particles"])
            _append(summary, row)
    if not summary:
        raise ValueError("no (ell, lam) of the case has a finished continuum run")
    for name, table in (("speed", speed), ("profiles", profiles), ("summary", summary)):
        A.write_csv(data / f"{name}.csv", {k: np.asarray(v, float) for k, v in table.items()})
    return data


# --------------------------------------------------------------------------- tables, figure


def _select(table: dict[str, np.ndarray], **keys: float) -> np.ndarray:
    sel = np.ones(len(table["model"]), bool)
    for k, v in keys.items():
        sel &= table[k] == v
    return sel


def markdown_table(summary: dict[str, np.ndarray]) -> str:
    """``summary.csv`` as the Markdown table of results.md (particles: seed mean +- std)."""

    def cell(name: str, i: int, fmt: str = ".3g") -> str:
        v = summary[name][i]
        sd = summary.get(f"{name}_std")
        if sd is not None and np.isfinite(sd[i]):
            return f"{v:{fmt}} +- {sd[i]:.2g}"
        return "-" if not np.isfinite(v) else f"{v:{fmt}}"

    lines = ["| ell | lam | R | dR/dt at R_s: reference | continuum | particles | time to R_s: "
             "reference | continuum | particles | growth layer: reference | continuum | "
             "particles | central stress: reference | continuum | particles (fit) | "
             "roughness: continuum | particles | rings: continuum | particles | wavelength: "
             "continuum | particles | unfed reference |",
             "|" + "---|" * 22]
    for i in range(len(summary["ell"])):
        cells = [f"{summary['ell'][i]:g}", f"{summary['lam'][i]:g}",
                 f"{summary['radius'][i]:.4g}"]
        for q in ("speed", "time", "layer", "central"):
            cells += [cell(f"{q}_{m}", i) for m in ("reference", "continuum", "particles")]
        cells += [cell(f"roughness_{m}", i) for m in ("continuum", "particles")]
        cells += [cell(f"rings_{m}", i) for m in ("continuum", "particles")]
        cells += [cell(f"wavelength_{m}", i) for m in ("continuum", "particles", "unfed")]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """nutrients.png / .pdf and results.md from the CSVs in ``data`` only.

    (A, B) front speed dR/dt against R at the smallest and the largest lam, one colour per
    ell: reference lines, continuum dashed, particles circles, with the asymptotes R/2 (no
    limitation) and ell (lam = 0, R >> ell) thin grey; (C) the speed at the last grid radius
    against ell and (D) the growth layer's width against ell, every lam, with ell ln 2 (the
    layer of the Bessel solution for R >> ell) dotted; (E) the stress and (F) the growth rate g
    at the final radius against R - r at the largest lam (particles: seed 0, annulus mean and
    spread band).
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import note_missing_engines, save_figure

    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    speed = A.read_csv(data / "speed.csv")
    prof = A.read_csv(data / "profiles.csv")
    summary = A.read_csv(data / "summary.csv")
    ells = np.unique(summary["ell"])
    lams = np.unique(summary["lam"])
    colors = {ell: plt.cm.viridis(i / max(1, len(ells))) for i, ell in enumerate(ells)}
    styles = {0: ("--", None), 1: ("none", "o"), 2: ("-", None)}
    fig, axes = plt.subplots(2, 3, figsize=(16, 9))
    for ax, letter, lam in zip(axes[0, :2], "AB", (lams[0], lams[-1]), strict=True):
        for ell in ells:
            for model, (ls, marker) in styles.items():
                sel = _select(speed, ell=ell, lam=lam, model=model) & (speed["seed"] == 0)
                if sel.any():
                    ax.plot(speed["R"][sel], speed["speed"][sel], ls=ls, marker=marker,
                            mfc="none", ms=4, color=colors[ell],
                            label=rf"$\ell$ = {ell:g}" if model == 2 else None)
            ax.axhline(ell, color="0.7", lw=0.6)
        R = np.unique(speed["R"])
        ax.plot(R, R / 2, color="0.5", lw=0.8, label="R/2 (no nutrient limitation)")
        ax.set(xscale="log", yscale="log", xlabel="R", ylabel="dR/dt",
               title=rf"({letter}) front speed, "
                     rf"$\lambda$ = {lam:g}: reference lines," "\ncontinuum dashed, "
                     "particles circles")
        ax.legend(fontsize=8)
    for ax, q, title in ((axes[0, 2], "speed", "(C) dR/dt at the last grid radius"),
                         (axes[1, 0], "layer", "(D) growth layer (g > 1/2): width")):
        for j, lam in enumerate(lams):
            sel = summary["lam"] == lam
            c = f"C{j}"
            ax.plot(summary["ell"][sel], summary[f"{q}_reference"][sel], "-", color=c,
                    label=rf"$\lambda$ = {lam:g}")
            ax.plot(summary["ell"][sel], summary[f"{q}_continuum"][sel], "s", mfc="none",
                    color=c)
            ax.errorbar(summary["ell"][sel], summary[f"{q}_particles"][sel],
                        yerr=np.nan_to_num(summary[f"{q}_particles_std"][sel]), fmt="o",
                        mfc="none", color=c, capsize=3)
        if q == "layer":
            ax.plot(ells, ells * math.log(2), "k:", lw=0.8, label=r"$\ell \ln 2$")
        else:
            ax.plot(ells, ells, "k:", lw=0.8, label=r"$\ell$")
        ax.set(xscale="log", yscale="log", xlabel=r"$\ell$",
               title=title + "\nreference lines, continuum squares, particles circles")
        ax.legend(fontsize=8)
    lam = lams[-1]
    for ax, letter, q, label in ((axes[1, 1], "E", "stress", "stress (particles) / p"),
                                 (axes[1, 2], "F", "g", "growth rate g")):
        for ell in ells:
            for model, (ls, marker) in styles.items():
                sel = _select(prof, ell=ell, lam=lam, model=model) & (prof["seed"] == 0)
                if not sel.any():
                    continue
                depth = prof["radius"][sel] - prof["r"][sel]
                ax.plot(depth, prof[q][sel], ls=ls, marker=marker, mfc="none", ms=3,
                        color=colors[ell], label=rf"$\ell$ = {ell:g}" if model == 2 else None)
                if model == 1 and f"{q}_std" in prof:
                    sd = prof[f"{q}_std"][sel]
                    ax.fill_between(depth, prof[q][sel] - sd, prof[q][sel] + sd,
                                    color=colors[ell], alpha=0.15, lw=0)
        ax.set(xlabel="depth R - r", ylabel=label,
               title=rf"({letter}) {label} at the final radius, $\lambda$ = {lam:g}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    note_missing_engines(fig, {MODELS[m] for m in (0, 1) if (speed["model"] == m).any()})
    (out / "results.md").write_text(
        "# colony case nutrients\n\nR_s: the last radius of the speed grid; particles: mean "
        "+- standard deviation over the seeds.\n\n" + markdown_table(summary))
    return save_figure(fig, out / "nutrients")
