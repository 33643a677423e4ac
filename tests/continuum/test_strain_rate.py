"""Strain rate of the Darcy flow (continuum.strain_rate) against exact answers, with its order."""

import math

import meshio
import numpy as np
import pytest

from continuum import radial, strain_rate
from continuum.mesh import circle_polygon, colony_mesh
from continuum.output import FieldWriter
from continuum.rings import area_centroid
from continuum.simulation import Config, Simulation


def _disc(R=5.0, h=0.5):
    points, tris = colony_mesh(circle_polygon(R, int(2 * math.pi * R / h)), h)[:2]
    return points, tris


def test_linear_flow_exact():
    """A linear flow u = L x: E = (L + L^T)/2 at every node to round-off; polar parts too."""
    points, tris = _disc()
    L = np.array([[0.3, -0.7], [0.2, -0.1]])
    f = strain_rate.strain_rate_fields(points, tris, points @ L.T, center=(0.0, 0.0))
    E = 0.5 * (L + L.T)
    assert np.allclose(f["e_xx"], E[0, 0], atol=1e-12)
    assert np.allclose(f["e_yy"], E[1, 1], atol=1e-12)
    assert np.allclose(f["e_xy"], E[0, 1], atol=1e-12)
    # trace and shear are frame invariants
    assert np.allclose(f["e_rr"] + f["e_tt"], np.trace(E), atol=1e-12)
    ev = np.linalg.eigvalsh(E)
    assert np.allclose(f["shear"], ev[1] - ev[0], atol=1e-12)


def test_rotation_and_expansion():
    """Rigid rotation: E = 0. u = x/2 (lam = 0): e_rr = e_tt = 1/2, no anisotropy."""
    points, tris = _disc()
    rot = np.column_stack([-points[:, 1], points[:, 0]])
    f = strain_rate.strain_rate_fields(points, tris, rot)
    assert np.abs(f["shear"]).max() < 1e-12
    f = strain_rate.strain_rate_fields(points, tris, points / 2)
    assert np.allclose(f["e_rr"], 0.5) and np.allclose(f["e_tt"], 0.5)
    assert np.abs(f["e_rr_minus_e_tt"]).max() < 1e-12


def test_radial_closed_form():
    """e_rr = du/dr (finite difference of radial.velocity), e_tt = u/r, edge (w-1)/(w+1)."""
    R, lam = 40.0, 1e-3
    r = np.linspace(0.5, R - 0.5, 9)
    e = strain_rate.radial_strain_rate(r, R, lam)
    d = 1e-5
    dudr = (radial.velocity(r + d, R, lam) - radial.velocity(r - d, R, lam)) / (2 * d)
    assert np.allclose(e["e_rr"], dudr, rtol=1e-8)
    assert np.allclose(e["e_tt"], radial.velocity(r, R, lam) / r, rtol=1e-12)
    w = math.sqrt(1 + lam * R * R / 2)
    assert strain_rate.radial_strain_rate(R, R, lam)["e_rr_minus_e_tt"] == pytest.approx(
        (w - 1) / (w + 1), rel=1e-12)
    zero = strain_rate.radial_strain_rate(r, R, 0.0)
    assert np.allclose(zero["e_rr"], 0.5) and np.allclose(zero["e_rr_minus_e_tt"], 0.0)


def _errors(n, lam=1e-2, R=10.0):
    s = Simulation(Config(lam=lam, shape=f"circle:{R:g}", n_nodes=n, h_max=1e3,
                          write_fields=False, element="P2")).state
    f = strain_rate.strain_rate_fields(s.points, s.triangles, s.u)
    c = area_centroid(s.points, s.triangles)
    r = np.minimum(np.hypot(*(s.points - c).T), s.radius)
    ex = strain_rate.radial_strain_rate(r, s.radius, lam)
    return s.h_mesh, [math.sqrt(np.mean((f[k] - ex[k]) ** 2))
                      for k in ("e_rr", "e_tt", "e_rr_minus_e_tt")]


def test_radial_convergence_order():
    """The solver's own flow (P2 pressure) on a disc R = 10, lam = 1e-2, 1000-8000 nodes.

    Root-mean-square nodal errors of e_rr, e_tt, e_rr - e_tt against the closed form: observed
    order (slope of ln error against ln h) 1.1-1.3 for each (measured: about 1.2), the finest
    error below 1 % of the edge anisotropy (w - 1)/(w + 1) = 0.101.
    """
    hs, errs = zip(*(_errors(n) for n in (1000, 2000, 4000, 8000)), strict=True)
    errs = np.array(errs)
    for k in range(3):
        order = np.polyfit(np.log(hs), np.log(errs[:, k]), 1)[0]
        assert 1.0 < order < 1.5, (k, order, errs[:, k])
    assert errs[-1].max() < 0.01 * 0.101


def test_written_into_frames(tmp_path):
    """FieldWriter adds the FIELDS whenever u is written; u = x/2 gives e_rr = e_tt = 1/2."""
    points, tris = _disc(3.0, 0.6)
    w = FieldWriter(tmp_path)
    path = w.write(0.0, points, tris, {"p": np.zeros(len(points)), "u": points / 2})
    data = meshio.read(path).point_data
    assert set(strain_rate.FIELDS) <= set(data)
    assert np.allclose(data["e_rr"], 0.5) and np.allclose(data["e_rr_minus_e_tt"], 0.0)
