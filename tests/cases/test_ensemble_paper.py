"""docs/measurements/ensemble_paper.py: seed bands at radius 150 from recorded colonies."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from cases import analysis as A
from continuum import radial
from tests.measurements import measurement

ensemble_paper = measurement("ensemble_paper")

LAM = 0.01


def _seed(profile_path: Path, history_path: Path, speed: float, scale: float) -> None:
    """A record: R = speed t to R = 150, stress scale p(0) (1 - (r/150)^2) (fit exact)."""
    t = np.linspace(0.0, 150.0 / speed, 400)
    A.write_csv(history_path, {"t": t, "radius": speed * t, "mean_stress": np.full(t.size, 1.0)})
    r = 150.0 * np.sqrt((np.arange(60) + 0.5) / 60)
    p0 = radial.max_pressure(150.0, LAM)
    A.write_csv(profile_path, {"r": r, "stress": scale * p0 * (1 - (r / 150.0) ** 2),
                               "mean_length": np.full(r.size, 1.5), "count": np.full(r.size, 50)})


def test_reduce_two_constructed_seeds(tmp_path):
    data = tmp_path / "data"
    (data / "fig3_paper").mkdir(parents=True)
    (data / "particles_paper" / f"lam={LAM:g}").mkdir(parents=True)
    rec = data / "ensemble_paper" / "seed=1" / f"lam={LAM:g}"
    rec.mkdir(parents=True)
    (rec / "config.json").write_text(json.dumps({"lam": LAM}))
    _seed(data / "fig3_paper" / f"profile_particles_lam={LAM:g}.csv",
          data / "particles_paper" / f"lam={LAM:g}" / "history.csv", speed=10.0, scale=1.0)
    _seed(rec / "profile_pooled.csv", rec / "history.csv", speed=7.5, scale=1.1)
    A.write_csv(data / "fig3_paper" / f"radius_continuum_lam={LAM:g}.csv",
                {"t": np.linspace(0, 20, 50), "radius": np.linspace(0.4, 150, 50)})
    records = ensemble_paper.seed_records(data)
    assert list(records) == [LAM] and list(records[LAM]) == [0, 1]
    out = ensemble_paper.reduce(records, tmp_path / "out", data)
    s = A.read_csv(out / "summary.csv")
    assert s["n_seeds"][0] == 2
    assert s["t_at_radius_mean"][0] == pytest.approx(17.5, rel=1e-6)  # 150/10 and 150/7.5
    assert s["rel_central_fit_mean"][0] == pytest.approx(0.05, abs=1e-9)  # 0 and +10 %
    assert s["rel_central_fit_q025"][0] == pytest.approx(0.0025, abs=1e-9)
    p = A.read_csv(out / f"profile_lam={LAM:g}.csv")
    inner = p["r"] < 140
    np.testing.assert_allclose(p["stress_mean"][inner] / p["stress_q975"][inner],
                               1.05 / (1.0 + 0.975 * 0.1), rtol=1e-6)
    assert "| 0.01 | 2 | 17.500 +- " in ensemble_paper.markdown_table(out)


def test_committed_bands_are_what_the_records_give(tmp_path):
    """cases/data/ensemble_paper's reduced files are remade byte for byte from its records."""
    committed = ensemble_paper.DATA / "ensemble_paper"
    out = ensemble_paper.reduce(ensemble_paper.seed_records(), tmp_path / "out")
    names = sorted(p.name for p in out.iterdir())
    assert "summary.csv" in names and f"profile_lam={LAM:g}.csv" in names
    for name in names:
        assert (out / name).read_bytes() == (committed / name).read_bytes(), name
    seeds = len(list(committed.glob(f"seed=*/lam={LAM:g}/profile_pooled.csv"))) + 1
    summary = A.read_csv(out / "summary.csv")
    assert summary["n_seeds"][summary["lam"] == LAM][0] == seeds >= 3
    shutil.rmtree(out)
