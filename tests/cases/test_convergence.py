"""``colony case convergence`` (cases/studies/convergence.py).

1. Observed orders on small continuum cases (as scikit-fem's convergence tests: the fitted slope
   within a stated band of the expected one), the runs of the smoke sizes taken by
   ``cases.sweep.run_one`` from the runs folder of the smoke scale's sweep (item 2, made once
   for the module; run_one would make a missing one): the mesh (R(t), max pressure: 2 +- 0.35;
   G: at least 0.8, the nodal velocity's O(h)), the time step at a fixed mesh (Heun: 2 +- 0.4,
   against the smallest courant), the bump width (the transported mean length against its
   delta limit: 1 +- 0.2) and the length cells of the transport by labels (2 +- 0.4).
2. The smoke scale end to end (``compute`` through the Dask sweep, ``plot``): orders.csv's
   columns and rows, the CSVs behind the curves, the figures.
3. The exact references of the study: the ellipse's axes from its area moments, the lam = 0
   ellipse ODE against a circle and the area growth exp(t).
4. The committed medium data (cases/data/convergence) redraws.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest

from cases import analysis as A
from cases.studies import convergence as C
from cases.sweep import run_engine, run_name, run_one
from tests.pictures import assert_figures


def _family(study: str) -> C.Family:
    return next(f for f in C.families("smoke") if f.study == study)


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """``compute("smoke")`` once for the module: (its data folder, its runs folder)."""
    out = tmp_path_factory.mktemp("convergence")
    return C.compute("smoke", out, n_workers=2), out / "runs"


def _runs(fam: C.Family, case, root) -> list:
    cfg = C.SCALES["smoke"]
    folders = []
    for value in fam.values:
        params = C.continuum_params(cfg, fam, case, value)
        folders.append(run_one(run_engine, params, root / run_name(params)))
    return folders


def test_mesh_orders(smoke):
    fam = _family("mesh")
    errors = [C.continuum_errors(f) for f in _runs(fam, 1e-2, smoke[1])]
    h = [e["h0"] for e in errors]
    assert h[0] > h[1] > h[2]
    for q in ("radius", "max_pressure"):
        order = C.fit_order(h, [e[q] for e in errors])
        assert abs(order - 2.0) < 0.35, (q, order, errors)
    assert C.fit_order(h, [e["G"] for e in errors]) > 0.8


def test_time_step_order_at_a_fixed_mesh(smoke):
    fam = _family("time_step")
    folders = _runs(fam, 1e-2, smoke[1])
    runs = [C.continuum_errors(f) for f in folders]
    assert len({r["n_remesh"] for r in runs}) == 1
    diffs = C._continuum_differences(runs, folders)
    courant = np.asarray(fam.values[:-1])
    for q in ("radius", "max_pressure", "G"):
        order = C.fit_order(courant, [d[q] for d in diffs[:-1]])
        assert abs(order - 2.0) < 0.4, (q, order, diffs)


def test_psi_orders(smoke):
    fam = _family("bump_width")
    errors = [C.continuum_errors(f, mask_width=max(fam.values)) for f in _runs(fam, 1e-2,
                                                                                smoke[1])]
    order = C.fit_order(fam.values, [e["mean_length"] for e in errors])
    assert abs(order - 1.0) < 0.2, (order, errors)
    fam = _family("length_cells:characteristics-labels")
    errors = [C.continuum_errors(f) for f in _runs(fam, 1e-2, smoke[1])]
    order = C.fit_order(1.0 / np.asarray(fam.values), [e["mean_length_transport"]
                                                       for e in errors])
    assert abs(order - 2.0) < 0.4, (order, errors)


def test_smoke_end_to_end(smoke, tmp_path):
    data = smoke[0]
    with (data / "orders.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert set(C.ORDER_COLUMNS) <= set(rows[0])
    assert {r["engine"] for r in rows} == {"continuum", "particles"}
    studies = {r["study"] for r in rows}
    assert {"mesh", "time_step", "bump_width", "length_cells:characteristics-labels", "dt",
            "tol"} <= studies
    assert not any(s in studies for s in ("length_cells:finite-volume",
                                          "length_cells:characteristics"))
    for r in rows:
        assert (r["expected_order"] == "") == ((r["study"], r["quantity"]) not in C.EXPECTED)
        if r["engine"] == "particles":
            assert float(r["seed_spread"]) >= 0 and r["resolved"] in ("yes", "no")
    for name in ("continuum_mesh_lam=0.01.csv", "continuum_time_step_ellipse.csv",
                 "particles_dt.csv", "particles_seeds.csv"):
        assert (data / name).is_file()
    paths = C.plot(data, tmp_path / "fig")
    assert {p.name for p in paths} >= {"convergence_continuum.png", "convergence_particles.png"}


def test_plot_from_committed_data(tmp_path):
    """`colony case convergence --from-data` redraws from cases/data/convergence alone."""
    from pathlib import Path

    import cases

    data = Path(cases.__file__).parent / "data" / "convergence"
    assert (data / "README.md").is_file()
    paths = C.plot(data, tmp_path)
    assert_figures(paths)
    assert "| mesh | radius | lam=0.01 |" in (tmp_path / "orders.md").read_text()


def test_a_particle_panel_without_positive_differences_says_so(tmp_path):
    """Differences all zero (or no seed spread): no empty log axes, no matplotlib warning."""
    import shutil
    import warnings
    from pathlib import Path

    import cases

    data = tmp_path / "data"
    shutil.copytree(Path(cases.__file__).parent / "data" / "convergence", data)
    table = A.read_csv(data / "particles_tol.csv")
    for q in C.PARTICLE_QUANTITIES:
        table[f"diff_{q}"] = np.zeros_like(table[f"diff_{q}"])
    A.write_csv(data / "particles_tol.csv", table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        paths = C.plot(data, tmp_path / "fig")
    assert any(p.name == "convergence_particles.png" for p in paths)
