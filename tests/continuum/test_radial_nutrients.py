"""The radial reference with nutrients (continuum.radial_nutrients) against exact answers."""

import math

import numpy as np
import pytest

from continuum import radial
from continuum import radial_nutrients as rn
from continuum.growth import uptake, uptake_slope


def test_uptake_is_monod_normalised_to_the_reservoir():
    c = np.linspace(0.0, 2.0, 21)
    for K in (0.1, 1.0, 30.0):
        f = uptake(c, K)
        assert uptake(1.0, K) == pytest.approx(1.0, abs=1e-15)
        assert np.allclose(f, (1 + K) * c / (K + c), rtol=1e-15)
        h = 1e-6  # the slope against a central difference: error O(h^2)
        assert np.allclose(uptake_slope(c, K), (uptake(c + h, K) - uptake(c - h, K)) / (2 * h),
                           rtol=1e-8)
    assert np.array_equal(uptake(c, math.inf), c)
    assert uptake(0.5, 1e12) == pytest.approx(0.5, rel=1e-11)  # K -> inf: first order


@pytest.mark.parametrize("R,ell", [(1.0, 5.0), (10.0, 5.0), (60.0, 5.0), (10.0, 40.0)])
def test_lam_zero_first_order_edge_supply_is_the_bessel_solution(R, ell):
    state = rn.solve(R, 0.0, ell)
    c, u, U = rn.bessel(state.r, R, ell)
    assert np.max(np.abs(state.c - c) / c) < 1e-9
    assert np.max(np.abs(state.u - u)) < 1e-9 * U
    assert state.speed == pytest.approx(U, rel=1e-10)
    assert np.allclose(state.p, ell**2 * (1 - state.c), rtol=0, atol=1e-12 * ell**2)


def test_the_time_to_a_radius_is_the_closed_form():
    """t(R) = ln(R I1(R/ell) / (R0 I1(R0/ell))): exponential, then linear at speed ell."""
    R = np.array([0.5, 2.0, 10.0, 30.0])
    for ell in (5.0, 20.0):
        assert np.allclose(rn.time_to_radius(R, 0.0, ell), rn.bessel_time_to_radius(R, ell),
                           rtol=1e-10, atol=1e-12)
    small = rn.bessel_time_to_radius(0.5, 1e3)  # R << ell: R = R0 exp(t / 2)
    assert small == pytest.approx(2 * math.log(0.5 / radial.R0), rel=1e-6)
    late = np.diff(rn.bessel_time_to_radius(np.array([1e4, 2e4]), 5.0))[0]
    assert 1e4 / late == pytest.approx(5.0, rel=1e-3)  # R >> ell: speed ell


def test_a_long_penetration_length_gives_the_model_without_nutrients():
    """As ell -> inf, t(R) -> continuum.radial's at the same lam, the error falling as ell^-2."""
    R, lam = 8.0, 1e-2
    exact = radial.time_to_radius(R, lam)
    errors = [abs(rn.time_to_radius(R, lam, ell) - exact) for ell in (40.0, 80.0, 160.0)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.05), orders


@pytest.mark.parametrize("R_dish", [None, 90.0])
def test_the_profile_solves_the_boundary_value_problem(R_dish):
    """ell^2 Laplace c = exp(-lam p) f(c): central differences of the profile miss it by O(h^2)."""
    lam, ell, K, R = 1e-2, 10.0, 0.5, 30.0
    misses = []
    for n in (751, 1501):
        state = rn.solve(R, lam, ell, K, R_dish, n=n)
        r, c, h = state.r, state.c, state.r[1] - state.r[0]
        lap = (c[2:] - 2 * c[1:-1] + c[:-2]) / h**2 + (c[2:] - c[:-2]) / (2 * h * r[1:-1])
        misses.append(np.max(np.abs(ell**2 * lap - state.growth(lam, K)[1:-1])))
    assert math.log2(misses[0] / misses[1]) == pytest.approx(2.0, abs=0.05)
    assert misses[1] < 1e-5


def test_in_a_dish_the_area_grows_as_the_agar_supplies():
    """dA/dt = 2 pi R U = 2 pi ell^2 (1 - c_R) / ln(R_dish / R), with c_R < 1."""
    lam, ell, K, R, R_dish = 1e-2, 10.0, 0.5, 50.0, 200.0
    state = rn.solve(R, lam, ell, K, R_dish)
    assert 0 < state.c_edge < 1
    assert 2 * math.pi * R * state.speed == pytest.approx(
        2 * math.pi * ell**2 * (1 - state.c_edge) / math.log(R_dish / R), rel=1e-10)
    edge = rn.solve(R, lam, ell, K)  # a dish just beyond the colony: the edge supply
    near = rn.solve(R, lam, ell, K, R * (1 + 1e-7))
    assert near.speed == pytest.approx(edge.speed, rel=1e-5)
    assert edge.speed > state.speed


def test_the_third_regime_in_a_dish_is_diffusive():
    """Late in a dish R ~ t^(1/2): the area's rate falls as the agar's supply, 1/ln(R_dish/R)."""
    ell, R_dish = 5.0, 400.0
    t_dish, t_edge = (rn.time_to_radius(12.0, 0.0, ell, R_dish=d) for d in (24.0, None))
    assert t_dish > t_edge > 0  # the agar's supply is slower than the reservoir's
    rates = [2 * math.pi * R * rn.radius_rate(R, 0.0, ell, R_dish=R_dish) for R in (40.0, 80.0)]
    bound = [2 * math.pi * ell**2 / math.log(R_dish / R) for R in (40.0, 80.0)]
    assert all(0.9 * b < a < b for a, b in zip(rates, bound, strict=True))


@pytest.mark.parametrize("args,match", [((10.0, 0.0, 0.0), "ell"), ((10.0, -1.0, 5.0), "lam"),
                                        ((10.0, 0.0, 5.0, 0.0), "K"),
                                        ((10.0, 0.0, 5.0, math.inf, 5.0), "dish")])
def test_bad_input_is_refused(args, match):
    with pytest.raises(ValueError, match=match):
        rn.solve(*args)
