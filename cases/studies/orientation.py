"""Orientational order of particle colonies against the continuum's flow (issue 31, part 2).

"The discrete simulations exhibit rich orientational structure" (the paper's last sentence).
This case grows ``seeds`` particle colonies per lam to a common radius (the runs of
cases.studies.ensemble: same parameters, same folder names, so a shared ``--runs`` folder reuses
them) and reduces the last frame of each with :mod:`cases.analysis.orientation`:

- per annulus (width WIDTH, of the nominal radius): the local order S_local (mean order of the
  grid cells, side CELL, Gaussian smoothing SMOOTH cells) against its isotropic floor; the
  radial alignment q_r = <cos 2 (theta - phi)> (+1 rods along the radius, -1 along circles);
  the mean angle between rod and radius (45 degrees for no preference);
- per colony: the +1/2 and -1/2 defects of the smoothed director per area (a +1 counts as two
  +1/2: the module doc of cases.analysis.orientation), and the same at every frame as the
  colony grows (``series.csv``);
- the flow: the radial solution's strain rate at the same radius (continuum.strain_rate:
  e_rr - e_tt = 8 lam c^2 r^2 / D^2, and relative to the expansion rate e_rr + e_tt = g), the
  rate at which it would turn a rod toward the radius.

Files in ``out/data``: ``annuli.csv`` (lam, seed, per annulus), ``seeds.csv`` (lam, seed,
per-colony scalars), ``series.csv`` (lam, seed, per frame), ``profile.csv`` (per lam and
annulus: seed mean, std and 95 % t-interval of S_local, q_r, mean_abs_angle; the flow's e_rr,
e_tt, e_rr - e_tt and the relative anisotropy), ``summary.csv`` (per lam), ``grid_lam=L.csv``
and ``defects_lam=L.csv`` (seed 0's last frame, for the field picture); ``out/vtu`` holds seed
0's grid and defects per lam for ParaView. ``plot`` draws ``orientation.png`` / ``.pdf`` and
``orientation_fields.png`` and writes ``results.md``.

Scales: "smoke" (radius 8, lam = 0 and 1e-2, 2 seeds: seconds), "medium" (radius 40, the paper's
lam 0, 1e-4, 1e-3, 1e-2, 4 seeds: about 40 min on one core), "paper" (the same with 8 seeds).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.analysis import orientation as O
from continuum import strain_rate

__all__ = ["SCALES", "CELL", "SMOOTH", "WIDTH", "run_params", "compute", "plot",
           "markdown_table", "flow_profile", "paper_colonies"]

#: Per scale: the ensemble scale of the runs (cases.studies.ensemble.ENSEMBLES: radius and
#: engine settings), the lams and the number of seeds (0, 1, ...).
SCALES = {
    "smoke": dict(ensemble="smoke", lams=(0.0, 1e-2), seeds=2),
    "medium": dict(ensemble="medium", lams=(0.0, 1e-4, 1e-3, 1e-2), seeds=4),
    "paper": dict(ensemble="medium", lams=(0.0, 1e-4, 1e-3, 1e-2), seeds=8),
}
#: Grid cell side, Gaussian smoothing (cells) and annulus width of the reduction.
CELL, SMOOTH, WIDTH = O.CELL, O.SMOOTH, O.WIDTH
#: Columns of annuli.csv reduced over the seeds in profile.csv.
PROFILE_QUANTITIES = ("S_local", "q_r", "mean_abs_angle")
#: Columns of seeds.csv reduced over the seeds in summary.csv.
SUMMARY_QUANTITIES = ("S_local", "S_local_iso", "q_r", "q_r_outer", "mean_abs_angle_outer",
                      "density_plus", "density_minus")


def _scale(scale: str) -> dict:
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {tuple(SCALES)}, got {scale!r}")
    return SCALES[scale]


def radius_of(scale: str) -> float:
    """The colonies' radius at ``scale`` (that of its ensemble)."""
    from cases.studies.ensemble import ENSEMBLES

    return float(ENSEMBLES[_scale(scale)["ensemble"]]["radius"])


def run_params(scale: str) -> list[tuple[float, int, dict]]:
    """(lam, seed, sweep parameters) of every particle colony, seed by seed."""
    from cases.studies.ensemble import particle_params

    cfg = _scale(scale)
    return [(float(lam), s, particle_params(lam, s, cfg["ensemble"]))
            for s in range(cfg["seeds"]) for lam in cfg["lams"]]


def flow_profile(r: np.ndarray, R: float, lam: float) -> dict[str, np.ndarray]:
    """The radial solution's e_rr, e_tt, e_rr - e_tt and (e_rr - e_tt) / (e_rr + e_tt) at r."""
    e = strain_rate.radial_strain_rate(np.minimum(r, R), R, lam)
    return e | {"relative_anisotropy": e["e_rr_minus_e_tt"] / (e["e_rr"] + e["e_tt"])}


def _append(cols: dict, row: dict) -> None:
    for k, v in row.items():
        cols.setdefault(k, []).extend(np.atleast_1d(v).tolist())


def _arrays(cols: dict) -> dict[str, np.ndarray]:
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def compute(scale: str = "smoke", out: str | Path = "runs/case-orientation-smoke",
            scheduler: str | None = None, n_workers: int = 2, runs: str | Path | None = None,
            engines: tuple[str, ...] = ("continuum", "particles"),
            finished_only: tuple[str, ...] = ()) -> Path:
    """Grow (or reuse) the colonies of ``scale`` and write the CSVs of the module doc.

    ``runs``: the particle runs' folder (default out/runs). Without "particles" in ``engines``
    only the flow (``profile.csv`` with the radial solution's columns) is written; with
    "particles" in ``finished_only`` no run is started and the finished ones are reduced.
    """
    from cases.sweep import is_done, run_engine, run_name, sweep

    cfg = _scale(scale)
    R = radius_of(scale)
    out = Path(out)
    data = out / "data"
    folder = Path(runs) if runs is not None else out / "runs"
    n_ann = max(1, round(R / WIDTH))
    r_mid = (np.arange(n_ann) + 0.5) * R / n_ann
    if "particles" not in engines:
        prof: dict[str, list] = {}
        for lam in cfg["lams"]:
            _append(prof, {"lam": np.full(n_ann, lam), "r": r_mid} | flow_profile(r_mid, R, lam))
        A.write_csv(data / "profile.csv", _arrays(prof))
        return data
    todo = run_params(scale)
    if "particles" in finished_only:
        todo = [t for t in todo if is_done(folder / run_name(t[2]))]
        if not todo:
            raise ValueError(f"no finished particle runs of scale {scale} in {folder}")
    folders = sweep(run_engine, [p for _, _, p in todo], folder, scheduler=scheduler,
                    n_workers=n_workers, progress=False)
    ann: dict[str, list] = {}
    seeds: dict[str, list] = {}
    series: dict[str, list] = {}
    for (lam, seed, _), run in zip(todo, folders, strict=True):
        ((t, last),) = A.particle_frames(run, last_only=True)
        res = O.frame_orientation(last, cell=CELL, smooth=SMOOTH, width=WIDTH)
        a = O.annulus_order(last["x"], last["y"], last["theta"], res["center"], R, width=WIDTH,
                            grid=res["grid"])
        _append(ann, {"lam": np.full(n_ann, lam), "seed": np.full(n_ann, seed)} | a)
        outer = a["r"] > R / 2
        w = a["count"][outer]
        row = {"lam": lam, "seed": seed, "t": t} | res["scalars"]
        row["mean_abs_angle_outer"] = float(np.sum(w * a["mean_abs_angle"][outer]) / w.sum())
        _append(seeds, row)
        s = O.orientation_series(run, cell=CELL, smooth=SMOOTH, width=WIDTH)
        n = s["t"].size
        _append(series, {"lam": np.full(n, lam), "seed": np.full(n, seed)} | s)
        if seed == 0:
            g = res["grid"]
            v = g["valid"]
            A.write_csv(data / f"grid_lam={lam:g}.csv",
                        {"x": g["xc"][v], "y": g["yc"][v], "count": g["count"][v],
                         "S": g["S"][v], "angle": g["angle"][v],
                         "angle_to_radial": g["angle_to_radial"][v]})
            d = res["defects"]
            A.write_csv(data / f"defects_lam={lam:g}.csv",
                        {"x": d["x"], "y": d["y"], "charge": d["charge"]})
            O.write_orientation_vtu(out / "vtu" / f"orientation_lam={lam:g}.vtu", g, d, t=t)
    ann_a, seeds_a = _arrays(ann), _arrays(seeds)
    A.write_csv(data / "annuli.csv", ann_a)
    A.write_csv(data / "seeds.csv", seeds_a)
    A.write_csv(data / "series.csv", _arrays(series))
    prof = {}
    summ: dict[str, list] = {}
    for lam in sorted(set(ann_a["lam"])):
        rows = {k: np.stack([ann_a[k][(ann_a["lam"] == lam) & (ann_a["seed"] == s)]
                             for s in sorted(set(ann_a["seed"][ann_a["lam"] == lam]))])
                for k in PROFILE_QUANTITIES}
        p = {"lam": np.full(n_ann, lam), "r": r_mid}
        for k in PROFILE_QUANTITIES:
            sp = A.seed_spread(rows[k])
            p |= {f"{k}_mean": sp["mean"], f"{k}_std": sp["std"], f"{k}_ci95": sp["ci95"]}
        _append(prof, p | flow_profile(r_mid, R, lam))
        sel = seeds_a["lam"] == lam
        srow = {"lam": lam, "seeds": int(sel.sum()), "radius": R}
        for k in SUMMARY_QUANTITIES:
            sp = A.seed_spread(seeds_a[k][sel])
            srow |= {f"{k}_mean": float(sp["mean"]), f"{k}_std": float(sp["std"])}
        fl = flow_profile(r_mid, R, lam)
        outer = r_mid > R / 2
        srow |= {"anisotropy_edge": float(flow_profile(np.array([R]), R, lam)
                                          ["e_rr_minus_e_tt"][0]),
                 "relative_anisotropy_outer": float(np.mean(fl["relative_anisotropy"][outer]))}
        _append(summ, srow)
    A.write_csv(data / "profile.csv", _arrays(prof))
    A.write_csv(data / "summary.csv", _arrays(summ))
    return data


def paper_colonies(folders: dict[int, str | Path], lam: float, data: str | Path) -> Path:
    """The same reductions of the radius-150 colonies of one lam (seed: run folder).

    Writes ``paper_seeds.csv`` (lam, seed, the last frame's scalars of
    :func:`cases.analysis.orientation.frame_orientation`, the mean angle to the radius beyond
    R/2 and the flow's relative anisotropy there) and ``paper_annuli.csv`` (lam, seed, per
    annulus of width WIDTH, with the flow's relative anisotropy at the annulus) into ``data``.
    These colonies are kept only on the machine that grew them (cases/data/ensemble_paper), so
    their numbers are committed rather than recomputed.
    """
    data = Path(data)
    seeds: dict[str, list] = {}
    ann: dict[str, list] = {}
    for seed, folder in sorted(folders.items()):
        ((t, last),) = A.particle_frames(folder, last_only=True)
        res = O.frame_orientation(last, cell=CELL, smooth=SMOOTH, width=WIDTH)
        R = res["scalars"]["radius"]
        a = res["annuli"]
        flow = flow_profile(a["r"], R, lam)["relative_anisotropy"]
        n = a["r"].size
        _append(ann, {"lam": np.full(n, lam), "seed": np.full(n, seed)}
                | {k: a[k] for k in ("r", "count", "S_local", "q_r", "mean_abs_angle")}
                | {"relative_anisotropy": flow})
        outer = a["r"] > R / 2
        w = a["count"][outer]
        _append(seeds, {"lam": lam, "seed": seed, "t": t} | res["scalars"]
                | {"mean_abs_angle_outer": float(np.sum(w * a["mean_abs_angle"][outer]) / w.sum()),
                   "relative_anisotropy_outer": float(np.sum(w * flow[outer]) / w.sum())})
    A.write_csv(data / "paper_seeds.csv", _arrays(seeds))
    A.write_csv(data / "paper_annuli.csv", _arrays(ann))
    return data


def markdown_table(data: str | Path) -> str:
    """summary.csv as a markdown table (the docs' table): seed mean ± std per lam."""
    s = A.read_csv(Path(data) / "summary.csv")

    def pm(k, i, f=".3f"):
        return f"{s[k + '_mean'][i]:{f}} ± {s[k + '_std'][i]:{f}}"

    rows = [(f"{lam:g}", int(s["seeds"][i]), pm("S_local", i), f"{s['S_local_iso_mean'][i]:.3f}",
             pm("q_r", i), pm("q_r_outer", i), pm("mean_abs_angle_outer", i, ".1f"),
             pm("density_plus", i, ".4f"), pm("density_minus", i, ".4f"),
             f"{s['anisotropy_edge'][i]:.3f}", f"{s['relative_anisotropy_outer'][i]:.3f}")
            for i, lam in enumerate(s["lam"])]
    head = ("lam", "seeds", "S_local", "isotropic floor", "q_r (all)", "q_r (r > R/2)",
            "angle to radius (r > R/2), deg", "+1/2 per area", "-1/2 per area",
            "flow e_rr - e_tt at R", "flow (e_rr - e_tt)/(e_rr + e_tt), r > R/2")
    return A.markdown_rows(head, rows) + "\n"


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """results.md, orientation.png / .pdf (profiles, flow, defects, growth) and the fields.

    orientation.png: (A) S_local(r), seed mean and std band per lam, dotted the isotropic floor;
    (B) radial alignment q_r(r); (C) mean angle between rod and radius; (D) the flow's relative
    anisotropy (e_rr - e_tt)/(e_rr + e_tt) of the radial solution; (E) defect densities per lam;
    (F) S_local and q_r of the growing colony (seed mean) against its radius.
    orientation_fields.png (when the grid files are there): seed 0's director per lam coloured
    by S, with its +1/2 (red) and -1/2 (blue) defects.
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    prof = A.read_csv(data / "profile.csv")
    lams = sorted(set(prof["lam"]))
    colors = {lam: plt.cm.viridis(i / max(1, len(lams) - 1) * 0.85) for i, lam in enumerate(lams)}
    has_particles = (data / "summary.csv").is_file()
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    (aS, aq, aa), (af, ad, at) = axes
    for lam in lams:
        sel = prof["lam"] == lam
        r, c, lab = prof["r"][sel], colors[lam], rf"$\lambda$ = {lam:g}"
        af.plot(r, prof["relative_anisotropy"][sel], color=c, label=lab)
        if not has_particles:
            continue
        for ax, k in ((aS, "S_local"), (aq, "q_r"), (aa, "mean_abs_angle")):
            m, sd = prof[f"{k}_mean"][sel], np.nan_to_num(prof[f"{k}_std"][sel])
            ax.plot(r, m, color=c, label=lab)
            ax.fill_between(r, m - sd, m + sd, color=c, alpha=0.2, lw=0)
    af.set(xlabel="r", ylabel=r"$(e_{rr} - e_{\theta\theta}) / (e_{rr} + e_{\theta\theta})$",
           title="(D) flow anisotropy, radial solution")
    af.legend(fontsize=7)
    if has_particles:
        ann = A.read_csv(data / "annuli.csv")
        r0 = prof["r"][prof["lam"] == lams[0]]
        iso = [np.nanmean(ann["S_local_iso"][ann["r"] == r]) for r in r0]
        aS.plot(r0, iso, "k:", lw=1, label="isotropic floor")
        aq.axhline(0, color="k", lw=0.5)
        aa.axhline(45, color="k", lw=0.5, ls=":")
        s = A.read_csv(data / "summary.csv")
        x = np.arange(len(s["lam"]))
        ad.errorbar(x - 0.05, s["density_plus_mean"], s["density_plus_std"], fmt="^", color="C3",
                    capsize=3, label="+1/2")
        ad.errorbar(x + 0.05, s["density_minus_mean"], s["density_minus_std"], fmt="v",
                    color="C0", capsize=3, label="-1/2")
        ad.set_xticks(x, [f"{lam:g}" for lam in s["lam"]])
        ser = A.read_csv(data / "series.csv")
        for lam in lams:
            sel = ser["lam"] == lam
            seeds = sorted(set(ser["seed"][sel]))
            n = min(int(np.sum(sel & (ser["seed"] == sd))) for sd in seeds)
            R = np.mean([ser["radius"][sel & (ser["seed"] == sd)][:n] for sd in seeds], axis=0)
            for k, ls in (("S_local", "-"), ("q_r_outer", "--")):
                v = np.mean([ser[k][sel & (ser["seed"] == sd)][:n] for sd in seeds], axis=0)
                at.plot(R, v, ls, color=colors[lam],
                        label=(rf"$\lambda$ = {lam:g}" if k == "S_local" else None))
        at.plot([], [], "k-", label=r"$S_{local}$")
        at.plot([], [], "k--", label=r"$q_r$, r > R/2")
    aS.set(xlabel="r", ylabel=r"$S_{local}$", title="(A) local nematic order (seed mean ± std)")
    aq.set(xlabel="r", ylabel=r"$q_r = \langle\cos 2(\theta - \phi)\rangle$",
           title="(B) radial alignment (+1 radial, -1 tangent)")
    aa.set(xlabel="r", ylabel="degrees", title="(C) mean angle rod - radius (45: none)")
    ad.set(xlabel=r"$\lambda$", ylabel="defects per unit area",
           title="(E) defects of the smoothed director")
    at.set(xlabel="colony radius R", ylabel="order", title="(F) as the colony grows (seed mean)")
    for ax in (aS, aq, ad, at):
        if ax.has_data():
            ax.legend(fontsize=7)
    fig.tight_layout()
    paths = save_figure(fig, out / "orientation")
    md = "" if not has_particles else markdown_table(data)
    (out / "results.md").write_text(md)
    grids = sorted(data.glob("grid_lam=*.csv"), key=lambda p: float(p.stem.split("=")[1]))
    if grids:
        paths += plot_fields(data, out, grids)
    return paths


def plot_fields(data: Path, out: Path, grids: list[Path]) -> list[Path]:
    """orientation_fields.png: seed 0's director per lam (segments coloured by S), its defects."""
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    from cases.figures.draw import save_figure

    fig, axes = plt.subplots(1, len(grids), figsize=(4 * len(grids), 4.2), squeeze=False)
    for ax, path in zip(axes[0], grids, strict=True):
        g = A.read_csv(path)
        d = A.read_csv(data / path.name.replace("grid_", "defects_"))
        cell = np.min(np.diff(np.unique(g["x"]))) if np.unique(g["x"]).size > 1 else 1.0
        h = 0.45 * cell * np.column_stack([np.cos(g["angle"]), np.sin(g["angle"])])
        seg = np.stack([np.column_stack([g["x"], g["y"]]) - h,
                        np.column_stack([g["x"], g["y"]]) + h], axis=1)
        lc = LineCollection(seg, array=g["S"], cmap="magma_r", linewidths=1.2)
        lc.set_clim(0, 1)
        ax.add_collection(lc)
        plus, minus = d["charge"] > 0, d["charge"] < 0
        ax.plot(d["x"][plus], d["y"][plus], "^", color="C3", ms=4, label="+1/2")
        ax.plot(d["x"][minus], d["y"][minus], "v", color="C0", ms=4, label="-1/2")
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_title(rf"$\lambda$ = {path.stem.split('=')[1]}, seed 0", fontsize=9)
        ax.legend(fontsize=6, loc="upper right")
    fig.colorbar(lc, ax=axes[0].tolist(), label="S (cell)", shrink=0.8)
    return save_figure(fig, out / "orientation_fields")
