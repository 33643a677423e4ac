"""``colony case nutrients`` (cases/studies/nutrients.py): its measures against exact answers.

1. The measures on the exact solution of lam = 0, K = inf, supply at the edge (the Bessel
   solution, continuum.radial_nutrients.bessel): the front speed of R(t) sampled from
   t(R) = ln(R I1(R/ell) / (R0 I1(R0/ell))) is ell I1(R/ell) / I0(R/ell) to second order in
   the difference's half-width (observed order asserted); the growth layer's width is the root
   of I0(r/ell) = I0(R/ell) / 2 to second order in the radial spacing.
2. The smoke scale end to end with both engines (about 20 s): the continuum's speed, time and
   growth layer within 1 % of the 1D reference, particle colonies faster with a longer ell and
   the tables and figure written; the committed medium data redrawn (``--from-data``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import i0

from cases import analysis as A
from cases import cli
from cases.studies import nutrients as N
from continuum import radial_nutrients
from continuum.radial import R0
from particles import B


def _order(errors: list[float], steps: list[float]) -> float:
    return math.log(errors[0] / errors[1]) / math.log(steps[0] / steps[1])


def test_front_speed_of_the_bessel_colony_is_second_order_in_the_window():
    ell = 3.0
    R = np.geomspace(R0, 40.0, 20001)
    t = radial_nutrients.bessel_time_to_radius(R, ell)
    radii = np.array([2.0, 5.0, 12.0, 30.0])
    exact = radial_nutrients.bessel(0.0, radii[0], ell)[2], *(
        radial_nutrients.bessel(0.0, x, ell)[2] for x in radii[1:])
    windows = [0.08, 0.04]
    errors = [float(np.max(np.abs(N.front_speed(t, R, radii, w) / exact - 1)))
              for w in windows]
    assert errors[1] < 2e-3
    assert _order(errors, windows) == pytest.approx(2.0, abs=0.25)


def test_crossing_times_take_the_first_crossing_and_nan_beyond_the_run():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    R = np.array([1.0, 3.0, 2.0, 4.0])  # a fluctuating radius: 2.5 is first reached at t = 0.75
    np.testing.assert_allclose(N.crossing_times(t, R, np.array([0.5, 2.5, 3.5, 5.0])),
                               [0.0, 0.75, 2.75, np.nan])


def test_layer_width_of_the_bessel_colony_is_second_order_in_the_spacing():
    """The layer's inner radius r_h, the root of I0(r/ell) = I0(R/ell) / 2, to order h^2.

    By linear interpolation its error is s (1 - s) h^2 |c''| / (2 c') for a root at the
    fraction s of a cell of width h, so R is chosen to put r_h mid-cell (s = 1/2) on grids of
    spacing 1 and 1/3 alike.
    """
    ell, r_h = 4.0, 26.5
    R = brentq(lambda x: i0(x / ell) - 2 * i0(r_h / ell), r_h, 2 * r_h)
    spacings, errors = [1.0, 1.0 / 3.0], []
    for h in spacings:
        r = np.arange(0.0, R, h)
        c = radial_nutrients.bessel(r, R, ell)[0]
        errors.append(abs(N.layer_width(r, c, R) - (R - r_h)))
    assert errors[1] < 0.01
    assert _order(errors, spacings) == pytest.approx(2.0, abs=0.1)
    assert (R - r_h) == pytest.approx(ell * math.log(2), rel=0.1)  # the layer of R >> ell


def test_layer_width_limits():
    r = np.linspace(0.0, 5.0, 6)
    assert N.layer_width(r, np.full(6, 0.9), 5.0) == 5.0  # the whole colony grows
    assert N.layer_width(r, np.full(6, 0.3), 5.0) == 0.0  # not even the edge
    assert math.isnan(N.layer_width(r, np.full(6, np.nan), 5.0))


def test_reference_profile_is_the_bessel_solution_at_lam_0():
    ell, R = 5.0, 20.0
    r = np.linspace(0.0, R, 41)
    ref = N.reference_profile(r, R, 0.0, ell)
    c = radial_nutrients.bessel(r, R, ell)[0]
    np.testing.assert_allclose(ref["c"], c, rtol=1e-4)
    np.testing.assert_allclose(ref["g"], c, rtol=1e-4)  # lam = 0, K = inf: g = c
    np.testing.assert_allclose(ref["stress"], ell**2 * (1 - c), rtol=1e-4, atol=1e-8)


def test_area_radius_of_one_cell_is_the_continuum_start():
    one_cell = {"total_length": np.array([1.0]), "radius": np.array([0.75])}
    assert N.area_radius(one_cell)[0] == pytest.approx(R0)
    assert N.area_radius({"radius": np.array([3.0])})[0] == 3.0
    assert R0 == pytest.approx(math.sqrt(B / math.pi))


def test_run_params_name_the_nutrient_and_reject_unknown_scales():
    p = N.run_params("particles", 10.0, 1e-3, "medium", seed=2)
    assert p["nutrient_length"] == 10.0 and p["radius"] == 40.0 and p["seed"] == 2
    assert "seed" not in N.run_params("continuum", 10.0, 1e-3, "medium")
    with pytest.raises(ValueError, match="scale must be one of"):
        N.run_params("particles", 10.0, 0.0, "huge")


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("nutrients")
    assert cli.main(["case", "nutrients", "--scale", "smoke", "--workers", "1",
                     "--out", str(out), "--quiet"]) == 0
    return out


def test_smoke_continuum_meets_the_reference_and_particles_follow_ell(smoke):
    s = A.read_csv(smoke / "data" / "summary.csv")
    for q in ("speed", "time", "central"):
        np.testing.assert_allclose(s[f"{q}_continuum"], s[f"{q}_reference"], rtol=0.01)
    np.testing.assert_allclose(s["layer_continuum"], s["layer_reference"], rtol=0.05)
    speed = A.read_csv(smoke / "data" / "speed.csv")
    for model in (0, 1, 2):  # every model: a longer ell feeds a faster front, at every lam
        for lam in N.SCALES["smoke"]["lams"]:
            u = [speed["speed"][(speed["model"] == model) & (speed["lam"] == lam)
                                & (speed["ell"] == ell)][-1] for ell in N.SCALES["smoke"]["ells"]]
            assert np.all(np.diff(u) > 0), (model, lam, u)
    assert np.all(s["seeds"] == 1) and np.all(np.isfinite(s["speed_particles"]))
    assert (smoke / "nutrients.png").stat().st_size > 0
    assert "| ell | lam |" in (smoke / "results.md").read_text()


def test_committed_medium_data_redraw_and_the_continuum_is_the_reference(tmp_path):
    """The committed medium data: results.md's table, the continuum on the reference.

    The continuum within 2e-3 of the reference in speed and time at every (ell, lam), the
    particles within 4 %; ``--from-data`` writes the table of docs/results.md.
    """
    data = cli.DATA / "nutrients"
    s = A.read_csv(data / "summary.csv")
    assert len(s["ell"]) == len(N.SCALES["medium"]["ells"]) * len(N.SCALES["medium"]["lams"])
    for q in ("speed", "time"):
        np.testing.assert_allclose(s[f"{q}_continuum"], s[f"{q}_reference"], rtol=2e-3)
        np.testing.assert_allclose(s[f"{q}_particles"], s[f"{q}_reference"], rtol=0.04)
    # the nutrient's own rings at lam = 0, ell = 5: one per division period ln 2 at the
    # front's speed; the starved core's rings move at under 2 % of it
    i = np.flatnonzero((s["ell"] == 5) & (s["lam"] == 0))[0]
    assert s["wavelength_continuum"][i] == pytest.approx(s["speed_reference"][i] * math.log(2),
                                                         rel=0.02)
    assert s["core_drift_continuum"][i] < 0.02 * s["speed_reference"][i]
    assert cli.main(["case", "nutrients", "--from-data", "--out", str(tmp_path)]) == 0
    table = (tmp_path / "results.md").read_text().split("\n", 4)[4]
    assert table in (cli.DATA.parents[1] / "docs" / "results.md").read_text()
    assert (tmp_path / "nutrients.png").stat().st_size > 0
