"""Cell lists equal brute force on random dense packings."""

import numpy as np
import pytest

from particles.neighbours import candidate_pairs


def brute_force_pairs(
    x: np.ndarray, y: np.ndarray, length: np.ndarray, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """Reference O(N^2) version of :func:`candidate_pairs` (same criterion, same order)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    length = np.asarray(length, dtype=np.float64)
    d2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    cut = 0.5 * (length[:, None] + length[None, :]) + margin
    i, j = np.nonzero(np.triu(d2 <= cut * cut, k=1))
    return i.astype(np.int64), j.astype(np.int64)


@pytest.mark.parametrize("seed,n,side,margin", [(0, 500, 10.0, 0.0), (1, 2000, 20.0, 0.1),
                                                (2, 3000, 15.0, 0.3), (3, 50, 2.0, 0.05)])
def test_cell_lists_equal_brute_force(seed, n, side, margin):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-side / 2, side / 2, n)
    y = rng.uniform(0, side, n)
    length = rng.uniform(1.0, 2.0, n)
    ci, cj = candidate_pairs(x, y, length, margin)
    bi, bj = brute_force_pairs(x, y, length, margin)
    assert ci.size > n  # dense: several neighbours per particle
    np.testing.assert_array_equal(ci, bi)
    np.testing.assert_array_equal(cj, bj)


def test_cell_lists_line_and_single():
    x = np.arange(40) * 1.5
    y = np.zeros(40)
    length = np.full(40, 1.5)
    ci, cj = candidate_pairs(x, y, length, 0.0)
    bi, bj = brute_force_pairs(x, y, length, 0.0)
    np.testing.assert_array_equal(ci, bi)
    np.testing.assert_array_equal(cj, bj)
    assert ci.size == 39
    e = candidate_pairs(np.zeros(1), np.zeros(1), np.ones(1), 0.1)
    assert e[0].size == 0


def test_cell_lists_bad_input():
    with pytest.raises(ValueError):
        candidate_pairs(np.zeros(3), np.zeros(2), np.ones(3), 0.1)
    with pytest.raises(ValueError):
        candidate_pairs(np.zeros(3), np.zeros(3), np.ones(3), -0.1)
    with pytest.raises(ValueError):
        candidate_pairs(np.array([0.0, np.nan]), np.zeros(2), np.ones(2), 0.1)


def test_contact_search_is_the_same_on_every_number_of_threads():
    """Candidate pairs and contacts (computed in parallel) do not depend on the threads."""
    import numba

    from particles.geometry import find_contacts
    from particles.packings import ring_packing

    x, y, theta, length = ring_packing(3000, seed=4)[:4]
    results = []
    saved = numba.get_num_threads()
    try:
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            pairs = candidate_pairs(x, y, length, 0.1)
            c = find_contacts(x, y, theta, length, pairs, 0.1)
            results.append([*pairs, *(getattr(c, k) for k in c.__slots__)])
    finally:
        numba.set_num_threads(saved)
    assert results[0][2].size > 3000  # i of the contacts: a dense packing
    for a, b in zip(*results, strict=True):
        assert a.tobytes() == b.tobytes()
    np.testing.assert_array_equal(results[0][:2], brute_force_pairs(x, y, length, 0.1))
