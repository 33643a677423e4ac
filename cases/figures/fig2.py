"""Fig 2 of the paper: pattern formation under stress-sensitive growth.

Rows A-C: particle colonies for the three lam of the scale (paper: 1e-4, 1e-3, 1e-2), each at
five times equally spaced up to the final time (t_k = k t_f / 5, the trajectory frame nearest
to it), particles drawn as sphero-cylinders coloured by length in [1, 2]. Rows D-F: the
continuum mean length lbar at the same five fractions of its own final time, same colours.
All panels of a row share the final colony's scale, so the growth is visible.

The continuum panels are drawn from the azimuthal average of the 2D field (equal-area annuli at
most 0.05 wide at the edge) revolved about the centre: the mean length of the transported Psi
over the annulus (column mean_length_psi, cases.analysis.continuum_profile), with the closed
form lbar = 2^frac(<G>/ln 2) of the annulus mean <G> of the smooth growth phase beside it in
the CSV as the check (column mean_length_phase; drawn from data made before the Psi column
existed; the annulus mean of the discontinuous lbar itself, column mean_length, smears every
ring over an annulus and is drawn only from data older still): the CSVs behind the figure stay small
(a 2D mesh at radius 150 has ~1e5 nodes per frame). How far the 2D field departs from radial
symmetry is not shown here. The particle snapshots are stored as gzipped CSV (x, y, theta,
length at 4 significant digits): at paper scale about 2 MB in all.

Scale: "smoke" (radius 15, lam in {0.03, 0.1, 0.3}; about a minute on 2 cores, runs shared with
the other cases through a common ``runs`` folder) or "paper" (radius 150; hours).

Engines and committed data as for every figure case (``cases.sweep.case_runs``, docs/DESIGN.md):
``engines=("continuum",)`` draws the continuum alone, ``--engines finished`` reuses finished
particle runs only; data in cases/data/fig2 (radius 40) and fig2_paper (radius 150).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.sweep import ENGINES, compute_case, engine_pairs, scale_config
from particles import enclosing_radius

__all__ = ["compute", "reduce", "plot", "runs_needed", "snapshot_indices", "N_SNAPSHOTS"]

N_SNAPSHOTS = 5


def runs_needed(scale: str, engines: tuple[str, ...] = ENGINES
                ) -> tuple[list[float], list[tuple[str, float]]]:
    """(lam values, (engine, lam) runs) at ``scale``."""
    lams = sorted(scale_config(scale)["lams"])
    return lams, engine_pairs(lams, engines)


def snapshot_indices(times: np.ndarray, n: int = N_SNAPSHOTS) -> list[int]:
    """Indices of the frames nearest to t_k = t0 + k (t_f - t0) / n, k = 1..n."""
    times = np.asarray(times, dtype=float)
    if times.size == 0:
        raise ValueError("no frames")
    t0, tf = times[0], times[-1]
    return [int(np.argmin(np.abs(times - (t0 + k * (tf - t0) / n)))) for k in range(1, n + 1)]


def compute(scale: str = "smoke", out: str | Path | None = None, **options) -> Path:
    """Run (or reuse) Fig 2's engine runs and reduce them to ``out/data``.

    :func:`cases.sweep.compute_case` with ``options`` as there; ``engines``: the engines whose
    rows are made (a subset of ENGINES, the continuum not required).
    """
    return compute_case("fig2", runs_needed, reduce, scale, out, needs_continuum=False, **options)


def reduce(folders: dict[tuple[str, float], Path], data: Path) -> Path:
    """Write the snapshots of every run and an index ``snapshots.csv`` into ``data``."""
    data = Path(data)
    index = {k: [] for k in ("engine", "lam", "k", "t", "radius")}
    for (engine, lam), folder in sorted(folders.items()):
        if engine == "particles":
            times = [t for t, _ in A.particle_frames(folder)]
            pick = snapshot_indices(np.array(times))
            for i, (t, fr) in enumerate(A.particle_frames(folder)):
                for k in (k for k, j in enumerate(pick, start=1) if j == i):
                    A.write_csv(data / f"particles_lam={lam:g}_k={k}.csv.gz",
                                {c: fr[c] for c in ("x", "y", "theta", "length")}, fmt="%.4g")
                    _index(index, 1, lam, k, t,
                           enclosing_radius(fr["x"], fr["y"], fr["theta"], fr["length"]))
        else:
            frames = A.continuum_frames(folder)
            pick = snapshot_indices(np.array([t for t, _ in frames]))
            for k, j in enumerate(pick, start=1):
                t, path = frames[j]
                pts, tri, d = A.read_continuum_frame(path)
                prof = A.continuum_profile(pts, tri, d)
                A.write_csv(data / f"continuum_lam={lam:g}_k={k}.csv",
                            {c: prof[c] for c in CONTINUUM_COLUMNS if c in prof})
                _index(index, 0, lam, k, t, A.mesh_radius(pts, tri))
    A.write_csv(data / "snapshots.csv", index)
    return data


#: Columns of a continuum snapshot's CSV (cases.analysis.continuum_profile).
CONTINUUM_COLUMNS = ("r", "mean_length_psi", "length_std_psi", "mean_length_phase", "mean_length")


def _continuum_mean_length(p: dict[str, np.ndarray]) -> np.ndarray:
    """The drawn mean length: the transported Psi's, else (older data) the closed form."""
    for name in ("mean_length_psi", "mean_length_phase", "mean_length"):
        if name in p:
            return p[name]
    raise ValueError("no mean length column in a continuum snapshot")


def _index(index: dict, engine: int, lam: float, k: int, t: float, radius: float) -> None:
    for key, v in zip(("engine", "lam", "k", "t", "radius"), (engine, lam, k, t, radius),
                      strict=True):
        index[key].append(v)


def _revolved(ax, r: np.ndarray, values: np.ndarray, n_theta: int = 256):
    """Draw a radial profile f(r) revolved about the origin (Gouraud-shaded triangles)."""
    from cases.figures.draw import draw_field

    ok = np.isfinite(values)
    r, values = np.append(0.0, r[ok]), np.append(values[ok][0], values[ok])  # fill the centre
    theta = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    R, T = np.meshgrid(r, theta, indexing="ij")
    pts = np.column_stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()])
    i, j = np.meshgrid(np.arange(r.size - 1), np.arange(n_theta), indexing="ij")
    a = (i * n_theta + j).ravel()
    b = (i * n_theta + (j + 1) % n_theta).ravel()
    c, d = a + n_theta, b + n_theta
    tri = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return draw_field(pts, tri, np.repeat(values, n_theta), ax=ax)


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Draw Fig 2 (PNG and PDF in ``out``) from the CSVs in ``data`` only."""
    import matplotlib.pyplot as plt

    from cases.figures.draw import colorbar, draw_particles, note_missing_engines, save_figure

    data, out = Path(data), Path(out)
    idx = A.read_csv(data / "snapshots.csv")
    lams = sorted(set(idx["lam"].tolist()))
    present = sorted(set(idx["engine"].astype(int).tolist()), reverse=True)  # particles first
    rows = [(engine, lam) for engine in present for lam in lams]
    fig, axes = plt.subplots(len(rows), N_SNAPSHOTS, figsize=(2.2 * N_SNAPSHOTS, 2.2 * len(rows)),
                             squeeze=False)
    mappable = None
    for row, (engine, lam) in enumerate(rows):
        sel = (idx["engine"] == engine) & (idx["lam"] == lam)
        label = chr(ord("A") + row + (len(lams) if 1 not in present else 0))  # continuum D-F
        axes[row, 0].set_ylabel(f"({label}) {'particles' if engine else 'continuum'}\n"
                                rf"$\lambda$ = {lam:g}", fontsize=8)
        if not sel.any():  # e.g. a paper-scale particle colony not computed
            for ax in axes[row]:
                ax.set_xticks([])
                ax.set_yticks([])
            axes[row, N_SNAPSHOTS // 2].text(0.5, 0.5, "not computed at this scale",
                                             ha="center", va="center", fontsize=8,
                                             transform=axes[row, N_SNAPSHOTS // 2].transAxes)
            continue
        R = float(idx["radius"][sel].max())
        for col in range(N_SNAPSHOTS):
            ax = axes[row, col]
            k = col + 1
            hit = sel & (idx["k"] == k)
            if engine == 1:
                p = A.read_csv(data / f"particles_lam={lam:g}_k={k}.csv.gz")
                c = np.array([p["x"].mean(), p["y"].mean()])
                mappable = draw_particles(p["x"] - c[0], p["y"] - c[1], p["theta"], p["length"],
                                          ax=ax)
            else:
                p = A.read_csv(data / f"continuum_lam={lam:g}_k={k}.csv")
                mappable = _revolved(ax, p["r"], _continuum_mean_length(p))
            ax.set_xlim(-1.05 * R, 1.05 * R)
            ax.set_ylim(-1.05 * R, 1.05 * R)
            ax.set_xticks([])
            ax.set_yticks([])
            if hit.any():
                ax.set_title(f"t = {float(idx['t'][hit][0]):.3g}", fontsize=8)
    if mappable is not None:
        colorbar(fig, mappable, axes.ravel().tolist())
    note_missing_engines(fig, {ENGINES[e] for e in present})  # codes 0, 1 as in ENGINES
    return save_figure(fig, out / "fig2")
