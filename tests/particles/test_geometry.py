"""Contact geometry and two-rod problems against hand calculations.

Two rods i, j with one active contact k and gap Phi: the step's optimality condition
grad_k = Phi + dt a gamma - (G_i l_i (exp(dt g_i) - 1) + G_j l_j (exp(dt g_j) - 1)) = 0,
a = 1/l_i + 1/l_j + 12 (r_i x n)^2 / l_i^3 + 12 (r_j x n)^2 / l_j^3, g = exp(-lam G gamma).
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from particles.geometry import (
    find_contacts,
    generalised_forces,
    max_overlap,
    segment_distance,
)
from particles.neighbours import candidate_pairs
from particles.solvers.bbpgd import solve_contacts
from particles.solvers.problem import ContactSolveError
from particles.stress import axial_stress

B = 0.5


def contacts_of(x, y, th, l, margin=0.05):
    x, y, th, l = (np.asarray(a, dtype=float) for a in (x, y, th, l))
    return find_contacts(x, y, th, l, candidate_pairs(x, y, l, margin), margin)


def sampled_distance(x, y, th, l, i, j, m=4001):
    """Segment distance by dense sampling of segment i and exact projection on j."""
    t = np.linspace(-0.5, 0.5, m) * (l[i] - B)
    px = x[i] + t * np.cos(th[i])
    py = y[i] + t * np.sin(th[i])
    uj, vj = np.cos(th[j]), np.sin(th[j])
    s = np.clip((px - x[j]) * uj + (py - y[j]) * vj, -(l[j] - B) / 2, (l[j] - B) / 2)
    return np.min(np.hypot(px - x[j] - s * uj, py - y[j] - s * vj))


def test_segment_distance_random_parallel_and_degenerate():
    rng = np.random.default_rng(3)
    for trial in range(200):
        x = rng.uniform(-1, 1, 2)
        y = rng.uniform(-1, 1, 2)
        th = rng.uniform(0, np.pi, 2)
        if trial % 4 == 0:
            th[1] = th[0]  # parallel
        if trial % 4 == 1:
            th[1] = th[0]
            y[1] = y[0] + (x[1] - x[0]) * np.tan(th[0])  # collinear
        l = rng.uniform(1.0, 2.0, 2)
        d = segment_distance(x, y, th, l, 0, 1, B)
        ref = sampled_distance(x, y, th, l, 0, 1)
        # sampling error is at most half the sample spacing
        assert ref - 1e-3 <= d <= ref + 1e-12


def test_crossing_segments_distance_zero():
    x = np.zeros(2)
    y = np.zeros(2)
    th = np.array([0.0, np.pi / 2])
    l = np.ones(2) * 1.5
    assert segment_distance(x, y, th, l, 0, 1, B) == 0.0
    assert max_overlap(x, y, th, l) == pytest.approx(B)


def solve_two(x, y, th, l, dt, lam, tol=1e-14):
    c = contacts_of(x, y, th, l)
    g, _ = solve_contacts(c, np.asarray(l, float), dt, lam, tol=tol)
    return c, g


@pytest.mark.parametrize("lam", [0.0, 0.3])
def test_end_to_end(lam):
    l = np.array([1.2, 1.7])
    x = np.array([0.0, 0.5 * (l[0] + l[1])])
    dt = 0.01
    c, g = solve_two(x, [0, 0], [0, 0], l, dt, lam)
    assert len(c) == 1 and c.gi[0] == pytest.approx(0.5) and c.gj[0] == pytest.approx(0.5)
    a = 1 / l[0] + 1 / l[1]

    def f(gam):
        return dt * a * gam - 0.5 * np.sum(l * np.expm1(dt * np.exp(-lam * 0.5 * gam)))

    ref = brentq(f, 0.0, 10.0, xtol=1e-15)
    assert g[0] == pytest.approx(ref, rel=1e-10)
    if lam == 0:
        assert ref == pytest.approx(0.5 * l.sum() * np.expm1(dt) / (dt * a), rel=1e-14)
    np.testing.assert_allclose(axial_stress(c, g, 2), [0.5 * ref, 0.5 * ref], rtol=1e-10)
    fx, fy, tz = generalised_forces(c, g, 2)
    np.testing.assert_allclose(fx, [-ref, ref], rtol=1e-10)
    np.testing.assert_allclose(np.r_[fy, tz], 0.0, atol=1e-12)


def test_side_by_side_two_contacts_and_overlap_removal():
    l = np.array([1.5, 1.5])
    delta = 0.01
    y = np.array([0.0, B - delta])
    dt = 0.01
    c, g = solve_two([0, 0], y, [0, 0], l, dt, 0.0)
    assert len(c) == 2  # one at each end
    np.testing.assert_allclose(c.gap, -delta, atol=1e-14)
    np.testing.assert_allclose(np.abs(c.rix), (l[0] - B) / 2)
    np.testing.assert_allclose(np.r_[c.gi, c.gj], 0.0, atol=1e-15)  # p . n = 0: no growth load
    # by symmetry gamma_1 = gamma_2 = gamma: -delta + dt (2 gamma / l) * 2 = 0
    np.testing.assert_allclose(g, delta * l[0] / (4 * dt), rtol=1e-10)
    fx, fy, tz = generalised_forces(c, g, 2)
    np.testing.assert_allclose(fy, [-2 * g[0], 2 * g[0]], rtol=1e-10)
    np.testing.assert_allclose(np.r_[fx, tz], 0.0, atol=1e-10)
    np.testing.assert_allclose(axial_stress(c, g, 2), 0.0, atol=1e-15)


@pytest.mark.parametrize("alpha,lam", [(np.pi / 2, 0.0), (np.pi / 3, 0.0), (np.pi / 3, 0.4)])
def test_crossed_end_on_side(alpha, lam):
    """Rod j at angle alpha with its lower end touching the side of horizontal rod i at x = s0."""
    li, lj = 1.8, 1.3
    s0 = 0.3
    hj = (lj - B) / 2
    x = np.array([0.0, s0 + hj * np.cos(alpha)])
    y = np.array([0.0, B + hj * np.sin(alpha)])
    th = np.array([0.0, alpha])
    dt = 0.01
    c, g = solve_two(x, y, th, [li, lj], dt, lam)
    assert len(c) == 1
    np.testing.assert_allclose([c.nx[0], c.ny[0]], [0.0, 1.0], atol=1e-14)
    np.testing.assert_allclose([c.rix[0], c.riy[0]], [s0, 0.0], atol=1e-14)
    gj = 0.5 * np.sin(alpha)
    assert c.gi[0] == pytest.approx(0.0, abs=1e-15) and c.gj[0] == pytest.approx(gj)
    rjxn = -hj * np.cos(alpha)  # r_j x n with r_j = -hj p_j, n = e_y
    a = 1 / li + 1 / lj + 12 * s0**2 / li**3 + 12 * rjxn**2 / lj**3

    def f(gam):
        return dt * a * gam - gj * lj * np.expm1(dt * np.exp(-lam * gj * gam))

    ref = brentq(f, 0.0, 10.0, xtol=1e-15)
    assert g[0] == pytest.approx(ref, rel=1e-10)
    fx, fy, tz = generalised_forces(c, g, 2)
    np.testing.assert_allclose(fy, [-ref, ref], rtol=1e-10)
    np.testing.assert_allclose(tz, [-ref * s0, ref * rjxn], rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(axial_stress(c, g, 2), [0.0, gj * ref], rtol=1e-10, atol=1e-15)


def test_separated_rods_no_force():
    c, g = solve_two([0, 0], [0, B + 0.03], [0, 0], [1.5, 1.5], 0.01, 0.0)
    assert len(c) == 2 and np.all(g == 0.0)


def test_contact_force_and_torque_balance_random():
    """Each contact's forces sum to zero and its torques about the origin cancel."""
    rng = np.random.default_rng(5)
    n = 300
    side = 9.0
    x = rng.uniform(0, side, n)
    y = rng.uniform(0, side, n)
    th = rng.uniform(0, np.pi, n)
    l = rng.uniform(1, 2, n)
    c = contacts_of(x, y, th, l, margin=0.1)
    gam = rng.uniform(0, 1, len(c))
    fx, fy, tz = generalised_forces(c, gam, n)
    assert abs(fx.sum()) < 1e-12 * len(c) and abs(fy.sum()) < 1e-12 * len(c)
    torque = np.sum(x * fy - y * fx + tz)
    assert abs(torque) < 1e-11 * len(c) * side
    # the smallest gap of each pair is its exact segment distance minus b; the other >= it
    pair = c.i * n + c.j
    for p in np.unique(pair)[::5]:
        ks = np.flatnonzero(pair == p)
        assert 1 <= ks.size <= 2
        d = segment_distance(x, y, th, l, c.i[ks[0]], c.j[ks[0]], B)
        assert np.min(c.gap[ks]) == pytest.approx(d - B, abs=1e-12)


def test_solver_failure_raises_with_history():
    l = np.array([1.5, 1.5])
    c = contacts_of([0, 0], [0, B - 0.01], [0, 0.05], l)
    with pytest.raises(ContactSolveError) as e:
        solve_contacts(c, l, 0.01, 0.0, tol=1e-300, maxiter=3)
    assert e.value.n_particles == 2 and e.value.n_contacts == len(c)
    assert e.value.residuals.shape == (4,)


def test_bad_input():
    l = np.array([1.5, 1.5])
    c = contacts_of([0, 0], [0, B], [0, 0], l)
    with pytest.raises(ValueError):
        solve_contacts(c, l, -1.0, 0.0)
    with pytest.raises(ValueError):
        solve_contacts(c, l, 0.01, -0.1)
    with pytest.raises(ValueError):
        contacts_of([0, 0], [0, 0.4], [0, 0], [0.4, 1.0])


def test_contact_keys_do_not_depend_on_the_particle_order():
    """The contact identities (warm start) survive a reordering of the particles in memory."""
    from particles.geometry import canonical_keys
    from particles.packings import ring_packing

    x, y, th, l = ring_packing(600, seed=2)[:4]
    ids = np.arange(x.size) * 3 + 7
    order = np.random.default_rng(0).permutation(x.size)
    keys = []
    for o in (np.arange(x.size), order):
        pairs = candidate_pairs(x[o], y[o], l[o], 0.1)
        c = find_contacts(x[o], y[o], th[o], l[o], pairs, 0.1, ids=ids[o])
        keys.append(np.sort(c.keys(ids[o])))
    assert keys[0].size > x.size and np.array_equal(*keys)
    raw = ids[c.i] * (1 << 31) + ids[c.j] * 4 + c.code  # (id_i, id_j, code) in index order
    assert np.array_equal(canonical_keys(raw), c.keys(ids))
    assert np.array_equal(canonical_keys(c.keys(ids)), c.keys(ids))


def test_contact_keys_and_warm_start_are_the_same_on_every_number_of_threads():
    """Contact identities and the warm start (parallel kernels) equal NumPy's on 1 and 2 threads.

    The reference is the engine's former NumPy code (canonical_keys of the raw keys; argsort and
    searchsorted), against previous keys that miss some contacts, add others below and above
    every key, and come in another order.
    """
    import numba

    from particles.geometry import canonical_keys
    from particles.packings import ring_packing
    from particles.stepping import warm_start

    x, y, th, l = ring_packing(3000, seed=5)[:4]
    ids = np.random.default_rng(1).permutation(x.size) * 2 + 5
    c = find_contacts(x, y, th, l, candidate_pairs(x, y, l, 0.1), 0.1, ids=ids)
    raw = canonical_keys(ids[c.i] * (1 << 31) + ids[c.j] * 4 + c.code)
    rng = np.random.default_rng(2)
    keep = rng.random(raw.size) < 0.8
    prev_keys = np.concatenate([raw[keep], [0, 1 << 62], raw[~keep][:5] + 1])
    order = rng.permutation(prev_keys.size)
    prev_keys, prev_gamma = prev_keys[order], rng.random(prev_keys.size)
    sk = np.sort(prev_keys)
    pos = np.clip(np.searchsorted(sk, raw), 0, sk.size - 1)
    hit = sk[pos] == raw
    expected = np.zeros(raw.size)
    expected[hit] = prev_gamma[np.argsort(prev_keys)[pos[hit]]]
    assert hit.sum() == keep.sum() > 3000
    saved = numba.get_num_threads()
    try:
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            keys = c.keys(ids)
            assert keys.dtype == np.int64 and keys.tobytes() == raw.tobytes()
            assert warm_start(keys, prev_keys, prev_gamma).tobytes() == expected.tobytes()
    finally:
        numba.set_num_threads(saved)
    assert not warm_start(keys, prev_keys[:0], prev_gamma[:0]).any()


def test_contact_search_refuses_short_particles_in_pairs_only():
    """A particle no longer than b is refused when it is in a candidate pair, not otherwise."""
    x, y, th = np.array([0.0, 0.7, 9.0]), np.zeros(3), np.zeros(3)
    l = np.array([1.0, 1.0, 0.4])
    assert len(find_contacts(x, y, th, l, candidate_pairs(x, y, l, 0.1), 0.1)) == 1
    l[1] = 0.5
    with pytest.raises(ValueError, match="exceed the diameter"):
        find_contacts(x, y, th, l, candidate_pairs(x, y, l, 0.1), 0.1)


def test_forces_and_contact_lists_are_the_same_on_every_number_of_threads():
    """D gamma has NumPy's bits, and by_particle gives the solver's lists, on 1 and 2 threads.

    generalised_forces against its np.bincount formula; by_particle (each particle's contacts
    in increasing order) against a stable sort of the contacts' two ends.
    """
    import numba

    from particles.geometry import by_particle, generalised_forces
    from particles.packings import ring_packing

    x, y, th, l = ring_packing(3000, seed=6)[:4]
    c = find_contacts(x, y, th, l, candidate_pairs(x, y, l, 0.1), 0.1)
    n = x.size
    gamma = np.random.default_rng(3).random(len(c)) * (np.arange(len(c)) % 3 > 0)
    tj = c.rjx * c.ny - c.rjy * c.nx
    ti = c.rix * c.ny - c.riy * c.nx
    expected = (np.bincount(c.j, gamma * c.nx, n) - np.bincount(c.i, gamma * c.nx, n),
                np.bincount(c.j, gamma * c.ny, n) - np.bincount(c.i, gamma * c.ny, n),
                np.bincount(c.j, gamma * tj, n) - np.bincount(c.i, gamma * ti, n))
    ends, ks = np.concatenate([c.i, c.j]), np.tile(np.arange(len(c)), 2)
    idx = ks[np.lexsort((ks, ends))]
    start = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=n))])
    saved = numba.get_num_threads()
    try:
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            got = generalised_forces(c, gamma, n)
            assert all(a.tobytes() == b.tobytes() for a, b in zip(got, expected, strict=True))
            s2, i2 = by_particle(c.i, c.j, n)
            assert np.array_equal(s2, start) and np.array_equal(i2, idx)
    finally:
        numba.set_num_threads(saved)
    assert len(c) > 3000  # a dense packing: every chunk of by_particle holds contacts
