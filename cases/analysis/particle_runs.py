"""Reductions of a particle run folder (its trajectory frames) for the figure cases.

Every frame carries x, y, theta and length, so the colony radius is the engine's own
(:func:`particles.enclosing_radius`: the smallest disc about the area-weighted centroid holding
every particle) and profiles are taken about that centroid (:mod:`particles.measures`).

- :func:`particle_wavelength_series`: the ring wavelength at every frame;
- :func:`final_particle_profile`: the final radial profile, pooled over the last frames;
- :func:`final_ring_coherence`: whether the final colony has rings;
- :func:`particle_growth_series`: central stress, rings and wavelength at every frame (how the
  colony compares with the continuum as it grows).
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import numpy as np

from particles.measures import centroid, enclosing_radius

from .io import particle_frames, read_csv
from .profiles import equal_area_annuli, particle_profile
from .rings import Rings, count_rings, profile_rings, ring_coherence, ring_series
from .statistics import central_value, max_value

__all__ = [
    "particle_wavelength_series",
    "final_particle_profile",
    "final_ring_coherence",
    "particle_growth_series",
    "profile_central_stress",
    "history_segments",
    "progress_lines",
    "progress_wall",
]


def _radius(frame: dict[str, np.ndarray]) -> float:
    """Colony radius of a trajectory frame: :func:`particles.enclosing_radius`."""
    return enclosing_radius(frame["x"], frame["y"], frame["theta"], frame["length"])


def particle_wavelength_series(folder: str | os.PathLike, edge_width: float = 0.5,
                               **kwargs) -> dict[str, np.ndarray]:
    """Rings and both wavelengths at every trajectory frame of a particle run.

    :func:`particle_profile` of the frame (annuli at most `edge_width` wide at the edge) and its
    rings by the rule of both models (:func:`profile_rings` at the frame's radius
    :func:`particles.enclosing_radius`, `kwargs` passed on). Columns of :func:`ring_series`.
    """
    rows = []
    for t, fr in particle_frames(folder):
        R = _radius(fr)
        rows.append((t, R, _frame_rings(fr, R, edge_width, **kwargs)))
    return ring_series(rows)


def _frame_profile(frame: dict[str, np.ndarray], radius: float,
                   edge_width: float) -> dict[str, np.ndarray]:
    return particle_profile(frame["x"], frame["y"], frame["theta"], frame["length"],
                            frame["stress"], edge_width=edge_width, radius=radius)


def _frame_rings(frame: dict[str, np.ndarray], radius: float, edge_width: float,
                 **kwargs) -> Rings:
    """:func:`profile_rings` of one frame's profile (none for fewer than three particles)."""
    if frame["x"].size < 3:
        return count_rings(np.empty(0), radius)
    return profile_rings(_frame_profile(frame, radius, edge_width), radius, **kwargs)


def final_particle_profile(folder: str | os.PathLike, growth_window: float = 1.0,
                           edge_width: float = 0.5) -> dict[str, np.ndarray]:
    """Radial profile (mean_length, stress) of a particle run, pooled over its last frames.

    To reduce noise (paper, Fig 3A) the particles of every frame whose colony radius
    (:func:`particles.enclosing_radius`) is within `growth_window` of the final radius R_f (the
    colony grew by less than that) are pooled, each frame about its own centroid, and binned in
    equal-area annuli of the final disc; with `growth_window` = 0 only the final frame is used.
    The pooled frames are correlated, so `count` overstates the number of independent samples.
    """
    if growth_window < 0:
        raise ValueError(f"growth_window must be >= 0, got {growth_window}")
    radii = [_radius(fr) for _, fr in particle_frames(folder)]
    if not radii:
        raise ValueError(f"no frames in {folder}")
    R_f = radii[-1]
    keep = {i for i, R in enumerate(radii) if R >= R_f - growth_window} | {len(radii) - 1}
    r, length, stress = [], [], []
    for i, (_, fr) in enumerate(particle_frames(folder)):
        if i in keep:
            cx, cy = centroid(fr["x"], fr["y"], fr["length"])
            r.append(np.hypot(fr["x"] - cx, fr["y"] - cy))
            length.append(fr["length"])
            stress.append(fr["stress"])
    r, length, stress = (np.concatenate(a) for a in (r, length, stress))
    out: dict[str, np.ndarray] = {}
    for name, v in (("mean_length", length), ("stress", stress)):
        r_mid, mean, std, count = equal_area_annuli(r, v, radius=max(R_f, r.max()),
                                                    edge_width=edge_width)
        out["r"], out[name], out[f"{name}_std"], out["count"] = r_mid, mean, std, count
    out["count"] = out.pop("count")
    return out


def final_ring_coherence(folder: str | os.PathLike, width: float = 1.0) -> tuple[float, float]:
    """:func:`ring_coherence` (C, z) of the lengths in the last frame of a particle run.

    (nan, nan) for a colony too small for five annuli of ``width`` over its outer half.
    """
    ((_, last),) = particle_frames(folder, last_only=True)
    r = np.hypot(last["x"] - last["x"].mean(), last["y"] - last["y"].mean())
    if r.size == 0 or 0.5 * r.max() < 5 * width:
        return math.nan, math.nan
    return ring_coherence(last["x"], last["y"], last["length"], width=width)



def profile_central_stress(profile: dict[str, np.ndarray], radius: float) -> dict[str, float]:
    """Central stress of a particle profile by both estimators.

    ``central_max``: the largest annulus mean (:func:`max_value`, the figures' "max stress",
    biased upwards by the annuli's noise); ``central_fit``, ``central_fit_se``: p0 of the fit
    p0 - c r^2 over the central region (:func:`central_value`, annuli weighted by their counts;
    nan with fewer than two annuli there).
    """
    try:
        p0, se, _ = central_value(profile["r"], profile["stress"], radius, profile["count"])
    except ValueError:  # fewer than two annuli in the central region (a small colony)
        p0, se = math.nan, math.nan
    return {"central_max": max_value(profile["stress"]), "central_fit": p0,
            "central_fit_se": se}


def particle_growth_series(folder: str | os.PathLike, edge_width: float = 0.5,
                           min_radius: float = 10.0) -> dict[str, np.ndarray]:
    """Central stress, rings and wavelength of every trajectory frame with radius >= min_radius.

    Each frame's :func:`particle_profile` (annuli at most ``edge_width`` wide at the edge);
    :func:`profile_central_stress` of it; its rings by the rule of both models
    (:func:`profile_rings`): the outermost ring's radius ``outer_ring`` (nan without one) and
    the ``wavelength`` (the two outermost rings' distance, nan with fewer). Columns t, radius,
    n_particles, central_max, central_fit, central_fit_se, outer_ring, wavelength.
    """
    names = ("t", "radius", "n_particles", "central_max", "central_fit", "central_fit_se",
             "outer_ring", "wavelength")
    out: dict[str, list] = {k: [] for k in names}
    for t, fr in particle_frames(folder):
        R = _radius(fr)
        if R < min_radius:
            continue
        prof = _frame_profile(fr, R, edge_width)
        row = {"t": t, "radius": R, "n_particles": fr["x"].size}
        row |= profile_central_stress(prof, R)
        rings = profile_rings(prof, R)
        row["outer_ring"] = float(rings.radii[-1]) if rings.count else math.nan
        row["wavelength"] = rings.outer_pair
        for k in names:
            out[k].append(row[k])
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def progress_lines(log: str | Path) -> dict[str, np.ndarray]:
    """Columns radius, particles, step, wall of the progress lines of a ``colony particles`` log.

    The lines written once a minute when stderr is not a terminal, ``colony: radius R of ...,
    t = T, N particles, step S, dt D, W s`` (W: seconds since the command started; the bar's
    carriage returns count as line ends). A log of a stopped and resumed run (the commands'
    stderr one after the other) counts on: where W starts again from a smaller value, the later
    lines are shifted by the last W before (the seconds between that line and the stop are not
    counted).
    """
    found = re.findall(r"radius (\S+) of \S+, t = \S+, (\d+) particles, step (\d+), "
                       r"dt \S+, (\d+) s\s*$",
                       Path(log).read_text().replace("\r", "\n"), flags=re.MULTILINE)
    wall, offset, last = [], 0.0, 0.0
    for *_, b in found:
        w = float(b)
        if w < last:  # a resumed command's clock
            offset += last
        last = w
        wall.append(offset + w)
    return {"radius": np.array([float(r) for r, *_ in found]),
            "particles": np.array([int(n) for _, n, *_ in found]),
            "step": np.array([int(s) for _, _, s, _ in found]), "wall": np.array(wall)}


def progress_wall(log: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(step, wall seconds) of :func:`progress_lines`, after (0, 0): the start, before step 1."""
    lines = progress_lines(log)
    return (np.concatenate([[0.0], lines["step"]]),
            np.concatenate([[0.0], lines["wall"]]))


def history_segments(run: str | Path, min_particles: float = 0.0,
                     max_particles: float = math.inf,
                     wall: tuple[np.ndarray, np.ndarray] | None = None) -> list[dict]:
    """Per step-policy segment of the run folder ``run``, its solver work.

    The segments are those of config.json's ``step_policy_changes`` (a run resumed with another
    step), restricted to ``min_particles`` <= N < ``max_particles``.

    These are: first and last step, N range, t range, dt range, steps, halved steps, iterations
    per unit time (main, passes and failed attempts; failed counted 0 where the history predates
    the column), the failed share and the largest overlap after a step.  With ``wall``, the
    (step, seconds) of the run's progress lines (:func:`progress_wall`), also the wall seconds
    of the segment up to the last progress line (interpolated linearly in the step between the
    lines: the last steps of a run, after its last line, are left out; nan for a segment that
    begins after it) and its wall milliseconds per iteration over the same steps.
    """
    run = Path(run)
    h = read_csv(run / "history.csv")
    changes = json.loads((run / "config.json").read_text()).get("step_policy_changes", [])
    bounds = [0, *(c["step"] for c in changes), math.inf]
    failed = np.nan_to_num(h["failed_iterations"])
    rows = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        m = ((h["step"] > a) & (h["step"] <= b) & (h["n_particles"] >= min_particles)
             & (h["n_particles"] < max_particles))
        if not m.any():
            continue
        work = h["iterations"][m] + failed[m]
        rows.append({"run": run.name, "first_step": int(h["step"][m][0]),
                     "last_step": int(h["step"][m][-1]),
                     "n_first": int(h["n_particles"][m][0]),
                     "n_last": int(h["n_particles"][m][-1]),
                     "t_first": float(h["t"][m][0]), "t_last": float(h["t"][m][-1]),
                     "dt_min": float(h["dt"][m].min()), "dt_max": float(h["dt"][m].max()),
                     "steps": int(m.sum()), "halved": int((h["substeps"][m] > 1).sum()),
                     "per_time": float(work.sum() / h["dt"][m].sum()),
                     "failed_share": float(failed[m].sum() / work.sum()),
                     "max_overlap": float(h["max_overlap"][m].max())})
        if wall is not None:
            steps, seconds = wall
            logged = h["step"][m] <= steps[-1]
            seconds_ = math.nan
            if logged.any():
                ends = np.interp([h["step"][m][0] - 1, h["step"][m][logged][-1]], steps, seconds)
                seconds_ = float(ends[1] - ends[0])
            rows[-1]["wall_s"] = seconds_
            its = float(work[logged].sum())
            rows[-1]["ms_per_iteration"] = 1e3 * seconds_ / its if its > 0 else math.nan
    return rows
