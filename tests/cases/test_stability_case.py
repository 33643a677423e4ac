"""`colony case stability` (cases.studies.stability) at smoke scale and from its committed data."""

from pathlib import Path

import numpy as np
import pytest

import cases
from cases import analysis as A
from cases.studies import stability

DATA = Path(cases.__file__).parent / "data" / "stability"


def test_smoke_case(tmp_path):
    """K = 3 at lam = 0 and 1e-2 on a disc of radius 10, 300 and 600 nodes, t in [0, 0.4].

    The measured rates are within 1.5 % of the theory at the finer mesh, and at lam = 1e-2 the
    theory (-1.270, 15 % away from -K/2 = -1.5) is the one they follow.
    """
    data = stability.compute(scale="smoke", out=tmp_path)
    paths = stability.plot(data, tmp_path)
    assert all(p.exists() and p.stat().st_size > 1000 for p in paths)
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
    assert paths and all(p.stat().st_size > 1000 for p in paths)
