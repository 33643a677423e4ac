"""``colony case strains`` (issue 32), run small: both engines, the CSVs, the figure.

At the smoke scale (particle colonies of 16-30 cells) only the continuum's direction of change is
asserted: a stress-insensitive mutant sector (lam = 0) in a lam = 1e-2 colony gains area, a
lam = 1e-2 sector in a lam = 0 colony loses it, and in the uniform mixture the stress-sensitive
strain's share falls (each material point's composition follows its strains' growth).
"""

import numpy as np
import pytest

from cases import analysis as A
from cases import cli
from cases.studies import strains


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    out = tmp_path_factory.mktemp("strains")
    assert cli.main(["case", "strains", "--scale", "smoke", "--out", str(out)]) == 0
    return out


def test_the_case_writes_both_engines_and_its_figure(case):
    t = A.read_csv(case / "data" / "strains.csv")
    cfg = strains.SCALES["smoke"]
    per_scenario = cfg["frames"] * (1 + cfg["seeds"])
    assert t["tau"].size == len(strains.SCENARIOS) * per_scenario
    assert set(t["engine"]) == {0, 1}
    assert (case / "strains.png").is_file() and "| mutant | particles |" in (
        case / "results.md").read_text()
    p = A.read_csv(case / "data" / "profiles.csv")
    assert np.all((p["fraction"][np.isfinite(p["fraction"])] >= 0)
                  & (p["fraction"][np.isfinite(p["fraction"])] <= 1))


def test_the_continuum_mutant_gains_and_the_reverse_loses(case):
    t = A.read_csv(case / "data" / "strains.csv")
    cont = t["engine"] == 0
    first = {}
    last = {}
    for i, name in enumerate(strains.SCENARIOS):
        sel = cont & (t["scenario"] == i)
        first[name] = t["fraction"][sel][np.argmin(t["tau"][sel])]
        last[name] = t["fraction"][sel][np.argmax(t["tau"][sel])]
    assert first["mutant"] == pytest.approx(1 / 8, abs=0.01)  # the sector's pi/4 of the disc
    assert last["mutant"] > first["mutant"] + 0.003
    assert last["reverse"] < first["reverse"] - 0.003
    assert first["mixture"] == pytest.approx(0.5, abs=1e-12) and last["mixture"] < 0.499


def test_bad_scale_is_refused():
    with pytest.raises(ValueError, match="scale must be one of"):
        strains.compute("huge", "/nonexistent")


def test_the_committed_data_redraw_and_hold_the_table(tmp_path):
    """``--from-data``: the curves and the table from cases/data/strains (no colony snapshots)."""
    assert cli.main(["case", "strains", "--from-data", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "results.md").read_text()
    assert "| mutant | continuum | 1 | 3.89 |" in text and (tmp_path / "strains.png").is_file()


def test_strain_runs_are_one_command_in_both_engines(colony, tmp_path):
    """``--strains`` and ``--layout``: both engines' run folders carry the strains."""
    import csv
    import json

    import meshio

    for engine in ("continuum", "particles"):
        out = tmp_path / engine
        status, _ = colony(engine, "--lam", "1e-2", "--radius", "6", "--shape", "circle:3",
                           "--strains", "1e-2,0:0.5", "--layout", "sector:1.57", "--out",
                           str(out), "--quiet")
        assert status == 0
        config = json.loads((out / "config.json").read_text())
        assert config["layout"] == "sector:1.57" and len(config["strains"]) == 2
    frame = meshio.read(sorted((tmp_path / "continuum" / "fields").glob("*.vtu"))[-1])
    assert 0 < frame.point_data["phi_1"].mean() < 0.5
    with open(tmp_path / "particles" / "particles.csv") as fh:
        strain = [int(float(r["strain"])) for r in csv.DictReader(fh)]
    assert 0 < sum(strain) < len(strain)


@pytest.mark.parametrize(("args", "needle"), [
    (("--layout", "sector:1"), "needs two or more strains"),
    (("--strains", "1e-2,0", "--layout", "sector:9"), "sector angle theta must lie in"),
    (("--strains", "1e-2,0", "--layout", "mixture:0.5,0.6"), "sum to 1"),
    (("--strains", "1e-2,0,0", "--layout", "sector:1"), "has 2 strains, the colony 3"),
])
def test_bad_strain_runs_fail_in_one_line_before_any_work(colony, tmp_path, args, needle):
    for engine in ("continuum", "particles"):
        out = tmp_path / engine
        status, err = colony(engine, "--lam", "1e-2", "--radius", "6", *args, "--out", str(out))
        assert status == 2 and needle in err and err.count("\n") == 1, err
        assert not out.exists()
