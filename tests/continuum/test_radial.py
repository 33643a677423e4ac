"""Tests of continuum.radial against independent computations (finite differences, solve_ivp)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from continuum import radial as rd

LAMS = [1e-2, 0.3, 2.0, -0.2]


def _slope(x, y):
    return np.polyfit(np.log(x), np.log(y), 1)[0]


@pytest.mark.parametrize("lam", LAMS)
def test_pressure_solves_radial_problem_with_order_two_residual(lam):
    """-p'' - p'/r - exp(-lam p) by central differences -> 0 at order 2; p(R) = 0, p'(0) = 0."""
    R = 2.5
    r = np.linspace(0.3, R - 0.3, 9)
    hs = np.array([0.08, 0.04, 0.02, 0.01])
    res = []
    for h in hs:
        pm, p, pp = (rd.pressure(r + d, R, lam) for d in (-h, 0.0, h))
        lap = (pp - 2 * p + pm) / h**2 + (pp - pm) / (2 * h * r)
        res.append(np.max(np.abs(-lap - np.exp(-lam * p))))
    assert abs(_slope(hs, res) - 2.0) < 0.1
    assert rd.pressure(R, R, lam) == 0.0
    h = 1e-4
    assert abs(rd.pressure(h, R, lam) - rd.pressure(0.0, R, lam)) < 1e-6
    assert rd.max_pressure(R, lam) == rd.pressure(0.0, R, lam)


@pytest.mark.parametrize("lam", LAMS + [0.0])
def test_velocity_and_growth_rate_are_consistent_with_pressure(lam):
    R = 3.0
    r = np.linspace(0.1, R - 0.1, 13)
    h = 1e-5
    dp = (rd.pressure(r + h, R, lam) - rd.pressure(r - h, R, lam)) / (2 * h)
    np.testing.assert_allclose(rd.velocity(r, R, lam), -dp, rtol=1e-7)
    np.testing.assert_allclose(
        rd.growth_rate(r, R, lam), np.exp(-lam * rd.pressure(r, R, lam)), rtol=1e-13
    )
    assert rd.radius_rate(R, lam) == pytest.approx(rd.velocity(R, R, lam), rel=1e-14)
    # model.md's form p = (2/lam) ln(1/(8c) - c lam r^2), c = [sqrt(1 + lam R^2/2) - 1]/(2 lam R^2)
    if lam != 0:
        c = (math.sqrt(1 + lam * R**2 / 2) - 1) / (2 * lam * R**2)
        assert rd.c_of_R(R, lam) == pytest.approx(c, rel=1e-12)
        p_md = 2 / lam * np.log(1 / (8 * c) - c * lam * r**2)
        np.testing.assert_allclose(rd.pressure(r, R, lam), p_md, rtol=1e-10, atol=1e-12)


def test_lam_zero_is_the_limit_of_small_lam():
    R = 4.0
    r = np.linspace(0, R, 11)
    np.testing.assert_allclose(rd.pressure(r, R, 0.0), (R**2 - r**2) / 4, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rd.velocity(r, R, 0.0), r / 2, rtol=1e-15)
    assert rd.c_of_R(R, 0.0) == 0.125
    lams = np.array([1e-3, 1e-4, 1e-5, 1e-6])
    errs = [np.max(np.abs(rd.pressure(r, R, lam) - rd.pressure(r, R, 0.0))) for lam in lams]
    assert abs(_slope(lams, errs) - 1.0) < 0.02  # p(lam) = p(0) + O(lam)
    assert np.max(np.abs(rd.pressure(r, R, 1e-14) - rd.pressure(r, R, 0.0))) < 1e-12


@pytest.mark.parametrize("lam", [0.0, 1e-4, 1e-2, 1.0, -0.5])
def test_radius_matches_independent_ode_solution(lam):
    t_eval = np.array([0.0, 0.5, 1.5, 2.5, 2.9])
    sol = solve_ivp(
        lambda t, y: [rd.radius_rate(y[0], lam)],
        (0, t_eval[-1]),
        [rd.R0],
        method="DOP853",
        rtol=1e-13,
        atol=1e-15,
        t_eval=t_eval,
    )
    np.testing.assert_allclose(rd.radius(t_eval, lam), sol.y[0], rtol=1e-11)
    np.testing.assert_allclose(rd.time_to_radius(rd.radius(t_eval, lam), lam), t_eval, atol=1e-12)


def test_radius_lam_zero_is_exponential():
    t = np.linspace(0, 20, 7)
    np.testing.assert_allclose(rd.radius(t, 0.0), rd.R0 * np.exp(t / 2), rtol=1e-15)


@pytest.mark.parametrize("lam", [1e-4, 1e-2, 1.0])
def test_late_time_slope_tends_to_sqrt_two_over_lam(lam):
    """dR/dt -> sqrt(2/lam), with error O(1/R) (slope -1 in the radius)."""
    Rs = np.array([1e2, 1e3, 1e4, 1e5]) / math.sqrt(lam)
    ts = rd.time_to_radius(Rs, lam)
    dt = 1e-3 * ts
    slope = (rd.radius(ts + dt, lam) - rd.radius(ts - dt, lam)) / (2 * dt)
    err = np.abs(slope - math.sqrt(2 / lam))
    assert err[-1] < 1e-4 * math.sqrt(2 / lam)
    assert abs(_slope(Rs, err) + 1.0) < 0.1


def test_negative_lam_beyond_critical_size_is_a_clear_error():
    lam = -0.5
    Rc = rd.critical_radius(lam)
    assert Rc == pytest.approx(2.0)
    with pytest.raises(rd.NoRadialSolution, match="critical|sqrt"):
        rd.pressure(0.0, 1.01 * Rc, lam)
    tc = rd.time_to_radius(Rc, lam)
    with pytest.raises(rd.NoRadialSolution):
        rd.radius(tc + 0.1, lam)
    with pytest.raises(ValueError):
        rd.pressure(3.0, 2.0, 0.1)
    with pytest.raises(ValueError):
        rd.radius(-1.0, 0.1)
    with pytest.raises(ValueError):
        rd.characteristics(0.1, t_end=1.0, radius_end=2.0)


def test_lam_zero_characteristics_are_exact():
    t = 3.7
    labels = np.linspace(0, rd.R0, 9)
    ch = rd.characteristics(0.0, t_end=t, r0=labels)
    np.testing.assert_allclose(ch.r, labels * math.exp(t / 2), rtol=1e-9)
    np.testing.assert_allclose(ch.G, t, rtol=1e-9)
    back = rd.characteristics(0.0, t_end=t, n_paths=9)
    np.testing.assert_allclose(back.r0, back.r * math.exp(-t / 2), rtol=1e-9)
    np.testing.assert_allclose(back.G, t, rtol=1e-9)
    lbar = rd.mean_length_profile(0.0, np.linspace(0, 1, 5), t=t)
    np.testing.assert_allclose(lbar, 2 ** ((t / math.log(2)) % 1), rtol=1e-9)
    assert rd.ring_radii(0.0, t=t).size == 0


@pytest.mark.parametrize("lam", [1e-2, 0.5])
def test_characteristics_match_an_independent_solve_in_time(lam):
    """Backward (sigma = ln R) paths vs forward paths in t with dr/dt = u(r, R(t)), dG/dt = g."""
    t_end = 6.0
    back = rd.characteristics(lam, t_end=t_end, n_paths=7)

    def f(t, y):
        R = rd.radius(t, lam)
        r = np.minimum(y[:7], R)
        return np.concatenate((rd.velocity(r, R, lam), rd.growth_rate(r, R, lam)))

    sol = solve_ivp(
        f,
        (0, t_end),
        np.concatenate((back.r0, np.zeros(7))),
        method="DOP853",
        rtol=1e-11,
        atol=1e-13,
    )
    np.testing.assert_allclose(sol.y[:7, -1], back.r, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(sol.y[7:, -1], back.G, rtol=1e-7)
    assert back.G[-1] == pytest.approx(t_end, rel=1e-9)  # the edge grows at g = 1
    assert np.all(np.diff(back.G) > 0)  # G increases outward: the centre is inhibited


def test_growth_phase_converges_with_its_tolerance():
    lam, R = 1e-2, 150.0
    r = np.linspace(0, R, 31)
    ref = rd.growth_phase(lam, r, radius=R, rtol=1e-13)
    errs = [
        np.max(np.abs(rd.growth_phase(lam, r, radius=R, rtol=tol) - ref))
        for tol in (1e-6, 1e-8, 1e-10)
    ]
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-8 * np.max(ref)


def test_ring_radii_at_radius_150_are_converged_and_on_the_phase_levels():
    lam, R = 1e-2, 150.0
    rings, k = rd.ring_radii(lam, radius=R, with_index=True)
    finer = rd.ring_radii(lam, radius=R, n_grid=4001, rtol=1e-12)
    assert rings.size == finer.size >= 5
    np.testing.assert_allclose(rings, finer, atol=1e-7)
    # forward integration from the ring labels lands on the rings with G = k ln 2
    back = rd.characteristics(lam, radius_end=R, r_final=rings)
    fwd = rd.characteristics(lam, radius_end=R, r0=back.r0, rtol=1e-12)
    np.testing.assert_allclose(fwd.r, rings, atol=1e-6)
    np.testing.assert_allclose(fwd.G, k * math.log(2), atol=1e-8)
    spacing = np.diff(rings)
    assert np.all(spacing > 0)
    # lbar drops from ~2 to ~1 across each ring
    eps = 1e-6
    lo = rd.mean_length_profile(lam, rings - eps, radius=R)
    hi = rd.mean_length_profile(lam, rings + eps, radius=R)
    assert np.all(lo > 1.99) and np.all(hi < 1.01)


def test_ring_radii_with_phase_offset_and_time_series():
    """Initial delta(l - 2^phase0): rings where G/ln 2 + phase0 is an integer; series = calls."""
    lam, phase0 = 1e-2, 0.3
    rings, k = rd.ring_radii(lam, radius=60.0, with_index=True, phase0=phase0)
    assert rings.size >= 2
    G = rd.growth_phase(lam, rings, radius=60.0)
    np.testing.assert_allclose(G / math.log(2) + phase0, k, atol=1e-10)
    eps = 1e-6
    lo = rd.mean_length_profile(lam, rings - eps, radius=60.0, phase0=phase0)
    hi = rd.mean_length_profile(lam, rings + eps, radius=60.0, phase0=phase0)
    assert np.all(lo > 1.99) and np.all(hi < 1.01)
    times = rd.time_to_radius(np.array([20.0, 40.0, 60.0]), lam)
    series = [rd.ring_radii(lam, t=t) for t in times]
    assert [s.size for s in series] == sorted(s.size for s in series)  # rings accumulate
