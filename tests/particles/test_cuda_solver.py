"""BBPGD on a CUDA GPU (solvers/bbpgd_cuda.py) against the CPU solver, in numba-cuda's simulator.

The simulator is switched on in tests/conftest.py; NUMBA_ENABLE_CUDASIM=0 runs these on a GPU.

The kernels are the CPU iteration step for step, with the Barzilai-Borwein sums reduced by a
fixed tree instead of in order: the same iteration count and iterates to round-off, the same
stopping test, and the same bits on every solve.  The simulator runs every thread in Python, so
the launch shape is made small (TPB 8, 2 blocks, a check every 4 iterations): the grid-stride
loops, a four-level tree and convergence inside a batch are all exercised on 16 cells.

Each solve still takes seconds there, so the default suite keeps one representative of each
property (the two-strain rows against the CPU, solved once for both that and the same-bits
test; a short run through the engine); the other growth laws and the longer run are marked
``slow`` (``pytest -m slow``).
"""

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("numba_cuda")

import particles  # noqa: E402
from particles.geometry import detect_contacts  # noqa: E402
from particles.solvers import check_device  # noqa: E402
from particles.solvers import problem as P  # noqa: E402
from particles.solvers.bbpgd import solve_contacts  # noqa: E402


def _small_launch(monkeypatch):
    from particles.solvers import bbpgd_cuda

    monkeypatch.setattr(bbpgd_cuda, "TPB", 8)
    monkeypatch.setattr(bbpgd_cuda, "NBLOCKS", 2)
    monkeypatch.setattr(bbpgd_cuda, "CHECK", 4)
    return bbpgd_cuda


@pytest.fixture
def gpu(monkeypatch):
    """bbpgd_cuda with a small launch shape (module docstring)."""
    return _small_launch(monkeypatch)


@pytest.fixture(scope="module")
def jammed():
    """A colony grown by the engine to t = 3 (16 cells, 32 contacts: more than 2 x 8 threads)."""
    s = particles.run(particles.Config(lam=1e-2, time=3.0, dt=0.01, seed=3, threads=1)).state
    c = detect_contacts(s.x, s.y, s.theta, s.length, 0.1)
    assert len(c) > 16
    return c, s.length


def _strains(n):
    """Per-cell growth law rows of two strains (lam, rate), alternating over the cells."""
    odd = np.arange(n) % 2
    return np.where(odd, 1e-2, 0.5), np.where(odd, 1.0, 0.7)


@pytest.fixture(scope="module")
def strains_solve(jammed):
    """The GPU solve of the two-strain rows at tol 1e-8 (small launch shape), made once.

    Shared by the comparison with the CPU and by the same-bits test (a solve takes seconds).
    """
    c, length = jammed
    lam, rate = _strains(length.size)
    with pytest.MonkeyPatch.context() as mp:
        return _small_launch(mp).solve_contacts_cuda(c, length, 0.005, lam, tol=1e-8, rate=rate)


@pytest.mark.parametrize(("lam", "rate"), [
    pytest.param(0.0, 1.0, marks=pytest.mark.slow), pytest.param(1e-2, 1.0, marks=pytest.mark.slow),
    pytest.param(1.0, 1.0, marks=pytest.mark.slow), ("strains", "strains")])
def test_same_iterates_as_the_cpu_solver(gpu, jammed, lam, rate, request):
    """The default suite compares the two-strain rows (array lam and rate, lam 1e-2 and 0.5).

    The scalar laws lam = 0, 1e-2 and 1 are ``slow``: the same kernels with constant rows.
    """
    c, length = jammed
    if lam == "strains":  # per-cell growth law rows (two strains)
        lam, rate = _strains(length.size)
        gc, hc = request.getfixturevalue("strains_solve")
    else:
        gc, hc = gpu.solve_contacts_cuda(c, length, 0.005, lam, tol=1e-8, rate=rate)
    gb, hb = solve_contacts(c, length, 0.005, lam, tol=1e-8, rate=rate)
    assert len(hc) == len(hb) > 10  # the same iteration stops: a solve of many iterations
    np.testing.assert_allclose(gc, gb, rtol=0, atol=1e-12 * gb.max())
    np.testing.assert_allclose(hc, hb, rtol=1e-8)
    q = P.linearised_gap(c, length, 0.005, lam, gc, rate=rate)
    a = P.problem_arrays(c, length, 0.005)[4]
    assert np.max(np.abs(np.minimum(a * gc, q))) <= 1e-8  # the engine's stopping test


def test_warm_start_without_growth_and_a_converged_start(gpu, jammed):
    c, length = jammed
    g0 = solve_contacts(c, length, 0.005, 1e-2, tol=1e-6)[0]
    gb, hb = solve_contacts(c, length, 0.005, 1e-2, g0 * 1.01, tol=1e-8, growth=False)
    gc, hc = gpu.solve_contacts_cuda(c, length, 0.005, 1e-2, g0 * 1.01, tol=1e-8, growth=False)
    assert len(hc) == len(hb)
    np.testing.assert_allclose(gc, gb, rtol=0, atol=1e-12 * gb.max())
    # a start that already meets tol: no iteration, gamma unchanged (negative entries cut)
    start = gb.copy()
    start[0] = -1.0
    g, h = gpu.solve_contacts_cuda(c, length, 0.005, 1e-2, start, tol=1.0, growth=False)
    assert len(h) == 1 and g[0] == 0.0 and np.array_equal(g[1:], gb[1:])


def test_same_bits_every_solve(gpu, jammed, strains_solve):
    """A second solve of the two-strain rows gives the bits of the first (``strains_solve``)."""
    c, length = jammed
    lam, rate = _strains(length.size)
    first = strains_solve
    again = gpu.solve_contacts_cuda(c, length, 0.005, lam, tol=1e-8, rate=rate)
    assert first[0].tobytes() == again[0].tobytes()
    assert first[1].tobytes() == again[1].tobytes()


def test_iteration_cap_raises_with_the_history(gpu, jammed):
    c, length = jammed
    with pytest.raises(P.ContactSolveError, match=r"BBPGD \(CUDA\) did not reach") as e:
        gpu.solve_contacts_cuda(c, length, 0.005, 1e-2, tol=1e-12, maxiter=6)
    assert e.value.residuals.shape == (7,) and np.all(np.isfinite(e.value.residuals))


@pytest.mark.parametrize("dt", [0.04, pytest.param(0.02, marks=pytest.mark.slow)])
def test_a_run_with_the_gpu_solver_follows_the_cpu_run(gpu, dt):
    """Steps, divisions and warm starts through the engine: the same colony to round-off.

    To t = 1.6 (four cells): 40 steps of 0.04 in the default suite, 80 of 0.02 ``slow``.
    """
    base = particles.Config(lam=1e-2, time=1.6, dt=dt, seed=1, threads=1)
    cpu = particles.run(base)
    dev = particles.run(replace(base, solver="bbpgd-cuda"))
    a, b = cpu.state, dev.state
    assert a.n == b.n >= 4 and a.step == b.step
    for f in ("x", "y", "theta", "length", "stress"):
        np.testing.assert_allclose(getattr(b, f), getattr(a, f), rtol=0, atol=1e-9)
    assert [r["iterations"] for r in cpu.history] == [r["iterations"] for r in dev.history]


def test_a_machine_without_a_gpu_is_refused_before_any_work(monkeypatch, tmp_path):
    from numba import cuda

    monkeypatch.setattr(cuda, "is_available", lambda: False)
    check_device("bbpgd")  # the CPU solvers run anywhere
    with pytest.raises(ValueError, match="needs a CUDA GPU"):
        check_device("bbpgd-cuda")
    with pytest.raises(ValueError, match="needs a CUDA GPU"):
        particles.Simulation(particles.Config(lam=1e-2, radius=3, solver="bbpgd-cuda"),
                             out=tmp_path)
    assert list(tmp_path.iterdir()) == []


PTX = """
import types
import numba.cuda.dispatcher as d
from numba import boolean, cuda, float64, int64
d.get_current_device = lambda: types.SimpleNamespace(compute_capability=(9, 0))  # no device
try:  # CUDA's compiler (NVVM, NVRTC) installed?
    cuda.compile_ptx(lambda a: None, (float64[::1],), cc=(9, 0))
except Exception as e:
    raise SystemExit(f"no toolkit: {e}")
from particles.solvers import bbpgd_cuda as B
A1, A2, I1 = float64[::1], float64[:, ::1], int64[::1]
sigs = {"project": (A1,) * 4, "moves": (A1, I1, I1, A2, A1, A1, A1, boolean, A2, A1, A2),
        "gradient": (A1,) * 4 + (I1, I1) + (A1,) * 7 + (float64, A2, A1, A1, A2),
        "update": (A2, int64, int64, float64, A1, A1), "largest": (A1, A1, A2)}
for name, sig in sigs.items():
    cuda.compile_ptx(getattr(B, name).py_func, sig, cc=(9, 0))
print("compiled", len(sigs))
"""


def test_kernels_compile_for_a_gpu():
    """The kernels as NVVM compiles them for a GPU (sm_90), where CUDA's compiler is installed.

    The simulator runs them as Python, so it cannot see what the device compiler refuses (it
    found NumPy's exp, which numba-cuda does not lower: bbpgd_cuda's overloads).  Needs the
    ``gpu`` extra's toolkit (NVVM), not a GPU; skipped without it.
    """
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0"}
    done = subprocess.run([sys.executable, "-c", PTX], env=env, capture_output=True, text=True)
    if done.stderr.startswith("no toolkit"):
        pytest.skip(f"CUDA's compiler is not installed (the gpu extra): {done.stderr[:200]}")
    assert done.returncode == 0, done.stderr[-2000:]
    assert "compiled 5" in done.stdout


def test_a_nan_gap_is_never_converged(gpu, jammed):
    c, length = jammed
    gap = c.gap.copy()
    c.gap[3] = np.nan
    try:
        with pytest.raises(P.ContactSolveError, match="last residual inf"):
            gpu.solve_contacts_cuda(c, length, 0.005, 1e-2, tol=1e-6, maxiter=8)
    finally:
        c.gap[:] = gap
