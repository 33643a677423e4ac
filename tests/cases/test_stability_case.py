"""`colony case stability` (cases.studies.stability) at smoke scale and from its committed data."""

from pathlib import Path

import numpy as np
import pytest

import cases
from cases import analysis as A
from cases.studies import stability
from tests.pictures import assert_figures

DATA = Path(cases.__file__).parent / "data" / "stability"


def test_smoke_case(tmp_path):
    """K = 3 at lam = 0 and 1e-2 on a disc of radius 10, 300 and 600 nodes, t in [0, 0.4].

    The measured rates are within 1.5 % of the theory at the finer mesh, and at lam = 1e-2 the
    theory (-1.270, 15 % away from -K/2 = -1.5) is the one they follow.
    """
    data = stability.compute(scale="smoke", out=tmp_path)
    paths = stability.plot(data, tmp_path)
    for p in paths:
        assert_figures([p])
    r = A.read_csv(data / "rates.csv")
    fine = r["nodes"] > 500
    assert np.all(np.abs(r["relative_error"][fine]) < 0.015), r["relative_error"]
    lam = fine & (r["lam"] == 1e-2)
    assert r["theory"][lam] == pytest.approx(-1.2701, abs=1e-3)
    assert np.all(np.abs(r["measured"][lam] - r["theory"][lam]) < 0.1 * abs(r["theory"][lam] + 1.5))
    assert (data / "orders.csv").is_file()


def test_plot_from_committed_data(tmp_path):
    """`colony case stability --from-data` redraws from cases/data/stability alone."""
    assert (DATA / "README.md").is_file()
    paths = stability.plot(DATA, tmp_path)
    for p in paths:
        assert_figures([p])
    assert {p.name for p in paths} >= {"stability.png", "particle_modes.png"}


def test_committed_particle_modes():
    """The committed medium particle data: every mode decays in every run (72 runs)."""
    r = A.read_csv(DATA / "particle_rates.csv")
    assert r["measured"].size == 72 and np.all(r["measured"] < 0)
    m = A.read_csv(DATA / "particle_modes.csv")
    assert set(m["K"]) == {2, 3, 4, 5, 6, 8} and set(m["orientation"]) == {0, 1}


def test_particle_smoke(tmp_path):
    """The particle stage alone at smoke scale: star K = 3, eps = 0.2, R = 5, 2 seeds, t <= 0.5.

    One row per seed with the columns of particle_rates.csv; the mode decays in every seed
    (negative rate, end amplitude below the start's and above 3 noise floors); the summary
    holds the theory -K/2 and the continuum from the same star; no continuum rates.csv.
    """
    data = stability.compute(scale="smoke", out=tmp_path, engines=("particles",), n_workers=1)
    r = A.read_csv(data / "particle_rates.csv")
    assert list(r) == ["orientation", "K", "lam", "seed", "radius", "eps", "measured",
                       "measured_late", "amplitude_start", "amplitude_end", "floor_end",
                       "particles_start", "particles_end"]
    assert sorted(r["seed"]) == [1, 2] and np.all(r["K"] == 3)
    assert np.all(r["measured"] < 0), r["measured"]
    assert np.all(r["amplitude_end"] < r["amplitude_start"])
    assert np.all(r["amplitude_end"] > 3 * r["floor_end"])
    assert np.all(r["particles_end"] > r["particles_start"])
    m = A.read_csv(data / "particle_modes.csv")
    assert m["theory"][0] == pytest.approx(-1.5, abs=1e-9)
    assert m["continuum_same_eps"][0] < 0 and m["seeds"][0] == 2
    assert not (data / "rates.csv").exists()
    paths = stability.plot(data, tmp_path)
    assert [p.name for p in paths] == ["particle_modes.png", "particle_modes.pdf"]
    assert "particles late half" in (tmp_path / "results.md").read_text()


def test_bad_engines(tmp_path):
    """An unknown engine is refused before any run."""
    with pytest.raises(ValueError, match="engines"):
        stability.compute(scale="smoke", out=tmp_path, engines=("gas",))
