"""Discrete-continuum cross-check: the results table of the README, with numbers.

For every lam of the scale (Fig 2-4 values and the scaling values, lam = 0 included):

- R(t): largest relative difference ``|R_p - R_c| / R_c`` of the particle radius (interpolated at
  the continuum's output times) over the common time range and over the part where
  R_c >= R_f / 2, for both particle radii of the history (the smallest centroid disc holding
  every particle, and sqrt(hull area / pi), closer to the continuum's sqrt(area / pi) while the
  young colony is elongated), and the times t_f at which each model reaches the final radius;
- final dR/dt (linear fit of the last 20 % of the run) of both models against the asymptote
  sqrt(2/lam) and the exact disc speed 4 c R at the final radius;
- maximum stress: particles (max of the radially averaged stress, pooled over the last unit of
  growth), continuum (max p), analytic p(0) of the disc of the final radius;
- final ring wavelength of both models and of the 1D radial reference (continuum and reference:
  the difference of the two outermost rings G = k ln 2, the contours of the growth phase,
  cases.analysis.continuum_wavelength, and continuum.radial.ring_radii at the continuum's final
  radius, cases.analysis.exact_wavelength; particles: the two outermost significant peaks of the
  radial mean-length profile), each by the rule of both models (cases.analysis.count_rings:
  nan unless two rings stand inside the colony, outside the edge layer), and the azimuthal
  coherence C of the particles' final length pattern with its significance z
  (:func:`cases.analysis.ring_coherence`, information);

and the power-law exponents fitted against lam (lam > 0, finite values) of the wavelengths and
maximum stresses with their 95 % intervals, beside the paper's statements, over measured values
only. Nothing is tuned: every
number is a measurement of the runs.

``compute`` writes ``table.csv``, ``exponents.csv`` and ``radius_diff_lam=*.csv`` to
``out/data``; ``plot`` writes ``results.md`` (the table) and ``crosscheck.png/pdf`` (relative
R(t) difference for both particle radii: against t over the whole run, and against the continuum
radius over the table's late window R_c >= R_f/2) from those CSVs only. Scales as in
cases.sweep.SCALES (smoke: about a minute on 2 cores; paper: hours).

Engines and committed data as for every figure case (``cases.sweep.case_runs``, docs/DESIGN.md):
``engines=("continuum",)`` draws the continuum alone, ``--engines finished`` reuses finished
particle runs only; data in cases/data/crosscheck (radius 40) and crosscheck_paper (radius 150).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.sweep import ENGINES, compute_case, engine_pairs, scale_config
from continuum import radial

__all__ = ["compute", "reduce", "plot", "runs_needed", "radius_difference", "markdown_table"]

LATE_FRACTION = 0.2

#: exponent row name -> (table column, the paper's statement)
EXPONENTS = {
    "wavelength_particles": ("wavelength_particles", "wavelength ~ lam^(-1/2)"),
    "wavelength_continuum": ("wavelength_continuum", "wavelength ~ lam^(-1/2)"),
    "wavelength_exact": ("wavelength_exact", "wavelength ~ lam^(-1/2)"),
    "max_stress_particles": ("max_stress_particles", "follows the analytic p(0)"),
    "max_pressure_continuum": ("max_pressure_continuum", "follows the analytic p(0)"),
    "p0_exact": ("p0_exact", "analytic p(0) = (2/lam) ln(1/(8c))"),
}


def runs_needed(scale: str, engines: tuple[str, ...] = ENGINES
                ) -> tuple[list[float], list[tuple[str, float]]]:
    """(lam values, (engine, lam) runs) at ``scale``."""
    cfg = scale_config(scale)
    lams = sorted({0.0, *cfg["lams"], *cfg["scaling_lams"]})
    return lams, engine_pairs(lams, engines)


def radius_difference(t_c: np.ndarray, R_c: np.ndarray, t_p: np.ndarray, R_p: np.ndarray
                      ) -> dict[str, np.ndarray]:
    """Relative difference (R_p - R_c) / R_c at the continuum times within both time ranges.

    R_p is interpolated linearly in t (its history has one row per step, much finer than the
    continuum's output).
    """
    t_c, R_c, t_p, R_p = (np.asarray(a, dtype=float) for a in (t_c, R_c, t_p, R_p))
    keep = (t_c >= t_p.min()) & (t_c <= t_p.max())
    t = t_c[keep]
    Rp = np.interp(t, t_p, R_p)
    return {"t": t, "radius_continuum": R_c[keep], "radius_particles": Rp,
            "rel_diff": (Rp - R_c[keep]) / R_c[keep]}


def compute(scale: str = "smoke", out: str | Path | None = None, **options) -> Path:
    """Run (or reuse) the cross-check's engine runs and reduce them to ``out/data``.

    :func:`cases.sweep.compute_case` with ``options`` as there.
    """
    return compute_case("crosscheck", runs_needed, reduce, scale, out, **options)


def reduce(folders: dict[tuple[str, float], Path], data: Path) -> Path:
    """Measure every row of the table from the run folders {(engine, lam): folder}.

    The continuum runs are required; a lam without its particle run gets nan (printed "-") in
    the particle and comparison columns.
    """
    data = Path(data)
    lams = sorted({lam for _, lam in folders})
    table: dict[str, list] = {k: [] for k in COLUMNS}
    for lam in lams:
        row = _continuum_row(folders["continuum", lam], lam)
        fp = folders.get(("particles", lam))
        row |= (_particle_row(fp, folders["continuum", lam], lam, data) if fp is not None
                else dict.fromkeys(PARTICLE_COLUMNS, math.nan))
        for k in COLUMNS:
            table[k].append(row[k])
    A.write_csv(data / "table.csv", table)
    A.write_csv(data / "exponents.csv", exponents(table))
    return data


PARTICLE_COLUMNS = ("t_final_particles", "max_rel_diff_R", "max_rel_diff_R_late",
                    "max_rel_diff_R_hull", "max_rel_diff_R_hull_late", "slope_particles",
                    "max_stress_particles", "wavelength_particles", "ring_coherence_particles",
                    "ring_z_particles")
COLUMNS = ("lam", "radius_final", "t_final_continuum", "t_final_particles", "max_rel_diff_R",
           "max_rel_diff_R_late", "max_rel_diff_R_hull", "max_rel_diff_R_hull_late",
           "slope_particles", "slope_continuum", "slope_exact",
           "slope_asymptotic", "max_stress_particles", "max_pressure_continuum", "p0_exact",
           "wavelength_particles", "wavelength_continuum", "wavelength_exact",
           "ring_coherence_particles", "ring_z_particles")


def _continuum_row(fc: Path, lam: float) -> dict[str, float]:
    """The continuum's and the exact references' columns of the table."""
    hc = A.read_csv(fc / "history.csv")
    R_f = float(hc["radius"][-1])
    return {
        "lam": lam,
        "radius_final": R_f,
        "t_final_continuum": float(hc["t"][-1]),
        "slope_continuum": A.late_slope(hc["t"], hc["radius"], LATE_FRACTION),
        "slope_exact": radial.radius_rate(R_f, lam),
        "slope_asymptotic": math.sqrt(2.0 / lam) if lam > 0 else math.nan,
        "max_pressure_continuum": float(hc["max_pressure"][-1]),
        "p0_exact": radial.max_pressure(R_f, lam),
        "wavelength_continuum": A.continuum_wavelength(fc).outer_pair,
        "wavelength_exact": A.exact_wavelength(lam, R_f),
    }


def _particle_row(fp: Path, fc: Path, lam: float, data: Path) -> dict[str, float]:
    """The particle columns, R(t) against the continuum's (also written to radius_diff_*.csv)."""
    hc, hp = A.read_csv(fc / "history.csv"), A.read_csv(fp / "history.csv")
    diff = radius_difference(hc["t"], hc["radius"], hp["t"], hp["radius"])
    hull = radius_difference(hc["t"], hc["radius"], hp["t"], hp["hull_radius"])
    A.write_csv(data / f"radius_diff_lam={lam:g}.csv",
                A.thin_rows({**diff, "rel_diff_hull": hull["rel_diff"]}))
    late = diff["radius_continuum"] >= 0.5 * float(hc["radius"][-1])
    pp = A.final_particle_profile(fp, growth_window=1.0)
    coherence, z = A.final_ring_coherence(fp)
    return {
        "t_final_particles": float(hp["t"][-1]),
        "max_rel_diff_R": float(np.max(np.abs(diff["rel_diff"]))),
        "max_rel_diff_R_late": float(np.max(np.abs(diff["rel_diff"][late]))),
        "max_rel_diff_R_hull": float(np.max(np.abs(hull["rel_diff"]))),
        "max_rel_diff_R_hull_late": float(np.max(np.abs(hull["rel_diff"][late]))),
        "slope_particles": A.late_slope(hp["t"], hp["radius"], LATE_FRACTION),
        "max_stress_particles": A.max_value(pp["stress"]),
        "wavelength_particles": A.profile_rings(
            A.final_particle_profile(fp, growth_window=0.0), float(hp["radius"][-1])).outer_pair,
        "ring_coherence_particles": coherence,
        "ring_z_particles": z,
    }


def exponents(table: dict[str, list]) -> dict[str, np.ndarray]:
    """Fitted exponent a of y = C lam^a (lam > 0, finite y) per EXPONENTS row.

    nan if fewer than 2 points. The wavelengths are measured only where two rings count
    (cases.analysis.count_rings), so every fit is over measured wavelengths only.

    Columns: row (index into EXPONENTS), exponent, its 95 % interval lo and hi (from the
    scatter, cases.analysis.power_law_interval; nan with two points), prefactor, n_points.
    """
    lam = np.asarray(table["lam"], dtype=float)
    out = {"row": [], "exponent": [], "lo": [], "hi": [], "prefactor": [], "n_points": []}
    for i, (_, (col, _)) in enumerate(EXPONENTS.items()):
        y = np.asarray(table[col], dtype=float)
        ok = (lam > 0) & np.isfinite(y) & (y > 0)
        try:
            a, lo, hi, C = A.power_law_interval(lam[ok], y[ok])
        except ValueError:
            a, lo, hi, C = (math.nan,) * 4
        for k, v in zip(out, (i, a, lo, hi, C, int(ok.sum())), strict=True):
            out[k].append(v)
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def _f(x: float, digits: int = 3) -> str:
    return "-" if not math.isfinite(x) else f"{x:.{digits}g}"


def markdown_table(data: str | Path) -> str:
    """The results table (markdown) from ``table.csv`` and ``exponents.csv`` in ``data``."""
    data = Path(data)
    t = A.read_csv(data / "table.csv")
    e = A.read_csv(data / "exponents.csv")
    lines = [
        "| lam | R_f | t_f cont. / part. | max rel. diff R(t): disc (all / R > R_f/2), "
        "hull (all / R > R_f/2) "
        "| dR/dt part. / cont. / disc 4cR / sqrt(2/lam) | max stress part. / cont. / p(0) "
        "| wavelength part. (ring z) / cont. / 1D ref. |",
        "|---|---|---|---|---|---|---|",
    ]
    for i in range(len(t["lam"])):
        g = {k: float(v[i]) for k, v in t.items()}
        lines.append(
            f"| {g['lam']:g} | {_f(g['radius_final'])} "
            f"| {_f(g['t_final_continuum'])} / {_f(g['t_final_particles'])} "
            f"| {_f(100 * g['max_rel_diff_R'], 2)} % / {_f(100 * g['max_rel_diff_R_late'], 2)} %, "
            f"{_f(100 * g['max_rel_diff_R_hull'], 2)} % / "
            f"{_f(100 * g['max_rel_diff_R_hull_late'], 2)} % "
            f"| {_f(g['slope_particles'])} / {_f(g['slope_continuum'])} / {_f(g['slope_exact'])}"
            f" / {_f(g['slope_asymptotic'])} "
            f"| {_f(g['max_stress_particles'])} / {_f(g['max_pressure_continuum'])}"
            f" / {_f(g['p0_exact'])} "
            f"| {_f(g['wavelength_particles'])} (z {_f(g.get('ring_z_particles', math.nan), 2)})"
            f" / {_f(g['wavelength_continuum'])}"
            f" / {_f(g['wavelength_exact'])} |")
    lines += ["", "| fitted against lam (measured values only) | exponent [95 % interval] "
              "| points | paper |", "|---|---|---|---|"]
    names = list(EXPONENTS)
    for i in range(len(e["row"])):
        name = names[int(e["row"][i])]
        interval = (f" [{_f(float(e['lo'][i]))}, {_f(float(e['hi'][i]))}]"
                    if "lo" in e and math.isfinite(float(e["lo"][i])) else "")
        lines.append(f"| {name} | {_f(float(e['exponent'][i]))}{interval} "
                     f"| {int(e['n_points'][i])} | {EXPONENTS[name][1]} |")
    lines.append("")
    lines.append("Paper: wavelength about 5 at lam = 1e-2; late growth linear, "
                 "dR/dt -> sqrt(2/lam).")
    return "\n".join(lines) + "\n"


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Write ``results.md`` and the R(t) difference figure (PNG, PDF) from the CSVs in ``data``."""
    import matplotlib.pyplot as plt

    from cases.figures.draw import note_missing_engines, save_figure

    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    md = out / "results.md"
    md.write_text(markdown_table(data))
    fig, (ax, late) = plt.subplots(1, 2, figsize=(11, 4))
    files = sorted(data.glob("radius_diff_lam=*.csv"), key=lambda p: float(p.stem.split("=")[1]))
    table = A.read_csv(data / "table.csv") if files else {}
    for i, p in enumerate(files):
        d = A.read_csv(p)
        c = plt.cm.plasma(i / max(1, len(files)))
        lam = float(p.stem.split("=")[1])
        R_f = table["radius_final"][np.isclose(table["lam"], lam)][0]
        window = d["radius_continuum"] >= 0.5 * R_f
        for y, style in ((d["rel_diff"], "-"), (d.get("rel_diff_hull"), "--")):
            if y is None:
                continue
            label = rf"$\lambda$ = {lam:g}" if style == "-" else None
            ax.plot(d["t"], 100 * y, style, color=c, label=label)
            late.plot(d["radius_continuum"][window], 100 * y[window], style, color=c)
    for a in (ax, late):
        a.axhline(0, color="k", lw=0.5)
    ax.set(xlabel="t", ylabel=r"$(R_p - R_c)/R_c$ [%]",
           title="(A) all times: disc (solid), sqrt(hull area/pi) (dashed)")
    late.set(xlabel=r"continuum radius $R_c$", ylabel=r"$(R_p - R_c)/R_c$ [%]",
             title=r"(B) late: $R_c \geq R_f/2$ (the table's window)")
    if files:
        ax.legend(fontsize=8)
    note_missing_engines(fig, {"continuum", *(["particles"] if files else [])})
    return [md, *save_figure(fig, out / "crosscheck")]
