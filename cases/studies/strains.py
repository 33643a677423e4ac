"""Colonies of two strains in both models: a mutant sector, its reverse, a mixture (issue 32).

``colony case strains [--scale smoke|medium|paper]`` (paper: radius 80). Strain i grows at
a_i exp(-lam_i sigma) and daughters inherit it (continuum.strains, particles.strains). One
specification of the initial layout serves both engines: the fractions phi0(x, y) of
continuum.strains (``core``, ``sector``, ``mixture``, ``polygon``), which the continuum
carries as nodal fractions and from which each particle draws its strain
(particles.strains.draw_strains). Scenarios (``SCENARIOS``):

- ``mutant``: a stress-insensitive mutant (lam = 0) in a sector of opening ``THETA0`` at the
  edge of a lam = 1e-2 colony;
- ``reverse``: a lam = 1e-2 mutant sector in a lam = 0 colony;
- ``mixture``: half and half lam = 0 and lam = 1e-2, mixed at random (per cell; uniform
  fractions 1/2 in the continuum).

Start: a particle colony grown from one cell at the wild type's lam to the enclosing radius
``r0`` (one per seed), its cells then given their strains; the continuum from the disc of that
colony's hull radius (seed 0's), strains as fractions, t = 0 there. The continuum runs to the
radius ``R``, and both engines are compared at the same times tau since the start, ``FRAMES``
of them.

Measured at each time (:func:`particle_measures`, :func:`continuum_measures`): the radius
(sqrt(area / pi); particles: the hull radius), the area fraction of strain 1 (particles: cell
areas b (l - b) + pi b^2 / 4 summed per strain), and its edge fraction: the share of the
colony's edge held by strain 1 (continuum: phi_1 along the boundary, by length; particles: the
area fraction of strain 1 among the cells whose centre lies within ``EDGE_BAND`` of the hull
radius), whose 2 pi multiple is the sector's opening angle.

Outputs in ``out/data``: ``strains.csv`` (scenario, engine 0 continuum / 1 particles, seed, tau,
radius, fraction, edge_fraction), ``profiles.csv`` (scenario, engine, seed, r, fraction of
strain 1, the stress (particles: the mean axial stress sigma; continuum: the pressure p) and
each strain's mean length length_0, length_1 in annuli of width ``ANNULUS`` at the last time;
the continuum's nodes weighted by their lumped areas and fractions, the particles by their
areas), ``snapshots/*.npz`` (seed 0's colony
at the first, middle and last time; not committed) and from :func:`plot` ``strains.png`` and
``results.md``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from cases import analysis as A

__all__ = ["SCENARIOS", "SCALES", "compute", "plot", "particle_measures", "continuum_measures"]

THETA0 = math.pi / 4
"""Opening of the mutant sector at the start (radians)."""

SCENARIOS = {
    "mutant": (((1e-2, 1.0), (0.0, 1.0)), "sector"),
    "reverse": (((0.0, 1.0), (1e-2, 1.0)), "sector"),
    "mixture": (((0.0, 1.0), (1e-2, 1.0)), "mixture"),
}
"""name: (strains (lam_i, a_i), strain 0 the wild type; layout)."""

SCALES = {"smoke": {"r0": 4.0, "R": 8.0, "seeds": 2, "frames": 5},
          "medium": {"r0": 10.0, "R": 40.0, "seeds": 3, "frames": 9},
          "paper": {"r0": 20.0, "R": 80.0, "seeds": 2, "frames": 9}}
"""r0: the particle colony's enclosing radius when the strains are set; R: the continuum's
radius at the end; seeds: particle colonies per scenario; frames: times compared. "paper" is
radius 80, not the paper's 150 (a particle colony there takes about an hour)."""

EDGE_BAND = 2.0
"""Width of the particles' edge band (length units; two cell lengths)."""
ANNULUS = 2.0
"""Width of the annuli of the final profiles."""


def layout(name: str):
    """phi0(x, y) of a scenario's layout (continuum.strains): the sector about +x, or 1/2 each."""
    from continuum.strains import mixture, sector

    return sector(THETA0) if name == "sector" else mixture(0.5, 0.5)


def cell_areas(length: np.ndarray) -> np.ndarray:
    """Area of each rod: b (l - b) + pi b^2 / 4."""
    from particles import B

    return B * (length - B) + math.pi * B * B / 4


def particle_measures(state) -> dict[str, float]:
    """Radius (hull), area fraction and edge fraction of strain 1 of a particle colony."""
    area = cell_areas(state.length)
    one = state.strain == 1
    radius = state.hull_radius()
    cx, cy = np.average(state.x, weights=area), np.average(state.y, weights=area)
    edge = np.hypot(state.x - cx, state.y - cy) > radius - EDGE_BAND
    return {"radius": radius, "fraction": float(area[one].sum() / area.sum()),
            "edge_fraction": float(area[edge & one].sum() / area[edge].sum())}


def continuum_measures(state) -> dict[str, float]:
    """Radius sqrt(A / pi), area fraction and edge fraction (phi_1 along the boundary)."""
    nb = state.n_boundary
    b = state.points[:nb]
    edge = np.hypot(*(np.roll(b, -1, axis=0) - b).T)
    phi = state.phi[:nb, 1]
    along = float(np.sum(edge * 0.5 * (phi + np.roll(phi, -1))) / edge.sum())
    return {"radius": math.sqrt(state.area / math.pi),
            "fraction": float(state.strain_areas[1] / state.area), "edge_fraction": along}


def nodal_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Lumped area of each node: a third of the area of every triangle it belongs to."""
    from continuum.mesh import triangle_areas

    return np.bincount(triangles.ravel(), np.repeat(triangle_areas(points, triangles) / 3, 3),
                       minlength=len(points))


def annulus_means(r: np.ndarray, weight: np.ndarray, values: dict, radius: float) -> dict:
    """Weighted means in annuli of width ``ANNULUS`` over [0, radius], and their centres "r".

    ``values``: name -> (value v, extra weight e) per point; the mean is sum w e v / sum w e
    per annulus (nan where empty).
    """
    edges = np.arange(0.0, radius + ANNULUS, ANNULUS)
    out = {"r": 0.5 * (edges[1:] + edges[:-1])}
    for name, (value, extra) in values.items():
        w = weight * extra
        total, _ = np.histogram(r, edges, weights=w)
        sums, _ = np.histogram(r, edges, weights=w * value)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[name] = sums / total
    return out


def grown_colony(lam: float, r0: float, seed: int):
    """A particle colony grown from one cell at lam to the enclosing radius r0 (seeded)."""
    import particles

    return particles.run(particles.Config(lam=lam, radius=r0, seed=seed, threads=1)).state


def compute(scale: str = "smoke", out: str | Path = "runs/case-strains-smoke",
            scheduler: str | None = None, n_workers: int = 1, runs=None,
            engines: tuple[str, ...] = ("continuum", "particles"),
            finished_only: tuple[str, ...] = ()) -> Path:
    """Grow every scenario of ``scale`` in both engines and write the CSVs of the module doc.

    In this process, one run after another (``scheduler``, ``n_workers``, ``runs`` and
    ``finished_only`` do not apply: the runs are minutes and keep no folder).
    """
    import continuum
    import particles

    if scale not in SCALES:
        raise ValueError(f"scale must be one of {', '.join(SCALES)}, got {scale!r}")
    cfg = SCALES[scale]
    data = Path(out) / "data"
    (data / "snapshots").mkdir(parents=True, exist_ok=True)
    rows: dict[str, list] = {}
    prof: dict[str, list] = {}
    grown = {}
    for name, (strains, kind) in SCENARIOS.items():
        phi0 = layout(kind)
        wild = strains[0][0]
        for seed in range(cfg["seeds"]):
            if (wild, seed) not in grown:
                grown[wild, seed] = grown_colony(wild, cfg["r0"], seed)
        start = grown[wild, 0]
        cc = continuum.Config(lam=wild, shape=f"circle:{start.hull_radius():.6g}",
                              strains=strains, output_every=0.0)
        sim = continuum.Simulation(cc, layout=phi0)
        sim.advance(radius=cfg["R"])
        tau_end = sim.state.t
        taus = np.linspace(0.0, tau_end, cfg["frames"])
        shots = {0: [], 1: []}
        sim = continuum.Simulation(cc, layout=phi0)
        for k, tau in enumerate(taus):
            sim.advance(time=tau) if tau > 0 else None
            _append(rows, {"scenario": name, "engine": 0, "seed": 0, "tau": tau,
                           **continuum_measures(sim.state)})
            if k in (0, len(taus) // 2, len(taus) - 1):
                s = sim.state
                shots[0].append({"points": s.points, "triangles": s.triangles,
                                 "phi": s.phi[:, 1]})
        s = sim.state
        fields, one = s.fields, np.ones(len(s.points))
        means = annulus_means(np.hypot(*s.points.T), nodal_areas(s.points, s.triangles), {
            "fraction": (s.phi[:, 1], one), "stress": (s.p, one),
            "length_0": (fields["mean_length_0"], s.phi[:, 0]),
            "length_1": (fields["mean_length_1"], s.phi[:, 1])}, math.sqrt(s.area / math.pi))
        _append_many(prof, name, 0, 0, means)
        if "particles" in engines:
            for seed in range(cfg["seeds"]):
                g = grown[wild, seed]
                pc = particles.Config(lam=wild, strains=strains, seed=seed, threads=1)
                ps = particles.Simulation(pc, state=g, layout=phi0)
                for k, tau in enumerate(taus):
                    if tau > 0:
                        ps.advance(time=g.t + tau)
                    st = ps.state
                    _append(rows, {"scenario": name, "engine": 1, "seed": seed, "tau": tau,
                                   **particle_measures(st)})
                    if seed == 0 and k in (0, len(taus) // 2, len(taus) - 1):
                        shots[1].append({a: getattr(st, a).copy()
                                         for a in ("x", "y", "theta", "length", "strain")})
                st = ps.state
                one = np.ones(st.n)
                means = annulus_means(
                    np.hypot(st.x - st.x.mean(), st.y - st.y.mean()), cell_areas(st.length), {
                        "fraction": (st.strain == 1, one), "stress": (st.stress, one),
                        "length_0": (st.length, st.strain == 0),
                        "length_1": (st.length, st.strain == 1)}, st.hull_radius())
                _append_many(prof, name, 1, seed, means)
        for engine, frames in shots.items():
            arrays = {f"{k}_{i}": v for i, fr in enumerate(frames) for k, v in fr.items()}
            if arrays:
                np.savez_compressed(data / "snapshots" / f"{name}_{engine}.npz", taus=taus,
                                    **arrays)
    A.write_csv(data / "strains.csv", _columns(rows))
    A.write_csv(data / "profiles.csv", _columns(prof))
    return data


def _append(table: dict, row: dict) -> None:
    for k, v in row.items():
        table.setdefault(k, []).append(v)


def _append_many(table: dict, name: str, engine: int, seed: int, means: dict) -> None:
    for k in range(len(means["r"])):
        _append(table, {"scenario": name, "engine": engine, "seed": seed,
                        **{key: v[k] for key, v in means.items()}})


def _columns(table: dict) -> dict[str, np.ndarray]:
    scen = {n: i for i, n in enumerate(SCENARIOS)}
    return {k: np.array([scen[x] for x in v] if k == "scenario" else v, dtype=float)
            for k, v in table.items()}


def summary(data: Path) -> list[dict]:
    """Per scenario and engine at the last time: fraction and edge angle (mean, seed std)."""
    t = A.read_csv(Path(data) / "strains.csv")
    out = []
    for i, name in enumerate(SCENARIOS):
        for engine in (0, 1):
            sel = (t["scenario"] == i) & (t["engine"] == engine)
            if not sel.any():
                continue
            last = sel & (t["tau"] == t["tau"][sel].max())
            f, e = t["fraction"][last], t["edge_fraction"][last]
            first = sel & (t["tau"] == 0)
            out.append({"scenario": name, "engine": ("continuum", "particles")[engine],
                        "seeds": int(last.sum()), "tau": float(t["tau"][last][0]),
                        "radius": float(t["radius"][last].mean()),
                        "fraction0": float(t["fraction"][first].mean()),
                        "fraction": float(f.mean()), "fraction_std": float(f.std(ddof=1))
                        if f.size > 1 else 0.0,
                        "angle0": float(360 * t["edge_fraction"][first].mean()),
                        "angle": float(360 * e.mean()),
                        "angle_std": float(360 * e.std(ddof=1)) if e.size > 1 else 0.0})
    return out


def markdown_table(rows: list[dict]) -> str:
    """The summary as a Markdown table (fractions and edge angles at the start and the end)."""
    lines = ["| scenario | engine | seeds | tau | R | strain-1 area at 0 | at tau | edge angle "
             "at 0 (deg) | at tau (deg) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['scenario']} | {r['engine']} | {r['seeds']} | {r['tau']:.3g} | "
                     f"{r['radius']:.3g} | {r['fraction0']:.3f} | {r['fraction']:.3f} +- "
                     f"{r['fraction_std']:.3f} | {r['angle0']:.1f} | {r['angle']:.1f} +- "
                     f"{r['angle_std']:.1f} |")
    return "\n".join(lines) + "\n"


def _engine_bands(ax, table: dict, scenario: int, x: str, key: str, scale: float = 1.0) -> None:
    """Each engine's ``key`` (times ``scale``) against ``x`` for one scenario.

    The seed mean as a line, the seeds' standard deviation as a band (none for one seed; NaN
    values ignored).
    """
    for engine, color in ((0, "k"), (1, "C3")):
        sel = (table["scenario"] == scenario) & (table["engine"] == engine)
        xs = np.unique(table[x][sel])
        vals = [scale * table[key][sel & (table[x] == v)] for v in xs]
        mean = np.array([np.nanmean(v) if np.isfinite(v).any() else np.nan for v in vals])
        std = np.array([np.nanstd(v, ddof=1) if np.isfinite(v).sum() > 1 else 0.0
                        for v in vals])
        ax.plot(xs, mean, color=color, label=("continuum", "particles")[engine])
        ax.fill_between(xs, mean - std, mean + std, color=color, alpha=0.2, lw=0)


def plot_profiles(prof: dict, out: Path) -> list[Path]:
    """strains_profiles.png / .pdf: stress and each strain's mean length against r.

    Per scenario, at the last time: the stress (particles sigma, continuum p), the mean lengths
    of strain 0 and strain 1 (particles: seed mean and std band).
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    fig, axes = plt.subplots(len(SCENARIOS), 3, figsize=(13, 3.2 * len(SCENARIOS)), squeeze=False)
    for i, name in enumerate(SCENARIOS):
        for ax, key, label in zip(axes[i], ("stress", "length_0", "length_1"), (
                "stress (particles) / p (continuum)", "mean length, strain 0",
                "mean length, strain 1"), strict=True):
            _engine_bands(ax, prof, i, "r", key)
            ax.set_title(f"{name}: {label}", fontsize=9)
            ax.set_xlabel("r at the last time", fontsize=8)
            ax.legend(fontsize=8)
    fig.subplots_adjust(hspace=0.45)
    return save_figure(fig, out / "strains_profiles")


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """strains.png / .pdf and results.md.

    Rows: the scenarios; columns: seed 0's particle colony and the continuum (phi_1) at the
    first, middle and last time (strain 1 red), then the area fraction and the edge angle of
    strain 1 against tau and its fraction against r at the last time (particles: seed mean and
    std band; continuum: line). With the per-strain profiles, strains_profiles.png too
    (:func:`plot_profiles`).
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import draw_field, draw_particles, save_figure

    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t = A.read_csv(data / "strains.csv")
    prof = A.read_csv(data / "profiles.csv")
    fig, axes = plt.subplots(len(SCENARIOS), 9, figsize=(27, 3.2 * len(SCENARIOS)),
                             squeeze=False)
    for i, name in enumerate(SCENARIOS):
        row = axes[i]
        for engine, offset in ((1, 0), (0, 3)):
            path = data / "snapshots" / f"{name}_{engine}.npz"
            for k in range(3):
                ax = row[offset + k]
                ax.set_axis_off()
                if not path.is_file():
                    continue
                with np.load(path) as z:
                    if f"x_{k}" in z or f"points_{k}" in z:
                        if engine == 1:
                            draw_particles(z[f"x_{k}"], z[f"y_{k}"], z[f"theta_{k}"],
                                           z[f"length_{k}"], ax=ax, color_by=z[f"strain_{k}"],
                                           cmap="coolwarm", clim=(0, 1))
                        else:
                            draw_field(z[f"points_{k}"], z[f"triangles_{k}"], z[f"phi_{k}"],
                                       ax=ax, cmap="coolwarm", clim=(0, 1))
                        tau = z["taus"][[0, len(z["taus"]) // 2, -1][k]]
                        ax.set_title(f"{name}, {('continuum', 'particles')[engine]}, "
                                     f"tau = {tau:.2f}", fontsize=8)
        for ax, key, scale, label in ((row[6], "fraction", 1, "area fraction of strain 1"),
                                      (row[7], "edge_fraction", 360, "edge angle (deg)")):
            _engine_bands(ax, t, i, "tau", key, scale)
            ax.set_xlabel(r"$\tau$ (time since the strains were set)", fontsize=8)
            ax.set_ylabel(label)
            ax.legend(fontsize=8)
        ax = row[8]
        _engine_bands(ax, prof, i, "r", "fraction")
        ax.set_xlabel("r at the last time", fontsize=8)
        ax.set_ylabel("fraction of strain 1")
        ax.legend(fontsize=8)
    fig.subplots_adjust(wspace=0.35)
    paths = save_figure(fig, out / "strains")
    if "length_1" in prof:
        paths += plot_profiles(prof, out)
    table = markdown_table(summary(data))
    (out / "results.md").write_text("# Two strains (colony case strains)\n\n" + table)
    return [*paths, out / "results.md"]
