"""The particle engine's nutrient fed at the colony's edge (particles.nutrients; issue 56)."""

import json
import math

import numpy as np
import pytest

import particles
from particles.nutrients import nutrient_at_cells, uptake


def packed_disc(radius: float, spacing: float):
    """Cells on a square lattice filling a disc, each of area spacing^2 (occupancy 1)."""
    g = np.arange(-radius, radius + spacing / 2, spacing)
    X, Y = np.meshgrid(g, g)
    inside = X**2 + Y**2 < radius**2
    x, y = X[inside], Y[inside]
    return x, y, np.full(len(x), spacing**2 / particles.geometry.B)


def bessel_c(r, R, ell):
    """The solution c = I0(r/ell) / I0(R/ell) of ell^2 Laplace c = c in a disc, 1 on its edge."""
    from scipy.special import i0e

    return i0e(r / ell) / i0e(R / ell) * np.exp((r - R) / ell)


def test_a_packed_disc_takes_up_as_the_bessel_solution():
    """At lam = 0, K = inf, a fully packed disc: the grid's c tends to I0(r/ell)/I0(R/ell).

    Away from the edge the error falls at first order in h (the edge is resolved to a node).
    """
    R, ell = 10.0, 3.0
    x, y, length = packed_disc(R, 0.25)
    r = np.hypot(x, y)
    interior = r < R - 2.0
    errors = []
    for h in (1.0, 0.5, 0.25):
        c = nutrient_at_cells(x, y, length, np.ones(len(x)), ell, math.inf, h)
        errors.append(np.max(np.abs(c - bessel_c(r, R, ell))[interior]))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 0.02 and np.all(orders > 0.9), (errors, orders)


def test_monod_uptake_is_solved_to_newtons_tolerance():
    """K = 0.5: Newton's fixed point; c between 0 and 1, lower where uptake is stronger."""
    x, y, length = packed_disc(8.0, 0.25)
    c_first = nutrient_at_cells(x, y, length, np.ones(len(x)), 3.0, math.inf, 0.5)
    c_monod = nutrient_at_cells(x, y, length, np.ones(len(x)), 3.0, 0.5, 0.5)
    assert np.all((0 < c_monod) & (c_monod <= 1))
    assert np.all(c_monod <= c_first + 1e-12)  # f(c) >= c for c <= 1: more uptake
    assert uptake(np.array([1.0]), 0.5)[0] == pytest.approx(1.0)


def test_nutrients_slow_the_colony_and_a_longer_ell_less():
    times = {}
    for ell in (None, 6.0, 3.0):
        sim = particles.run(particles.Config(lam=1e-3, radius=8.0, seed=1, threads=1,
                                             nutrient_length=ell))
        times[ell] = sim.state.t
    assert times[None] < times[6.0] < times[3.0], times


def test_a_resumed_nutrient_run_equals_an_uninterrupted_one(tmp_path):
    config = particles.Config(lam=1e-2, radius=5.0, seed=2, threads=1, nutrient_length=3.0,
                              monod_k=0.5, output_every=0.5)
    for name in ("one", "two"):
        (tmp_path / name).mkdir()
    particles.run(config, tmp_path / "one")
    assert not particles.run(config, tmp_path / "two", max_steps=30).finished
    particles.run(config, tmp_path / "two")
    for name in ("history.csv", "particles.csv", "trajectory.gsd", "config.json"):
        assert (tmp_path / "two" / name).read_bytes() == (tmp_path / "one" / name).read_bytes()
    saved = json.loads((tmp_path / "one" / "config.json").read_text())
    assert saved["nutrient_length"] == 3.0 and saved["monod_k"] == 0.5


def test_without_nutrients_config_json_is_as_before(tmp_path):
    particles.run(particles.Config(lam=1e-2, radius=1.5, threads=1), tmp_path)
    saved = json.loads((tmp_path / "config.json").read_text())
    assert not {"nutrient_length", "monod_k", "nutrient_grid"} & set(saved)


@pytest.mark.parametrize("kw,match", [
    (dict(nutrient_length=0.0), "nutrient_length must be a positive finite number"),
    (dict(nutrient_length=math.inf), "finite"),
    (dict(nutrient_length=math.nan), "finite"),
    (dict(nutrient_length=3.0, monod_k=-1.0), "monod_k must be positive"),
    (dict(monod_k=1.0), "monod_k = 1 needs nutrient_length"),
    (dict(nutrient_grid=0.5), "nutrient_grid = 0.5 needs nutrient_length"),
    (dict(nutrient_length=3.0, nutrient_grid=0.0), "nutrient_grid must be in"),
    (dict(nutrient_length=3.0, nutrient_grid=5.0), "nutrient_grid must be in"),
])
def test_bad_nutrient_settings_are_refused_in_one_line(kw, match):
    with pytest.raises(ValueError, match=match) as err:
        particles.Config(lam=1e-2, radius=3.0, **kw)
    assert "\n" not in str(err.value)


def test_a_checkpoint_of_another_nutrient_setting_is_refused(tmp_path):
    particles.run(particles.Config(lam=1e-2, radius=4.0, threads=1, nutrient_length=3.0),
                  tmp_path, max_steps=5)
    with pytest.raises(ValueError, match="nutrient_length"):
        particles.run(particles.Config(lam=1e-2, radius=4.0, threads=1, nutrient_length=4.0),
                      tmp_path)
