"""Fixtures of the particle engine's tests."""

import numpy as np
import pytest

from particles.geometry import find_contacts
from particles.neighbours import candidate_pairs


def _chain(lengths):
    """Rods of the given lengths on the x axis, touching end to end, centred on the origin.

    Returns the centres' x and the contacts (N - 1 of them, gap 0; test_chain.py).
    """
    lengths = np.asarray(lengths, dtype=float)
    right = np.cumsum(lengths)
    x = right - lengths / 2 - right[-1] / 2
    y = np.zeros_like(x)
    th = np.zeros_like(x)
    c = find_contacts(x, y, th, lengths, candidate_pairs(x, y, lengths, 0.05), 0.05)
    return x, c


@pytest.fixture
def chain():
    """``chain(lengths) -> (x, contacts)``: a straight chain of rods touching end to end."""
    return _chain
