"""The seed ensemble (cases.studies.ensemble) and its statistics (cases.analysis.statistics).

1. The central-stress estimators on synthetic noisy profiles with a known centre value p0: the
   largest annulus mean is biased upwards (by many of its standard errors), the fit
   p0 - c r^2 is not, and its stated standard error is the fit's actual scatter.
2. seed_spread and time_at_radius against exact values.
3. The smoke ensemble end to end with the real engines (four particle runs and one continuum
   run at radius 8; about 40 s of CPU).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import t as student_t

from cases import analysis as A
from cases import datasets
from cases.studies import ensemble
from tests.measurements import measurement
from tests.pictures import assert_figures


def _noisy_profiles(rng, p0=400.0, c=0.25, R=40.0, per_annulus=200, rel_std=0.8, n=400):
    """Annulus means of ``n`` synthetic colonies: gamma-distributed loads about p0 - c r^2.

    Equal-area annuli at most 0.5 wide at the edge (as the particle profiles), ``per_annulus``
    particles each with standard deviation ``rel_std`` of the local mean (force chains: skewed,
    positive loads).
    """
    N = A.annuli_for_edge_width(R, 0.5)
    r = R * np.sqrt((np.arange(N) + 0.5) / N)
    mean = p0 - c * r**2
    shape = 1.0 / rel_std**2
    samples = rng.gamma(shape, mean[None, :, None] / shape, size=(n, N, per_annulus))
    return r, samples.mean(axis=2), np.full(N, per_annulus)


def test_fit_is_unbiased_where_the_largest_annulus_mean_is_not():
    rng = np.random.default_rng(17)
    p0, R = 400.0, 40.0
    r, means, count = _noisy_profiles(rng, p0=p0, R=R)
    largest = means.max(axis=1)
    fits = np.array([A.central_value(r, m, R, count) for m in means])
    est, se = fits[:, 0], fits[:, 1]
    n = len(means)
    # the largest annulus mean: biased upwards by far more than its standard error
    bias_max = largest.mean() - p0
    assert bias_max > 5 * largest.std(ddof=1) / math.sqrt(n)
    assert bias_max > 0.01 * p0  # measured 1.75 % (independent loads; chains make it larger)
    # the fit: mean within 3 standard errors of p0 ...
    assert abs(est.mean() - p0) < 3 * est.std(ddof=1) / math.sqrt(n)
    # ... and its stated error is its scatter; the 95 % t-interval covers p0 about 95 % of times
    assert 0.8 < np.median(se) / est.std(ddof=1) < 1.25
    dof = int(np.sum(r < A.CENTRAL_FRACTION * R)) - 2
    covered = np.abs(est - p0) <= student_t.ppf(0.975, dof) * se
    assert 0.9 < covered.mean() <= 1.0


def test_fit_is_exact_on_the_radial_pressure_at_lam_0():
    from continuum import radial

    R = 40.0
    N = A.annuli_for_edge_width(R, 0.5)
    r = R * np.sqrt((np.arange(N) + 0.5) / N)
    p0, se, c = A.central_value(r, radial.pressure(r, R, 0.0), R)
    assert p0 == pytest.approx(R**2 / 4, rel=1e-12)
    assert c == pytest.approx(0.25, rel=1e-12)
    assert se < 1e-9
    for lam in (1e-3, 1e-2, 1e-1):  # the neglected r^4 term: below 0.3 % (docs/results.md)
        p0, _, _ = A.central_value(r, radial.pressure(r, R, lam), R)
        assert abs(p0 / radial.max_pressure(R, lam) - 1) < 3e-3


def test_central_value_bad_input():
    r = np.linspace(1, 10, 10)
    with pytest.raises(ValueError, match="two finite annuli"):
        A.central_value(r, r, 1.5)
    with pytest.raises(ValueError, match="fraction"):
        A.central_value(r, r, 10.0, fraction=0.0)
    with pytest.raises(ValueError, match="differ in length"):
        A.central_value(r, r[:3], 10.0)


def test_seed_spread_exact():
    v = np.array([[1.0, 10.0], [2.0, 10.0], [3.0, np.nan], [4.0, 10.0], [5.0, 10.0],
                  [6.0, 10.0], [7.0, 10.0], [8.0, 10.0]])
    s = A.seed_spread(v)
    assert s["n"].tolist() == [8, 7]
    assert s["mean"].tolist() == [4.5, 10.0]
    std = math.sqrt(42 / 7)
    assert s["std"][0] == pytest.approx(std)
    assert s["std"][1] == 0.0
    t8 = 2.3646242510102993  # t_{0.975, 7}
    assert s["ci95"][0] == pytest.approx(t8 * std / math.sqrt(8))
    assert s["pi95"][0] == pytest.approx(t8 * std * math.sqrt(1 + 1 / 8))
    assert s["q025"][0] == pytest.approx(1 + 0.025 * 7)
    assert s["q975"][0] == pytest.approx(1 + 0.975 * 7)
    one = A.seed_spread(np.array([[3.0]]))
    assert one["mean"][0] == 3.0 and math.isnan(one["std"][0]) and math.isnan(one["ci95"][0])


def test_time_at_radius_exact_and_first_crossing():
    t = np.linspace(0, 4, 4001)
    R = np.exp(t / 2)
    radii = np.array([1.0, 2.0, 5.0, 100.0])
    got = A.time_at_radius(t, R, radii)
    np.testing.assert_allclose(got[:3], 2 * np.log(radii[:3]), atol=1e-6)
    assert math.isnan(got[3])
    # not monotone: the first crossing (of the running maximum)
    assert A.time_at_radius([0, 1, 2, 3], [1, 3, 2, 4], [2.5])[0] == pytest.approx(0.75)


# ------------------------------------------------------------------ smoke scale, real engines


def test_smoke_ensemble_end_to_end(tmp_path):
    data = ensemble.compute(scale="smoke", out=tmp_path, n_workers=1)
    paths = ensemble.plot(data, tmp_path)
    assert_figures(paths)
    seeds = A.read_csv(data / "seeds.csv")
    assert seeds["seed"].tolist() == [0, 1]
    assert np.all(np.abs(seeds["radius_final"] - 8.0) < 0.5)
    s = A.read_csv(data / "summary.csv")
    assert s["n_seeds"].tolist() == [2]
    # the two colonies differ (seeds); at radius 8 the colony (~100 particles) is still below
    # the continuum's stress (measured 2026-12-01, 3 seeds: central fit -35 +- 4 %, time to
    # radius 8 -11 +- 2 %)
    assert s["t_final_std"][0] > 0
    d = A.read_csv(data / "differences.csv")
    assert -0.6 < d["rel_central_fit_mean"][0] < 0.2
    assert abs(d["rel_t_final_mean"][0]) < 0.15
    prof = A.read_csv(data / "profile_lam=0.1.csv")
    ok = np.isfinite(prof["stress_mean"])
    assert ok.sum() > 5
    assert np.all(prof["stress_q025"][ok] <= prof["stress_mean"][ok] + 1e-9)
    assert np.all(prof["stress_mean"][ok] <= prof["stress_q975"][ok] + 1e-9)
    num = A.read_csv(data / "numerics.csv")
    assert sorted(zip(num["dt"], num["tol"], strict=True)) == [
        (0.005, 0.001), (0.01, 0.0005), (0.01, 0.001)]
    assert sorted(num["solver_tol"]) == [0.00025, 0.0005, 0.0005]  # tol / 2 unless set
    growth = A.read_csv(data / "growth_lam=0.1.csv")
    assert growth["radius"][-1] == pytest.approx(8.0)
    assert np.isfinite(growth["rel_t_mean"]).all()


def test_ensemble_needs_both_engines(tmp_path):
    with pytest.raises(ValueError, match="needs both"):
        ensemble.compute(scale="smoke", out=tmp_path, engines=("continuum",))
    with pytest.raises(ValueError, match="scale must be one of"):
        ensemble.compute(scale="paper", out=tmp_path)


def test_cycle_mean_removes_a_periodic_dip_and_mean_pressure_exact():
    period = ensemble.DIVISION_PERIOD
    t = np.linspace(0, 5, 50001)
    y = 1.0 + 0.5 * np.sin(2 * np.pi * t / period)
    m = ensemble.cycle_mean(t, y)
    assert np.all(np.isnan(m[t < period - 1e-9]))
    np.testing.assert_allclose(m[t >= period + 1e-3], 1.0, atol=1e-7)
    from continuum import radial

    R = np.array([10.0, 40.0])
    np.testing.assert_allclose(ensemble.continuum_mean_pressure(R, 0.0), R**2 / 8, rtol=1e-15)
    r = np.linspace(0, 40.0, 400001)
    exact = 2 * np.trapezoid(radial.pressure(r, 40.0, 1e-2) * r, r) / 40.0**2
    assert ensemble.continuum_mean_pressure(40.0, 1e-2)[0] == pytest.approx(exact, rel=1e-5)


def test_trailing_rate():
    R = np.array([10.0, 20, 40, 80, 160])
    assert ensemble.trailing_rate(R, -0.5 * R**-1.0) == pytest.approx(-1.0)
    # the sign changes after R = 20: only the last three radii are fitted
    assert ensemble.trailing_rate(R, np.array([-0.3, -0.1, 0.01 * 40, 0.01 * 80, 0.01 * 160])
                                  ) == pytest.approx(1.0)
    assert math.isnan(ensemble.trailing_rate(R, np.array([1.0, 1, 1, -1, 1])))


def test_plot_and_offset_tables_from_committed_data(tmp_path):
    """`colony case ensemble --from-data` and `python docs/measurements/stress_offset.py`."""
    from pathlib import Path

    stress_offset = measurement("stress_offset")

    data = Path(ensemble.__file__).resolve().parents[1] / "data" / "ensemble"
    paths = ensemble.plot(data, tmp_path)
    assert_figures(paths)
    assert "| lam | seeds |" in (tmp_path / "tables.md").read_text()
    assert stress_offset.main(["--out", str(tmp_path)]) == 0
    for name in ("estimators.csv", "growth_paper.csv"):  # the committed tables, reproduced
        assert (tmp_path / name).read_bytes() == (data / name).read_bytes()


# ------------------------------------------------------------------ partial-lam merge


def _tables(folder, lams, value):
    """Small ensemble data in ``folder``: the four lam tables, per-lam files, other tables."""
    rows = {"lam": [lam for lam in lams for _ in range(2)], "seed": [0, 1] * len(lams),
            "t_final": [value + lam + 0.1 * s for lam in lams for s in (0, 1)]}
    A.write_csv(folder / "seeds.csv", rows)
    for name, col in (("summary.csv", "t_final_mean"), ("differences.csv", "rel_t_final_mean"),
                      ("growth_rates.csv", "rate_t")):
        A.write_csv(folder / name, {"lam": lams, col: [value + 1 / 3 + lam for lam in lams]})
    for lam in lams:
        for kind in ("profile", "radius", "time", "growth"):
            A.write_csv(folder / f"{kind}_lam={lam:g}.csv", {"r": [1.0, 2.0], "v": [value] * 2})
    for name in ("numerics.csv", "estimators.csv", "growth_paper.csv"):
        A.write_csv(folder / name, {"lam": [1e-3], "x": [value]})


def test_merge_adds_and_replaces_lam_and_keeps_the_rest_byte_for_byte(tmp_path):
    from cases.figures import merge as figure_merge

    old, new = tmp_path / "old", tmp_path / "new"
    old.mkdir(), new.mkdir()
    _tables(old, [0.0, 1e-3, 1e-2], 1.0)
    _tables(new, [1e-4, 1e-2], 2.0)  # 1e-4 added, 1e-2 replaced
    (old / "README.md").write_text("old readme\n")
    out = tmp_path / "merged"
    assert figure_merge.main(["ensemble", str(new), str(old), str(out)]) == 0
    assert not (tmp_path / "merged.partial").exists()

    def lines(path):
        return path.read_bytes().splitlines(keepends=True)

    for name in datasets.LAM_TABLES:
        got, was, add = lines(out / name), lines(old / name), lines(new / name)
        assert got[0] == was[0]
        lam_of_row = [float(r.split(b",")[0]) for r in got[1:]]
        assert lam_of_row == sorted(lam_of_row)  # ordered by lam
        kept = [r for r in was[1:] if float(r.split(b",")[0]) in (0.0, 1e-3)]
        assert [r for r in got[1:] if float(r.split(b",")[0]) in (0.0, 1e-3)] == kept
        assert [r for r in got[1:] if float(r.split(b",")[0]) in (1e-4, 1e-2)] == add[1:]
    s = A.read_csv(out / "seeds.csv")
    assert s["lam"].tolist() == [0, 0, 1e-4, 1e-4, 1e-3, 1e-3, 1e-2, 1e-2]
    assert s["seed"].tolist() == [0, 1] * 4
    for lam, source in ((0.0, old), (1e-4, new), (1e-3, old), (1e-2, new)):
        for kind in ("profile", "radius", "time", "growth"):
            name = f"{kind}_lam={lam:g}.csv"
            assert (out / name).read_bytes() == (source / name).read_bytes()
    for name in ("numerics.csv", "estimators.csv", "growth_paper.csv", "README.md"):
        assert (out / name).read_bytes() == (old / name).read_bytes()
    assert sorted(p.name for p in out.iterdir()) == sorted(
        {p.name for p in old.iterdir()} | {p.name for p in new.iterdir()})

    with pytest.raises(ValueError, match="exists already"):
        datasets.merge(new, old, out)
    A.write_csv(new / "growth_rates.csv", {"lam": [1e-4, 1e-2], "other": [1.0, 2.0]})
    with pytest.raises(ValueError, match="columns differ"):
        datasets.merge(new, old, tmp_path / "bad")
    assert not (tmp_path / "bad").exists() and not (tmp_path / "bad.partial").exists()


def test_lams_select_runs_of_the_ensemble():
    particles, continuum, numerics = ensemble._run_list("medium", [1e-4])
    assert sorted(particles) == [(1e-4, s) for s in range(8)]
    assert list(continuum) == [1e-4] and numerics == {}
    particles, continuum, numerics = ensemble._run_list("medium")
    assert len(particles) == 56 and len(continuum) == 7 and len(numerics) == 3
    with pytest.raises(ValueError, match="lam 0.5 not among the lam of the medium ensemble"):
        ensemble._run_list("medium", [0.5])
