"""docs/measurements/stability_radius.py: the reduction and fits, the R sweep at smoke size.

On constructed rates, at smoke size, and the committed data.
"""

import math
from pathlib import Path

import numpy as np
import pytest

import cases
from cases import analysis as A
from tests.measurements import measurement
from tests.pictures import assert_figures

SR = measurement("stability_radius")

DATA = Path(cases.__file__).parent / "data" / "stability"


def _constructed(ratio_of_R, radii=(8.0, 16.0, 32.0), spread=0.05):
    """Rates of K = 4 (theory -2) and 3 seeds per R whose ratios are ratio(R) + (-s, 0, +s)."""
    cols = {k: [] for k in SR.RATE_COLS}
    for R in radii:
        for seed, dev in zip((1, 2, 3), (-spread, 0.0, spread), strict=True):
            r = ratio_of_R(R) + dev
            row = dict(orientation=0, K=4, radius=R, seed=seed, lam=0.0, eps=0.15,
                       measured=-2.0 * r, measured_late=-2.0 * r, theory=-2.0, ratio=r,
                       ratio_late=r, amplitude_start=0.15, amplitude_end=0.05, floor_end=0.01,
                       particles_start=1, particles_end=2, frames=11)
            for k in cols:
                cols[k].append(row[k])
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def test_reduce_and_power_law_exact():
    """Ratio = 1 - 0.4 (R / 8)^-1.5 per seed mean: the power law exactly.

    Exponent -1.5, prefactor 0.4 * 8^1.5 and the 10 % radius 8 * 4^(1/1.5), exactly; seeds'
    std 0.05, sem 0.05 / sqrt(3).
    """
    q = SR.reduce_ratios(_constructed(lambda R: 1.0 - 0.4 * (R / 8.0) ** -1.5))
    assert q["mean"] == pytest.approx(1.0 - 0.4 * (q["radius"] / 8.0) ** -1.5, abs=1e-12)
    assert q["std"] == pytest.approx(0.05) and q["sem"] == pytest.approx(0.05 / math.sqrt(3))
    assert np.all(q["seeds"] == 3) and np.all(q["measurable"] == 1.0)
    f = SR.fit_ratios(q)
    assert f["exponent"][0] == pytest.approx(-1.5, abs=1e-10)
    assert f["prefactor"][0] == pytest.approx(0.4 * 8.0 ** 1.5, rel=1e-10)
    assert f["R10_power"][0] == pytest.approx(8.0 * 4.0 ** (1 / 1.5), rel=1e-10)


def test_linear_in_inverse_R_exact():
    """The line in 1/R exactly.

    Ratio = 0.6 + 1.6 / R: r_inf 0.6 (never within 10 %: R10 inf); ratio = 1.02 - 4 / R:
    r_inf 1.02, within 10 % from R = 4 / 0.12; a ratio already within at R = 8: R10 = 8.
    """
    f = SR.fit_ratios(SR.reduce_ratios(_constructed(lambda R: 0.6 + 1.6 / R)))
    assert f["r_inf"][0] == pytest.approx(0.6, abs=1e-10)
    assert f["slope_inv_R"][0] == pytest.approx(1.6, abs=1e-9)
    assert math.isinf(f["R10_linear"][0]) and f["radii"][0] == 3
    f = SR.fit_ratios(SR.reduce_ratios(_constructed(lambda R: 1.02 - 4.0 / R)))
    assert f["r_inf"][0] == pytest.approx(1.02, abs=1e-10)
    assert f["R10_linear"][0] == pytest.approx(4.0 / 0.12, rel=1e-9)
    f = SR.fit_ratios(SR.reduce_ratios(_constructed(lambda R: 1.05 - 0.08 / R)))
    assert f["R10_linear"][0] == 8.0 and f["R10_power"][0] == 8.0
    # means on both sides of 1: no power law
    f = SR.fit_ratios(SR.reduce_ratios(_constructed(lambda R: 1.0 + (R - 16.0) / 100)))
    assert math.isnan(f["exponent"][0])


def test_radius_sweep_smoke(tmp_path):
    """The R sweep at smoke size (R = 4, 5; K = 3; one seed; t in [0, 0.5]).

    One row per run, the mode decays, theory -K/2 at lam = 0, the reduction, fit, table and
    figure are made.
    """
    data = SR.main(["--scale", "smoke", "--out", str(tmp_path)])
    r = A.read_csv(data / "radius_rates.csv")
    assert r["radius"].tolist() == [4.0, 5.0]
    assert np.all(r["theory"] == -1.5) and np.all(r["measured"] < 0)
    np.testing.assert_allclose(r["ratio"], r["measured"] / r["theory"], rtol=1e-7)
    assert np.all(r["particles_start"][1] > r["particles_start"][0])
    f = A.read_csv(data / "radius_fit.csv")
    assert f["radii"].tolist() == [2.0, 2.0] and f["window"].tolist() == [0.0, 1.0]
    assert_figures([tmp_path / "radius_study.png"])
    assert "ratio [0, t_end]" in (tmp_path / "radius_results.md").read_text()


@pytest.mark.skipif(not (DATA / "radius_rates.csv").is_file(), reason="no committed R sweep")
def test_committed_radius_data(tmp_path):
    """The committed R sweep reduces to its committed ratios and fits and redraws."""
    r = A.read_csv(DATA / "radius_rates.csv")
    q = SR.reduce_ratios(r)
    committed = A.read_csv(DATA / "radius_ratios.csv")
    for k in ("mean", "std"):
        np.testing.assert_allclose(q[k], committed[k], rtol=1e-5, atol=1e-6)
    paths = SR.plot(DATA, tmp_path)
    assert_figures(paths)


def test_outline_of_edge_rods_is_the_full_outline():
    """The alpha shape of the rods near the edge (stability_radius.outline) is the one of all rods.

    A star:3,0.15,16 filled with rods (about 1000); the margin keeps about half of them; the
    two outlines hold the same vertices in the same cyclic order, so the mode amplitudes agree.
    """
    from cases.shapes import initial_particles
    from cases.studies.stability import mode_amplitude

    st = initial_particles("star:3,0.15,16", seed=1)
    x, y, th, ln = st.x, st.y, st.theta, st.length
    keep = SR.boundary_rods(np.asarray(x), np.asarray(y))
    assert 0.2 < keep.mean() < 0.9
    part, full = SR.outline(x, y, th, ln), SR.outline(x, y, th, ln, margin=None)
    start = np.flatnonzero((full == part[0]).all(axis=1))
    assert start.size == 1 and part.shape == full.shape
    np.testing.assert_array_equal(np.roll(full, -start[0], axis=0), part)
    assert mode_amplitude(part, 3) == pytest.approx(mode_amplitude(full, 3), rel=1e-12)
