"""Fixtures shared by the tests of every package: tiny finished runs of both engines.

Each is made once per session into a temporary folder; a test that changes a run's files puts
them back.
"""

import os

# The CUDA contact solver's kernels (particles/solvers/bbpgd_cuda.py) run in numba-cuda's
# simulator, which numba reads when it is first imported: set here, before any test imports it.
# NUMBA_ENABLE_CUDASIM=0 runs them on a GPU instead.
os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "1")

import pytest  # noqa: E402


@pytest.fixture(scope="session")
def particle_run(tmp_path_factory):
    """Folder of a particle run: lam = 1e-2 to radius 4 (16 particles), a frame every 0.4."""
    from particles import Config, run

    out = tmp_path_factory.mktemp("particles")
    run(Config(lam=1e-2, radius=4, output_every=0.4, threads=1), out=out)
    return out


@pytest.fixture(scope="session")
def continuum_run(tmp_path_factory):
    """Folder of a continuum run: lam = 1e-2 to radius 2, 17 VTU frames (output_every 0.2)."""
    from continuum import Config, run

    out = tmp_path_factory.mktemp("continuum")
    run(Config(lam=1e-2, radius=2, output_every=0.2), out=out)
    return out
