"""Reductions of a continuum run folder (its VTU frames, ``rings.csv``) for the figure cases.

The rings are the contours G = k ln 2 of the smooth growth phase (:mod:`continuum.rings`), not
peaks of a binned profile: :func:`frame_rings`, :func:`continuum_rings` (a run's ``rings.csv``
or its last frame), :func:`continuum_wavelength` and :func:`continuum_wavelength_series`
(difference of the two outermost mean ring radii). Radial profiles (:func:`continuum_profile`,
the run's ``profile.csv``; :func:`final_continuum_profile`) give the transported Psi's mean
length and spread of lengths per annulus, with the closed form 2^frac(<G> / ln 2) beside.
The colony radius of a frame is sqrt(A / pi), A the mesh's area (:func:`mesh_radius`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from continuum import rings as _rings
from continuum.mesh import triangle_areas
from continuum.strain_rate import strain_rate_fields

from .io import continuum_frames, read_continuum_frame, read_csv
from .profiles import PSI_FIELDS, field_profile
from .rings import Rings, contour_rings, profile_rings, ring_series

#: Strain-rate columns of a continuum profile (the polar components of continuum.strain_rate).
STRAIN_COLUMNS = ("e_rr", "e_tt", "e_rr_minus_e_tt")

__all__ = [
    "mesh_radius",
    "continuum_wavelength_series",
    "continuum_profile",
    "final_continuum_profile",
    "frame_rings",
    "continuum_rings",
    "continuum_wavelength",
]


def mesh_radius(points: np.ndarray, triangles: np.ndarray) -> float:
    """Colony radius sqrt(A / pi) of a frame, A = sum of the triangles' areas ``|T|``."""
    return math.sqrt(float(np.abs(triangle_areas(points, triangles)).sum()) / math.pi)


def continuum_wavelength_series(folder: str | os.PathLike, edge_width: float = 0.05,
                                **kwargs) -> dict[str, np.ndarray]:
    """Rings and both wavelengths at every VTU frame of a continuum run.

    The contours G = k ln 2 of the growth phase (:func:`frame_rings`) counted by the rule of
    both models (:func:`contour_rings`: inside the colony, not in the edge layer); a frame
    without G (runs older than the G output) falls back to the peaks of the
    :func:`field_profile` of lbar (annuli at most `edge_width` wide at the edge, noise-free;
    `kwargs` to :func:`profile_rings`). Columns of :func:`ring_series`.
    """
    rows = []
    for t, path in continuum_frames(folder):
        pts, tri, data = read_continuum_frame(path)
        R = mesh_radius(pts, tri)
        rows.append((t, R, _frame_rings(pts, tri, data, R, edge_width, **kwargs)))
    return ring_series(rows)


def _frame_rings(pts: np.ndarray, tri: np.ndarray, data: dict, radius: float,
                 edge_width: float, **kwargs) -> Rings:
    """The rings of one frame: its contours of G, else the peaks of its lbar profile."""
    if "G" in data:
        return contour_rings(_rings.ring_table(pts, tri, data["G"]), radius)
    prof = field_profile(pts, tri, {"mean_length": data["mean_length"]}, edge_width=edge_width)
    return profile_rings(prof, radius, noisy=False, **kwargs)


def continuum_profile(points: np.ndarray, triangles: np.ndarray, fields: dict,
                      edge_width: float = 0.05) -> dict[str, np.ndarray]:
    """The radial profile of a continuum state or frame: ``profile.csv`` (:func:`field_profile`).

    ``fields`` the nodal fields (continuum.state.State.fields, or a VTU frame's point data with
    the pressure as ``p``). Columns (each with its ``_std``, the spread over the annulus, but
    where said):

    - r: the radius halving the annulus' area (equal-area annuli, the outermost at most
      ``edge_width`` wide);
    - mean_length: annulus mean of the closed form lbar = 2^frac(G / ln 2) at the nodes;
    - pressure;
    - G: the growth phase; number: the number of cells per area of the transported Psi;
    - mean_length_psi, length_std_psi (no _std): the mean and the standard deviation of the
      lengths of all the cells of the annulus, from the transported Psi (number-weighted; the
      one-sigma band of Fig 4A);
    - mean_length_phase (no _std): the closed form 2^frac(<G> / ln 2) of the annulus mean of G,
      the mean length for Psi0 = delta(l - 1), the check beside mean_length_psi;
    - e_rr, e_tt, e_rr_minus_e_tt: the strain rate of the Darcy flow in polar components about
      the colony's centroid (:func:`continuum.strain_rate.strain_rate_fields`; the frame's fields,
      else from the velocity u), whose difference is the flow's anisotropy;
    - count: samples in the annulus.

    Frames written before a field existed (G, length_std_psi, the strain rate without u) lack
    its columns.
    """
    values = {"mean_length": fields["mean_length"], "pressure": fields["p"]}
    for name in ("G", *PSI_FIELDS):
        if name in fields:
            values[name] = fields[name]
    strain = fields
    if "e_rr" not in fields and "u" in fields:
        strain = strain_rate_fields(points, triangles, np.asarray(fields["u"])[:, :2])
    for name in STRAIN_COLUMNS:
        if name in strain:
            values[name] = strain[name]
    return field_profile(points, triangles, values, edge_width=edge_width)


def final_continuum_profile(folder: str | os.PathLike, edge_width: float = 0.05
                            ) -> dict[str, np.ndarray]:
    """Radial profile of the last VTU frame of a continuum run (:func:`continuum_profile`)."""
    pts, tri, data = read_continuum_frame(continuum_frames(folder)[-1][1])
    return continuum_profile(pts, tri, data, edge_width=edge_width)


def frame_rings(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Ring table (:func:`continuum.rings.ring_table`) of the G field of one VTU frame."""
    pts, tri, data = read_continuum_frame(path)
    if "G" not in data:
        raise ValueError(f"{path}: no growth phase G in the frame")
    return _rings.ring_table(pts, tri, data["G"])


def continuum_rings(folder: str | os.PathLike) -> dict[str, np.ndarray]:
    """Final ring table of a continuum run.

    Its ``rings.csv`` (written by the run) if present, else computed from the G of its last VTU
    frame (the same numbers).
    """
    folder = Path(folder)
    if (folder / "rings.csv").is_file():
        table = read_csv(folder / "rings.csv")
        for key in ("k", "n_pieces"):
            if key in table:
                table[key] = table[key].astype(int)
        return table
    return frame_rings(continuum_frames(folder)[-1][1])


def continuum_wavelength(folder: str | os.PathLike, edge_width: float = 0.05, **kwargs) -> Rings:
    """The final rings of a continuum run, both wavelengths (:class:`Rings`).

    :func:`contour_rings` of :func:`continuum_rings` at the last frame's radius; a run without
    G in its frames falls back to the peaks of the last frame's lbar profile (as
    :func:`continuum_wavelength_series`).
    """
    folder = Path(folder)
    pts, tri, data = read_continuum_frame(continuum_frames(folder)[-1][1])
    R = mesh_radius(pts, tri)
    if (folder / "rings.csv").is_file():
        return contour_rings(continuum_rings(folder), R)
    return _frame_rings(pts, tri, data, R, edge_width, **kwargs)
