"""The contact solvers of the per-step convex problem, one file each.

- problem.py: the problem E(gamma) every solver solves (model.md), its Numba kernels, the
  stopping test and ``ContactSolveError``;
- bbpgd.py: Barzilai-Borwein projected gradient descent (``--solver bbpgd``, the default);
- apgd.py: Jacobi-scaled accelerated projected gradient with adaptive restart (``apgd``).

Every solver is a callable (contacts, length, dt, lam, gamma0, tol, maxiter, growth)
-> (gamma, residual history); ``BY_NAME`` maps the names of ``config.SOLVERS`` to them.
"""

from __future__ import annotations

from .apgd import solve_contacts_apgd
from .bbpgd import solve_contacts
from .problem import ContactSolveError as ContactSolveError  # re-exported

BY_NAME = {
    "bbpgd": solve_contacts,
    "apgd": solve_contacts_apgd,
}
"""Contact solvers by name (``Config.solver``, one of config.SOLVERS): callables
(contacts, length, dt, lam, gamma0, tol, maxiter, growth) -> (gamma, residual history)."""
