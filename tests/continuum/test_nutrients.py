"""The continuum with nutrients fed at its edge (issue 56) against exact answers.

Exact 1 (lam = 0, K = inf, a disc): R(t) of the Bessel solution; exact 2 (any lam, K, shape):
the nutrient equation holds on the mesh with c = 1 - p / ell^2; exact 3: the radial reference
(continuum.radial_nutrients) at lam > 0 and finite K. Each with its observed order in h.
"""

import json
import math

import numpy as np
import pytest
import scipy.sparse.linalg as spla

import continuum
from continuum import radial_nutrients as rn
from continuum.growth import nutrient_level
from continuum.state import sample_fields


def grown(h: float, **kw) -> continuum.Simulation:
    """A run without frames, its mesh refined as a whole: spacing h, n_nodes as h^-2."""
    return continuum.run(continuum.Config(h_max=h, n_nodes=round(2000 * (0.55 / h) ** 2),
                                          write_fields=False, **kw))


def test_lam_zero_first_order_grows_as_the_bessel_solution():
    """R(t) within 3e-4 of t(R) = ln(R I1(R/ell) / (R0 I1(R0/ell))), falling as h^2."""
    ell, R = 4.0, 12.0
    errors = []
    for h in (0.55, 0.275):
        sim = grown(h, lam=0.0, radius=R, nutrient_length=ell)
        exact = rn.bessel_time_to_radius(sim.state.radius, ell)
        errors.append(abs(sim.state.t / exact - 1.0))
    assert errors[0] < 3e-4, errors
    assert math.log2(errors[0] / errors[1]) == pytest.approx(2.0, abs=0.4), errors


def test_stress_and_monod_uptake_follow_the_radial_reference():
    """At lam = 1e-2, K = 0.5: t(R) within 1e-3 and p(r) within 3e-3 of max p of the 1D BVP."""
    lam, ell, K = 1e-2, 5.0, 0.5
    sim = grown(0.55, lam=lam, radius=15.0, nutrient_length=ell, monod_k=K)
    reference = rn.solve(sim.state.radius, lam, ell, K, n=801)
    assert sim.state.t == pytest.approx(rn.time_to_radius(sim.state.radius, lam, ell, K),
                                        rel=1e-3)
    r = np.hypot(*sim.state.points.T)
    p_ref = np.interp(r, reference.r, reference.p)
    assert np.max(np.abs(sim.state.p - p_ref)) < 3e-3 * reference.p.max()  # h = 0.55


@pytest.mark.parametrize("shape", ["ellipse:4,2", "rectangle:6,3"])
def test_the_nutrient_equation_holds_on_other_shapes(shape):
    """On the mesh itself c = 1 - p / ell^2 solves ell^2 Laplace c = g, c = 1 on the edge.

    The discrete nutrient problem assembled on the pressure's operators and solved directly
    for the source g of the solve gives c to the Newton tolerance; and c at fixed points
    converges at order 2 in h (four meshes, h halved thrice; the order fitted to the changes).
    """
    ell, lam, K = 2.0, 1e-2, 0.5
    samples = np.array([[0.0, 0.0], [1.5, 0.5], [-2.0, -0.6], [0.7, -1.0]])
    values = []
    spacings = (0.4, 0.2, 0.1, 0.05)
    for h in spacings:
        config = continuum.Config(lam=lam, shape=shape, nutrient_length=ell, monod_k=K,
                                  h_max=h, n_nodes=50, interior_coarsening=1.0)
        sim = continuum.Simulation(config)
        solver, last = sim.solver, sim.solver.last
        space, ops = solver.space, last["ops"]
        stiffness = space.matrix(ops.K_data)
        rhs = -ops.load(last["g"]) / ell**2
        boundary = space.boundary_dofs
        interior = np.setdiff1d(np.arange(space.n), boundary)
        c = np.ones(space.n)  # c = 1 on the edge; K_II c_I = rhs_I - K_IB 1
        block = stiffness[interior][:, interior].tocsc()
        c[interior] = spla.spsolve(block, rhs[interior] - stiffness[interior][:, boundary]
                                   @ np.ones(len(boundary)))
        assert np.max(np.abs(c - nutrient_level(last["p"], ell))) < 1e-7
        fields = sample_fields(sim.state.points, sim.state.triangles, sim.state.fields,
                               samples)
        values.append(fields["c"])
        assert 0 < fields["c"].min() and fields["c"].max() < 1
    changes = np.max(np.abs(np.diff(values, axis=0)), axis=1)  # unstructured meshes: fitted
    order = np.polyfit(np.log(spacings[:-1]), np.log(changes), 1)[0]
    assert order == pytest.approx(2.0, abs=0.4), (order, changes)


def test_without_nutrients_nothing_is_written_of_them(tmp_path):
    """With ell unset: no ``c`` field, no nutrient keys in config.json (bytes as before)."""
    continuum.run(continuum.Config(lam=1e-2, radius=1.2, n_nodes=200), out=tmp_path)
    config = json.loads((tmp_path / "config.json").read_text())
    assert "nutrient_length" not in config and "monod_k" not in config
    sim = continuum.Simulation(continuum.Config(lam=1e-2, n_nodes=200))
    assert "c" not in sim.state.fields
    sim = continuum.Simulation(continuum.Config(lam=1e-2, n_nodes=200, nutrient_length=3.0))
    c = sim.state.fields["c"]
    assert np.all((0 < c) & (c <= 1)) and c[: sim.state.n_boundary] == pytest.approx(1.0)


@pytest.mark.parametrize("kw,match", [
    (dict(nutrient_length=0.0), "nutrient_length must be a positive finite number"),
    (dict(nutrient_length=-2.0), "nutrient_length must be a positive finite number"),
    (dict(nutrient_length=math.inf), "a finite number|positive finite"),
    (dict(nutrient_length=math.nan), "a finite number|positive finite"),
    (dict(nutrient_length=3.0, monod_k=0.0), "monod_k must be positive"),
    (dict(nutrient_length=3.0, monod_k=math.nan), "monod_k must be|finite"),
    (dict(monod_k=2.0), "monod_k = 2 needs nutrient_length"),
    (dict(nutrient_length="3"), "nutrient_length must be"),
    (dict(nutrient_length=3.0, strains=[[1e-2, 1], [0, 1]]), "not supported yet"),
    (dict(nutrient_length=3.0, lam=-1e-3), "nutrients need lam >= 0"),
])
def test_bad_nutrient_settings_are_refused_in_one_line(kw, match):
    kw = {"lam": 1e-2, "radius": 3.0} | kw
    with pytest.raises(ValueError, match=match) as err:
        continuum.Config(**kw)
    assert "\n" not in str(err.value)


def test_inf_monod_k_is_first_order():
    config = continuum.Config(lam=1e-2, nutrient_length=3.0, monod_k=math.inf)
    assert config.monod_k is None and config.nutrient == (3.0, math.inf)


def test_a_checkpoint_of_another_nutrient_setting_is_refused(tmp_path):
    config = continuum.Config(lam=1e-2, radius=3.0, n_nodes=300, nutrient_length=3.0)
    continuum.run(config, out=tmp_path, max_steps=3)
    other = continuum.Config(lam=1e-2, radius=3.0, n_nodes=300, nutrient_length=4.0)
    with pytest.raises(ValueError, match="nutrient_length"):
        continuum.run(other, out=tmp_path)


def test_a_resumed_nutrient_run_equals_an_uninterrupted_one(tmp_path):
    config = continuum.Config(lam=1e-2, radius=3.0, n_nodes=300, nutrient_length=3.0,
                              monod_k=0.5, output_every=0.5)
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    one = continuum.run(config, out=tmp_path / "one")
    assert not continuum.run(config, out=tmp_path / "two", max_steps=7).finished
    two = continuum.run(config, out=tmp_path / "two")
    assert two.state.t == one.state.t and np.array_equal(two.state.p, one.state.p)
    for name in ("history.csv", "boundary.csv", "fields.pvd"):
        assert (tmp_path / "two" / name).read_bytes() == (tmp_path / "one" / name).read_bytes()
