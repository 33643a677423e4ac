"""Strain rate of the Darcy flow: E = (grad u + grad u^T) / 2 of u = -grad p (issue 31, part 2).

A rod carried by a flow turns toward the axis of largest extension of E, so E is the continuum's
side of the particles' orientational order (:mod:`cases.analysis.orientation`). At the nodes of
the mesh, from the nodal velocity u of the state:

- grad u on every triangle from the P1 interpolant of u (constant per element), averaged to the
  nodes weighted by the triangle areas (the patch average, as continuum.velocity's recovery
  without SPR), so E_n = sum_T A_T E_T / sum_T A_T over the triangles T around node n (A_T
  the area of T);
- in polar coordinates about the centre c (default: the area centroid of the mesh), with
  e_r = (x - c) / norm(x - c) and e_t = z x e_r::

      e_rr = e_r . E e_r,   e_tt = e_t . E e_t,   e_rt = e_r . E e_t,

  their difference ``e_rr - e_tt`` (the anisotropy of the expansion; div u = e_rr + e_tt = g),
  the principal shear rate ``shear = sqrt((e_rr - e_tt)^2 + 4 e_rt^2)`` (difference of the two
  eigenvalues of E) and the angle of the extension axis (largest eigenvalue) from the radial
  direction, ``axis_angle = 0.5 atan2(2 e_rt, e_rr - e_tt)`` in (-pi/2, pi/2] (0: radial,
  +-pi/2: azimuthal).

The radial solution (continuum.radial: u(r) = 4 c r / D(r), D = 1 + lam c (R^2 - r^2)) has
(:func:`radial_strain_rate`) ::

    e_tt = u / r = 4 c / D,   e_rr = du/dr = 4 c / D + 8 lam c^2 r^2 / D^2,
    e_rr - e_tt = 8 lam c^2 r^2 / D^2 >= 0,

zero at lam = 0 (u = r/2: isotropic expansion, no preferred axis) and at the centre, largest
at the edge, where it is (w - 1) / (w + 1) with w = sqrt(1 + lam R^2 / 2): extension is radial,
compression azimuthal, and rods are turned toward the radius at a rate (e_rr - e_tt) / 2
(Jeffery's rate of a long rod, 2D). Numbers only (no plotting): continuum.output writes these
fields into every VTU frame (:data:`FIELDS`).

Accuracy (tests/continuum/test_strain_rate.py, disc R = 10, lam = 1e-2, against the closed form).
With the P2 pressure (``element="P2"``: u = -grad p_h is O(h^2) at the vertices) E converges at
the nodes, root-mean-square error O(h^1.2) (the boundary's O(h) dominates; the interior is
exact for lam = 0). With the default P1 pressure u is the recovered gradient, and a gradient of
a recovered gradient (a Hessian of p_h) does not converge pointwise on an unstructured mesh:
the nodal error stays about 1e-3 (a few % of the edge's e_rr - e_tt at lam = 1e-2, R = 10)
however fine the mesh; averages over annuli are unaffected.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from continuum import radial
from continuum.rings import area_centroid

__all__ = ["FIELDS", "velocity_gradient", "strain_rate", "strain_rate_fields",
           "radial_strain_rate"]

#: The point fields of :func:`strain_rate_fields` (continuum.output adds them to every frame).
FIELDS = ("e_xx", "e_yy", "e_xy", "e_rr", "e_tt", "e_rt", "e_rr_minus_e_tt", "shear",
          "axis_angle")


def velocity_gradient(points: NDArray, triangles: NDArray, u: NDArray) -> NDArray:
    """Nodal velocity gradient L_ij = d u_i / d x_j, (N, 2, 2), by area-weighted patch average.

    On each triangle the P1 interpolant of u has the constant gradient
    L_T = sum_a u_a (grad lambda_a)^T (lambda_a the barycentric coordinates); the node's value is
    sum_T A_T L_T / sum_T A_T over its triangles of areas A_T (O(h^2) at interior nodes of
    smooth meshes, O(h) at the boundary).
    """
    points = np.asarray(points, dtype=float)
    tris = np.asarray(triangles, dtype=np.int64)
    u = np.asarray(u, dtype=float)[:, :2]
    p = points[tris]                                   # (M, 3, 2)
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]    # twice the signed area
    # gradients of lambda_1, lambda_2 (rows of the inverse Jacobian), lambda_0 = -sum
    g1 = np.column_stack([d2[:, 1], -d2[:, 0]]) / det[:, None]
    g2 = np.column_stack([-d1[:, 1], d1[:, 0]]) / det[:, None]
    grads = np.stack([-(g1 + g2), g1, g2], axis=1)     # (M, 3, 2)
    L_T = np.einsum("mai,maj->mij", u[tris], grads)    # (M, 2, 2)
    area = 0.5 * np.abs(det)
    n = len(points)
    idx = tris.ravel()
    w = np.repeat(area, 3)
    patch = np.bincount(idx, weights=w, minlength=n)
    L = np.empty((n, 2, 2))
    for i in range(2):
        for j in range(2):
            L[:, i, j] = np.bincount(idx, weights=w * np.repeat(L_T[:, i, j], 3), minlength=n)
    return L / np.where(patch > 0, patch, 1.0)[:, None, None]


def strain_rate(points: NDArray, triangles: NDArray, u: NDArray) -> NDArray:
    """Nodal strain rate E = (L + L^T) / 2, (N, 2, 2), L of :func:`velocity_gradient`."""
    L = velocity_gradient(points, triangles, u)
    return 0.5 * (L + np.swapaxes(L, 1, 2))


def strain_rate_fields(points: NDArray, triangles: NDArray, u: NDArray,
                       center: ArrayLike | None = None) -> dict[str, NDArray]:
    """The point fields :data:`FIELDS` of the strain rate of the nodal velocity u.

    Cartesian e_xx, e_yy, e_xy; polar e_rr, e_tt, e_rt about ``center`` (default: the area
    centroid of the mesh, :func:`continuum.rings.area_centroid`); e_rr_minus_e_tt; shear (eigenvalue
    difference); axis_angle of the extension axis from the radial direction, radians in
    (-pi/2, pi/2]. At the centre itself the polar frame is that of the x axis.
    """
    points = np.asarray(points, dtype=float)
    E = strain_rate(points, triangles, u)
    if center is None:
        center = area_centroid(points, triangles)
    d = points - np.asarray(center, dtype=float)
    phi = np.arctan2(d[:, 1], d[:, 0])
    c, s = np.cos(phi), np.sin(phi)
    exx, eyy, exy = E[:, 0, 0], E[:, 1, 1], E[:, 0, 1]
    err = c * c * exx + 2 * c * s * exy + s * s * eyy
    ett = s * s * exx - 2 * c * s * exy + c * c * eyy
    ert = c * s * (eyy - exx) + (c * c - s * s) * exy
    diff = err - ett
    return {"e_xx": exx, "e_yy": eyy, "e_xy": exy, "e_rr": err, "e_tt": ett, "e_rt": ert,
            "e_rr_minus_e_tt": diff, "shear": np.hypot(diff, 2.0 * ert),
            "axis_angle": 0.5 * np.arctan2(2.0 * ert, diff)}


def radial_strain_rate(r: ArrayLike, R: float, lam: float) -> dict[str, NDArray]:
    """Closed-form e_rr, e_tt and e_rr - e_tt of the radial solution at 0 <= r <= R.

    e_tt = u/r = 4 c / D, e_rr - e_tt = 8 lam c^2 r^2 / D^2, e_rr their sum (module
    docstring; c = c(R) of continuum.radial, D = 1 + lam c (R^2 - r^2)).
    """
    r = np.asarray(r, dtype=float)
    if np.any(r < 0) or np.any(r > R * (1 + 1e-12)):
        raise ValueError("radial positions must satisfy 0 <= r <= R")
    c = radial.c_of_R(R, lam)
    D = 1.0 + lam * c * (R * R - r * r)
    ett = 4.0 * c / D
    diff = 8.0 * lam * c * c * r * r / (D * D)
    return {"e_rr": ett + diff, "e_tt": ett, "e_rr_minus_e_tt": diff}
