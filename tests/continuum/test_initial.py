"""continuum.initial.state_from: the state at t = 0 from a polygon and a Psi0."""

import numpy as np
import pytest

from continuum import Config, Simulation
from continuum.initial import sizes_from, state_from
from continuum.simulation import initial_state
from continuum.sizes import CharacteristicSizes, LengthGrid, bump_profile


def test_the_configured_shape_and_bump_give_the_model_start():
    """state_from(the config's polygon, the bump's row) is initial_state(config), bit for bit."""
    config = Config(lam=0.01, n_nodes=200, initial_sizes="bump")
    row = bump_profile(LengthGrid(config.n_length_cells), config.bump_width)
    a, b = initial_state(config), state_from(config, config.initial_boundary(), row)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    np.testing.assert_array_equal(a.sizes.n, b.sizes.n)
    assert type(a.sizes) is type(b.sizes) and a.n_boundary == b.n_boundary


def test_a_simulation_grows_a_given_start():
    """A square with lengths growing to the right: G0 = 0, Psi0 as given, the copy grown."""
    config = Config(lam=0.01, n_nodes=200, h_max=0.3)
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    grid = LengthGrid(config.n_length_cells)

    def psi0(xy):
        out = np.zeros((len(xy), grid.n_cells))
        out[np.arange(len(xy)), (xy[:, 0] * 10).astype(int)] = 1.0  # cell 0..20 by x
        return out

    start = state_from(config, square, psi0)
    assert isinstance(start.sizes, CharacteristicSizes)
    cell_mean = grid.length_integrals / grid.ds  # the mean length of one cell
    np.testing.assert_allclose(start.fields["mean_length_psi"],
                               cell_mean[(start.points[:, 0] * 10).astype(int)], rtol=1e-12)
    lbar0 = start.fields["mean_length_psi"].copy()
    sim = Simulation(config, state=start)
    assert sim.state is not start and np.all(sim.state.G == 0)
    sim.advance(time=0.3)
    assert np.all(start.G == 0)  # the given state is not changed
    assert sim.state.area > 4.0 * np.exp(0.29)
    assert np.all(sim.state.fields["mean_length_psi"] > lbar0.min())


def test_bad_psi0_is_rejected():
    config = Config(lam=0.01)
    pts = np.zeros((3, 2))
    for bad, match in [(np.ones(5), "shape"), (-np.ones(40), ">= 0"), (np.zeros(40), "no cells"),
                       (np.full(40, np.nan), "finite")]:
        with pytest.raises(ValueError, match=match):
            sizes_from(config, pts, bad)
    with pytest.raises(ValueError, match="not simple"):
        state_from(config, np.array([[0, 0], [1, 1], [1, 0], [0, 1.0]]), np.ones(40))
