"""``colony case shapes`` at smoke scale, end to end (both engines, the hand-off, the figure)."""

import subprocess
import sys

import numpy as np
import pytest

from cases import analysis as A
from cases.studies import shapes as S
from tests.pictures import assert_drawn


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """The case at smoke scale by its command, ``--quiet``: it prints nothing on stderr.

    (Dask's cluster once logged 13 INFO lines there: issue 54.)
    """
    out = tmp_path_factory.mktemp("shapes") / "case"
    done = subprocess.run([sys.executable, "-m", "cases.cli", "case", "shapes", "--quiet",
                           "--workers", "1", "--out", str(out)], capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    return out / "data", out


def test_columns_and_files(smoke):
    data, out = smoke
    names = ["ellipse", "rectangle", "star3", "star5", "line", "handoff"]
    for name in names:
        s = A.read_csv(data / f"shape_{name}.csv")
        assert list(s) == list(S.COLUMNS)
        assert set(s["engine"]) == {0.0, 1.0}
        o = A.read_csv(data / f"outlines_{name}.csv")
        assert list(o) == ["engine", "t", "x", "y"]
    d = A.read_csv(data / "differences.csv")
    assert {"shape", "t", "area_rel", "aspect", "mode2", "mode6"} <= set(d)
    assert set(d["shape"]) == set(range(len(names)))
    paths = S.plot(data, out / "fig")
    assert (out / "fig" / "results.md").read_text().count("| ellipse |") == 2
    assert all(p.is_file() for p in paths)


def test_initial_areas_agree_within_packing(smoke):
    """At t = 0 the fill's area is the outline's up to the packing of rods at its edge."""
    data, _ = smoke
    d = A.read_csv(data / "differences.csv")
    for i in (0, 2, 3):  # ellipse, star3, star5 (the thin rectangle and the line are narrower)
        first = np.flatnonzero(d["shape"] == i)[0]
        assert d["t"][first] == 0.0
        assert abs(d["area_rel"][first]) < 0.1, (i, d["area_rel"][first])
    handoff = np.flatnonzero(d["shape"] == 5)[0]  # the continuum starts from the alpha shape
    assert abs(d["area_rel"][handoff]) < 0.1


def test_ellipse_relaxes_in_both_engines(smoke):
    data, _ = smoke
    s = A.read_csv(data / "shape_ellipse.csv")
    for engine in (0, 1):
        aspect = s["aspect"][s["engine"] == engine]
        assert abs(aspect[0] - 2.0) < 0.05
        assert 1.0 < aspect[-1] < aspect[0] - 0.1, (engine, aspect)


def test_bad_input():
    with pytest.raises(ValueError, match="scale"):
        S.compute("huge")
    with pytest.raises(ValueError, match="both"):
        S.compute("smoke", engines=("continuum",))


def test_radial_outline_drops_notches_only():
    """A star keeps every vertex and its exact mode; a small notch is dropped, a bay is not."""
    from continuum import shapes

    star = shapes.outline("star:3,0.2,7")
    assert len(S.radial_outline(star)) == len(star)
    assert abs(S.outline_measures(star)["mode3"] - 0.2) < 1e-3  # linear r(theta): O(h^2)
    notch = star.copy()
    notch[10] = notch[9] + 0.3 * (notch[9] - notch[11])  # turns back by ~0.01 rad
    kept = S.radial_outline(notch)
    assert kept is not None and len(kept) == len(star) - 1
    assert abs(S.outline_measures(notch)["mode3"] - 0.2) < 2e-3
    th = np.linspace(0.0, 1.5 * np.pi, 100)  # a thick horseshoe: rays cross it twice
    horseshoe = np.vstack([np.column_stack([2 * np.cos(th), 2 * np.sin(th)]),
                           np.column_stack([np.cos(th[::-1]), np.sin(th[::-1])])])
    assert S.radial_outline(horseshoe) is None
    assert np.isnan(S.outline_measures(horseshoe)["mode2"])

def test_committed_medium_data(tmp_path, colony):
    """`colony case shapes --from-data` redraws from cases/data/shapes; the ellipse relaxes."""
    from pathlib import Path

    data = Path(S.__file__).parents[1] / "data" / "shapes"
    assert (data / "README.md").is_file()
    status, err = colony("case", "shapes", "--from-data", "--out", str(tmp_path))
    assert status == 0, err
    assert_drawn(tmp_path / "shapes.png")
    s = A.read_csv(data / "shape_ellipse.csv")
    for engine in (0, 1):
        aspect = s["aspect"][s["engine"] == engine]
        assert aspect[-1] < 1.2 < 1.9 < aspect[0]
