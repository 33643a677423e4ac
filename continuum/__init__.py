"""Continuum colony solver (see docs/DESIGN.md).

Modules: ``mesh`` (polygons, Triangle meshes), ``pressure`` (Newton + AMG-CG for
-Laplace p = exp(-lam p)), ``velocity`` (u = -grad p: patch recovery, boundary residual flux),
``motion`` (RK2 node motion, remeshing criteria, gradient-corrected transfer), ``sizes``
(Psi(x, l, t)), ``radial`` (1D reference), ``simulation`` (``ContinuumConfig``, ``run``),
``output`` (run folder files).
"""
