"""Shared analysis of both engines' outputs (model.md, "Analysis"), by concept.

Everything works on plain arrays, so the particle engine (samples = particles) and the
continuum solver (samples = points of the mesh) are reduced the same way:

- :mod:`.io`: the runs' files: CSVs, continuum VTU frames, particle trajectory frames;
- :mod:`.profiles`: radial profiles in annuli of equal area (Fig 3A, Fig 4A);
- :mod:`.rings`: ring peaks and wavelengths, ring coherence, contour wavelengths, and the 1D
  radial reference's wavelength and rings at a colony's radius (Fig 4);
- :mod:`.statistics`: late-time slope, maxima, power-law fits, the E. coli estimate (Fig 3);
- :mod:`.continuum_runs`, :mod:`.particle_runs`: reductions of one engine's run folder
  (wavelength at every frame, final profile, final rings) used by the figure cases;
- :mod:`.orientation`: the rods' nematic order tensor per annulus and on a grid, its director
  and +-1/2 defects, of any particle run folder (CSV, VTU; issue 31).

The closed-form radial solution (analytic curves of Fig 3) is :mod:`continuum.radial`; the growth
law and lbar = 2^frac(G / ln 2) are :mod:`continuum.growth`; the particle colony's centroid and
radius are :mod:`particles.measures`. Every module's ``__all__`` is re-exported here (``from cases
import analysis as A``; ``A.read_csv``), each name defined once in its module.
"""

from . import continuum_runs, io, orientation, particle_runs, profiles, rings, statistics
from .continuum_runs import *  # noqa: F403
from .io import *  # noqa: F403
from .orientation import *  # noqa: F403
from .particle_runs import *  # noqa: F403
from .profiles import *  # noqa: F403
from .rings import *  # noqa: F403
from .statistics import *  # noqa: F403

#: The names of every module's ``__all__``.
__all__ = [name for module in (io, profiles, rings, statistics, continuum_runs, particle_runs,
                                       orientation)
           for name in module.__all__]
