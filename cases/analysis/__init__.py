"""Shared analysis of both engines' outputs (model.md, "Analysis"), by concept.

Everything works on plain arrays, so the particle engine (samples = particles) and the
continuum solver (samples = points of the mesh) are reduced the same way:

- :mod:`.io`: the runs' files: CSVs, continuum VTU frames, particle trajectory frames;
- :mod:`.profiles`: radial profiles in annuli of equal area (Fig 3A, Fig 4A);
- :mod:`.rings`: ring peaks and wavelengths, ring coherence, contour wavelengths (Fig 4);
- :mod:`.statistics`: late-time slope, maxima, power-law fits, the E. coli estimate (Fig 3);
- :mod:`.continuum_runs`, :mod:`.particle_runs`: reductions of one engine's run folder
  (wavelength at every frame, final profile, final rings) used by the figure cases.

The closed-form radial solution (analytic curves of Fig 3) is :mod:`continuum.radial`; the growth
law and lbar = 2^frac(G / ln 2) are :mod:`continuum.growth`; the particle colony's centroid and
radius are :mod:`particles.measures`. The names below are re-exported here (``from cases import
analysis as A``; ``A.read_csv``), each defined once in its module.
"""

from .continuum_runs import (
    continuum_rings,
    continuum_wavelength,
    continuum_wavelength_series,
    final_continuum_profile,
    frame_rings,
    mesh_radius,
)
from .io import (
    continuum_frames,
    markdown_rows,
    particle_frames,
    read_continuum_frame,
    read_csv,
    thin_rows,
    write_csv,
)
from .particle_runs import final_particle_profile, final_ring_coherence, particle_wavelength_series
from .profiles import (
    annuli_for_edge_width,
    equal_area_annuli,
    field_profile,
    particle_profile,
    radial_profile,
)
from .rings import (
    RING_Z,
    contour_wavelength,
    profile_ring_radii,
    profile_wavelength,
    ring_coherence,
    ring_peaks,
    ring_wavelength,
    smooth_profile,
)
from .statistics import ecoli_lambda, late_slope, max_value, power_law_fit

__all__ = [
    # io
    "read_csv",
    "write_csv",
    "markdown_rows",
    "thin_rows",
    "continuum_frames",
    "read_continuum_frame",
    "particle_frames",
    # profiles
    "annuli_for_edge_width",
    "equal_area_annuli",
    "radial_profile",
    "field_profile",
    "particle_profile",
    # rings
    "smooth_profile",
    "ring_peaks",
    "ring_wavelength",
    "profile_wavelength",
    "RING_Z",
    "ring_coherence",
    "profile_ring_radii",
    "contour_wavelength",
    # statistics
    "late_slope",
    "max_value",
    "power_law_fit",
    "ecoli_lambda",
    # runs of one engine
    "mesh_radius",
    "continuum_wavelength_series",
    "final_continuum_profile",
    "frame_rings",
    "continuum_rings",
    "continuum_wavelength",
    "particle_wavelength_series",
    "final_particle_profile",
    "final_ring_coherence",
]
