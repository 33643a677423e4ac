"""The contact solvers of the per-step convex problem, one file each.

- problem.py: the problem E(gamma) every solver solves (model.md), its Numba kernels, the
  stopping test and ``ContactSolveError``;
- bbpgd.py: Barzilai-Borwein projected gradient descent (``--solver bbpgd``, the default);
- apgd.py: Jacobi-scaled accelerated projected gradient with adaptive restart (``apgd``);
- bbpgd_cuda.py: BBPGD's iteration as CUDA kernels (``bbpgd-cuda``; numba-cuda, the ``gpu``
  extra, imported on first use).

Every solver is a callable (contacts, length, dt, lam, gamma0, tol, maxiter, growth)
-> (gamma, residual history); ``BY_NAME`` maps the names of ``config.SOLVERS`` to them.
"""

from __future__ import annotations

from .apgd import solve_contacts_apgd
from .bbpgd import solve_contacts
from .problem import ContactSolveError as ContactSolveError  # re-exported


def solve_contacts_cuda(*args, **kwargs):
    """BBPGD on a CUDA GPU (bbpgd_cuda.solve_contacts_cuda), imported on first use."""
    from .bbpgd_cuda import solve_contacts_cuda as solve

    return solve(*args, **kwargs)


def check_device(solver: str) -> None:
    """Raise a one-line ValueError when ``solver`` needs a device this machine lacks.

    ``bbpgd-cuda`` needs numba-cuda and a CUDA GPU that it finds (or its simulator,
    NUMBA_ENABLE_CUDASIM=1); the other solvers run anywhere.
    """
    if solver != "bbpgd-cuda":
        return
    try:
        from numba import cuda
    except ImportError as e:
        raise ValueError(f"solver bbpgd-cuda needs numba-cuda: pip install "
                         f"'colony-mechanics[gpu]' ({e})") from None
    if not cuda.is_available():
        raise ValueError("solver bbpgd-cuda needs a CUDA GPU, and numba-cuda finds none "
                         "(use --solver bbpgd)")


BY_NAME = {
    "bbpgd": solve_contacts,
    "apgd": solve_contacts_apgd,
    "bbpgd-cuda": solve_contacts_cuda,
}
"""Contact solvers by name (``Config.solver``, one of config.SOLVERS): callables
(contacts, length, dt, lam, gamma0, tol, maxiter, growth) -> (gamma, residual history)."""
