"""The layered (core-shell) radial reference against exact answers (continuum.radial_strains)."""

import numpy as np
import pytest

from continuum import radial
from continuum.radial_strains import Strain, layers, pressure_lam0, radii


@pytest.mark.parametrize("lam", [0.0, 1e-3, 1e-2])
def test_identical_strains_are_the_one_strain_reference(lam):
    R = 30.0
    L = layers([12.0, 21.0, R], [Strain(lam)] * 3)
    r = np.linspace(0.0, R, 301)
    pmax = radial.max_pressure(R, lam)
    np.testing.assert_allclose(L.pressure(r), radial.pressure(r, R, lam), rtol=0,
                               atol=1e-9 * pmax)
    np.testing.assert_allclose(L.velocity(r[1:]), radial.velocity(r[1:], R, lam), rtol=1e-8)
    np.testing.assert_allclose(L.velocity_at_radii, radial.velocity([12.0, 21.0, R], R, lam),
                               rtol=1e-9)
    # R(t) and a material circle r(t) of the one-strain colony
    t = np.array([0.0, 0.5, 1.5, 3.0])
    out = radii(t, [1.0, 2.0], [Strain(lam)] * 2)
    np.testing.assert_allclose(out[:, 1], radial.radius(t, lam, R0=2.0), rtol=1e-8)


@pytest.mark.parametrize("growth", [(1.0, 0.5), (0.7, 1.3), (1.0, 2.0, 0.4)])
def test_lam0_rings_grow_exponentially_and_pressure_closed_form(growth):
    a = np.array(growth)
    r0 = np.arange(1, len(a) + 1) * 1.5
    t = np.array([0.0, 0.4, 1.0, 2.0])
    out = radii(t, r0, [Strain(0.0, g) for g in a])
    area0 = np.diff(np.concatenate([[0.0], r0**2]))
    exact = np.sqrt(np.cumsum(area0[None, :] * np.exp(a[None, :] * t[:, None]), axis=1))
    np.testing.assert_allclose(out, exact, rtol=1e-8)
    L = layers(r0, [Strain(0.0, g) for g in a])
    r = np.linspace(0.0, r0[-1], 97)
    np.testing.assert_allclose(L.pressure(r), pressure_lam0(r, r0, a), rtol=0,
                               atol=1e-10 * pressure_lam0([0.0], r0, a)[0])


def test_stress_insensitive_core_pushes_harder():
    """A lam = 0 core in a lam = 1e-2 shell lies between the two one-strain colonies.

    More central pressure and a faster edge than all lam = 1e-2, less than all lam = 0
    (comparison principle).
    """
    r = [10.0, 40.0]
    mixed = layers(r, [Strain(0.0), Strain(1e-2)])
    assert radial.max_pressure(40.0, 1e-2) < mixed.p0 < radial.max_pressure(40.0, 0.0)
    u = mixed.velocity_at_radii[-1]
    assert radial.radius_rate(40.0, 1e-2) < u < radial.radius_rate(40.0, 0.0)


@pytest.mark.parametrize(("args", "match"), [
    (([1.0, 0.5], [Strain(0.0)] * 2), "increasing"),
    (([1.0], [Strain(0.0)] * 2), "one radius per strain"),
    (([-1.0], [Strain(0.0)]), "positive"),
])
def test_bad_input(args, match):
    with pytest.raises(ValueError, match=match):
        layers(*args)


@pytest.mark.parametrize(("kw", "match"), [(dict(lam=-1e-3), "lam"), (dict(lam=0.0, growth=0.0),
                                                                     "growth")])
def test_bad_strain(kw, match):
    with pytest.raises(ValueError, match=match):
        Strain(**kw)
