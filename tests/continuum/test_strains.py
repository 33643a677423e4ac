"""Strains in the continuum (issue 32): identical strains, the core-shell reference, outputs, input.

The core-shell colony is checked against the 1D layered reference (continuum.radial_strains)
on several meshes, with the observed order asserted. Measured (``_core_shell_errors``, T = 2.5,
R 3 -> 8.41, interface 1.8 -> 6.28; P1, uniform mesh of spacing h = h_max, 0.1-1.3 s a run):
the errors are systematic (core and colony too small) and of order 1,

    h          0.8      0.56     0.4      0.28     0.2
    R          -0.207   -0.112   -0.092   -0.043   -0.044
    interface  -0.463   -0.267   -0.234   -0.114   -0.115
    p / p(0)   0.076    0.041    0.034    0.016    0.016

fitted orders 0.95 (R), 0.83 (interface), 1.04 (p) over the test's h = 0.66 ... 0.2 (8 meshes),
the pairwise ones scattered (the mesh's node placement varies with h). (Measured with the
fractions' growth of continuum.strains.grown_fractions; with constant fractions the errors were
about 1.2x these, e.g. -0.59 ... -0.16 for the interface.)
Why order 1, where the one-strain colony has 2: the fractions live on the material nodes
(continuum.strains, "Accuracy").
"""

import csv
import functools
import json

import meshio
import numpy as np
import pytest

import continuum
from continuum import radial_strains
from continuum.rings import area_centroid
from continuum.strains import (
    Strain,
    as_strains,
    check_fractions,
    core,
    interface_table,
    mixed_growth,
    mixture,
    sector,
)

SMALL = dict(lam=1e-2, n_nodes=300, h_max=0.3, stretch=1.2, initial_radius=1.0,
             output_every=0.0)
"""A colony of radius 1 grown to radius 4: 23 steps, remeshed (0.1 s)."""


def _grow(fractions=None, **changes):
    sim = continuum.Simulation(continuum.Config(**{**SMALL, **changes}), layout=fractions)
    sim.advance(radius=4.0)
    return sim


@pytest.mark.parametrize(("strains", "fractions"), [
    (((1e-2, 1.0),), None),
    (((1e-2, 1.0),) * 2, core(0.6)),
    (((1e-2, 1.0),) * 2, sector(1.0)),
    (((1e-2, 1.0),) * 3, mixture(0.2, 0.5, 0.3)),
])
def test_identical_strains_are_the_one_strain_run_bit_for_bit(strains, fractions):
    """Identical strains in any layout grow the one-strain colony: the same bits.

    The mixture's source is evaluated relative to strain 0 (continuum.strains.mixed_growth),
    so equal strains add exact zeros; exact equality, not a tolerance, because Triangle
    remeshes a boundary moved by round-off into another mesh (a tolerance would hold only
    until the first remesh).
    """
    one = _grow()
    many = _grow(fractions, strains=strains)
    assert many.state.n_remesh >= 1
    a, b = one.state, many.state
    assert [r["radius"] for r in one.history] == [r["radius"] for r in many.history]
    assert [r["t"] for r in one.history] == [r["t"] for r in many.history]
    for name in ("points", "p", "G", "u"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for i in range(len(strains)):
        np.testing.assert_array_equal(b.G_strains[:, i], a.G)
    np.testing.assert_allclose(b.phi.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    assert b.phi.min() >= 0.0 and b.phi.max() <= 1.0 + 1e-15


STRAINS = (Strain(0.0, 1.0), Strain(2e-2, 0.7))
"""Core: stress-insensitive, growth 1; shell: lam = 2e-2, growth 0.7."""
R0, R1, T = 3.0, 1.8, 2.5


@functools.cache
def _core_shell_reference() -> tuple[float, float, radial_strains.Layers]:
    """The reference at T: interface radius, edge radius and pressure (about 2 s)."""
    r1_ref, R_ref = radial_strains.radii([T], [R1, R0], STRAINS)[0]
    return r1_ref, R_ref, radial_strains.layers([r1_ref, R_ref], STRAINS)


def _core_shell_errors(h: float) -> tuple[float, float, float]:
    """Signed errors of R(T), of the interface radius sqrt(A_core / pi) and max |p - p_ref| / p(0).

    A uniform mesh of spacing h (interior_coarsening 1, n_nodes 50 so that h_max applies from
    the start); the reference (continuum.radial_strains) from the exact radii R0, R1.
    """
    cfg = continuum.Config(lam=0.0, initial_radius=R0, n_nodes=50, h_max=h,
                           interior_coarsening=1.0, strains=STRAINS, output_every=0.0)
    sim = continuum.Simulation(cfg, layout=core(R1))
    s = sim.advance(time=T)
    r1_ref, R_ref, ref = _core_shell_reference()
    r = np.hypot(*(s.points - area_centroid(s.points, s.triangles)).T)
    e_p = np.abs(s.p - ref.pressure(np.minimum(r, R_ref))).max() / ref.p0
    return s.radius - R_ref, np.sqrt(s.strain_areas[0] / np.pi) - r1_ref, e_p


def test_core_shell_colony_converges_to_the_layered_reference_at_order_one():
    """R(T), the interface radius and the pressure against continuum.radial_strains.

    Order 1 (module docstring: nodal fractions), errors systematic: both radii too small.
    """
    hs = np.array([0.66, 0.56, 0.47, 0.4, 0.33, 0.28, 0.23, 0.2])
    errs = np.array([_core_shell_errors(h) for h in hs])
    assert np.all(errs[:, :2] < 0)  # the core and the colony lag behind the reference
    for k in range(3):
        order = np.polyfit(np.log(hs), np.log(np.abs(errs[:, k])), 1)[0]
        assert abs(order - 1.0) < 0.3, (k, order, errs[:, k])
    assert np.all(np.abs(errs[:, 1]) < 0.8 * hs)  # |interface error| ~ 0.4-0.6 h measured


def test_run_folder_carries_the_strains(tmp_path):
    """history.csv areas, phi_i and G_i in the frames, interfaces.csv, config.json, checkpoint."""
    cfg = continuum.Config(**{**SMALL, "radius": 3.0, "strains": ((0.0, 1.0), (1e-2, 0.8))})
    sim = continuum.run(cfg, tmp_path, layout=core(0.6))
    rows = list(csv.DictReader((tmp_path / "history.csv").open()))
    for row in rows:
        total = float(row["area_0"]) + float(row["area_1"])
        assert abs(total - float(row["area"])) < 1e-12 * float(row["area"])
    assert float(rows[-1]["area_0"]) > float(rows[0]["area_0"])
    frame = meshio.read(sorted((tmp_path / "fields").glob("*.vtu"))[-1])
    for name in ("phi_0", "phi_1", "G_0", "G_1", "mean_length_0", "mean_length_1"):
        assert name in frame.point_data
    np.testing.assert_array_equal(frame.point_data["phi_0"], sim.state.phi[:, 0])
    table = list(csv.DictReader((tmp_path / "interfaces.csv").open()))
    assert [int(r["strain"]) for r in table] == [0, 1]
    core_row = table[0]
    assert int(core_row["n_pieces"]) == 1
    assert abs(float(core_row["mean_radius"]) - np.sqrt(float(core_row["area"]) / np.pi)) < 0.1
    saved = json.loads((tmp_path / "config.json").read_text())
    assert saved["strains"] == [{"lam": 0.0, "growth": 1.0}, {"lam": 1e-2, "growth": 0.8}]
    assert continuum.Config(**saved) == cfg


def test_checkpoint_continues_a_strains_run_bit_for_bit(tmp_path):
    cfg = continuum.Config(**{**SMALL, "strains": ((0.0, 1.0), (1e-2, 0.8))})
    sim = continuum.Simulation(cfg, layout=sector(2.0))
    sim.advance(radius=2.5)
    sim.save(tmp_path / "c.npz")
    again = continuum.Simulation.load(tmp_path / "c.npz")
    np.testing.assert_array_equal(again.state.phi, sim.state.phi)
    sim.advance(radius=3.5)
    again.advance(radius=3.5)
    for name in ("points", "p", "phi", "G_strains"):
        np.testing.assert_array_equal(getattr(again.state, name), getattr(sim.state, name))


def test_one_strain_config_json_has_no_strains(tmp_path):
    """A one-strain run's config.json is the file it was before strains (bytes unchanged)."""
    continuum.run(continuum.Config(**{**SMALL, "radius": 1.5}), tmp_path)
    assert "strains" not in json.loads((tmp_path / "config.json").read_text())
    assert "area_0" not in (tmp_path / "history.csv").read_text().splitlines()[0]
    assert not (tmp_path / "interfaces.csv").exists()


def test_mixed_growth_and_its_slope():
    """The source sum phi_i a_i exp(-lam_i p) and v = -g'(p) / max lam_i (finite differences)."""
    strains = (Strain(0.0, 1.0), Strain(2e-2, 0.7), Strain(1e-2, 1.3))
    p = np.linspace(0.0, 30.0, 7)
    phi = np.random.default_rng(1).dirichlet(np.ones(3), size=len(p))
    g, v = mixed_growth(p, phi, strains)
    direct = sum(phi[:, i] * s.rate(p) for i, s in enumerate(strains))
    np.testing.assert_allclose(g, direct, rtol=1e-14)
    d = 1e-6
    slope = -(mixed_growth(p + d, phi, strains)[0] - mixed_growth(p - d, phi, strains)[0]) / (2 * d)
    np.testing.assert_allclose(2e-2 * v, slope, rtol=1e-7)


def test_layouts():
    x = np.array([0.0, 0.5, 1.5, 2.5, -3.0])
    y = np.zeros(5)
    np.testing.assert_array_equal(core(1.0)(x, y)[:, 0], [1, 1, 0, 0, 0])
    np.testing.assert_array_equal(core(1.0, 2.0)(x, y).argmax(axis=1), [0, 0, 1, 2, 2])
    np.testing.assert_array_equal(sector(1.0)(x, y)[:, 1], [1, 1, 1, 1, 0])
    np.testing.assert_array_equal(sector(1.0, direction=np.pi)(x, y)[:, 1], [0, 0, 0, 0, 1])
    np.testing.assert_allclose(mixture(0.25, 0.75)(x, y), np.tile([0.25, 0.75], (5, 1)))
    pts = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=float)
    tris = np.array([[0, 1, 2], [1, 3, 2]])
    table = interface_table(pts, tris, np.array([[1, 0], [0, 1], [0, 1], [0, 1]], dtype=float))
    np.testing.assert_allclose(table["area"], [1 / 6, 5 / 6])
    assert list(table["strain"]) == [0, 1]


@pytest.mark.parametrize(("strains", "match"), [
    (((-1e-3, 1.0),), "lam must be finite and >= 0"),
    (((0.0, 0.0),), r"growth must be in \(0, 100\]"),
    (((0.0, 1e300),), r"growth must be in \(0, 100\]"), (((0.0,),) * 65, "65 given, at most 64"),
    (((0.0, -1.0), (0.0, 1.0)), r"growth must be in \(0, 100\]"),
    (((0.0, 1.0, 2.0),), "a strain must be"),
    ((("x", 1.0),), "lam must be a number"),
    ("fast", "strains must be"),
])
def test_bad_strains(strains, match):
    with pytest.raises(ValueError, match=match) as err:
        continuum.Config(lam=0.0, strains=strains)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("strains", "fractions", "match"), [
    (((0.0, 1.0),) * 2, None, "give the initial fractions"),
    (((0.0, 1.0),) * 2, lambda x, y: np.full((len(x), 2), 0.6), "sum to 1"),
    (((0.0, 1.0),) * 2, lambda x, y: np.full((len(x), 3), 1 / 3), "shape"),
    (((0.0, 1.0),) * 2, lambda x, y: np.tile([1.5, -0.5], (len(x), 1)), r"in \[0, 1\]"),
    (((0.0, 1.0),) * 2, np.full((7, 2), 0.5), "shape"),
    ((), core(0.2), "need strains"),
])
def test_bad_fractions(strains, fractions, match):
    cfg = continuum.Config(**{**SMALL, "strains": strains})
    with pytest.raises(ValueError, match=match) as err:
        continuum.Simulation(cfg, layout=fractions)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("make", "match"), [
    (lambda: core(-1.0), "core radii"),
    (lambda: core(2.0, 1.0), "core radii"),
    (lambda: sector(0.0), "sector angle"),
    (lambda: mixture(0.5, 0.6), "sum to 1"),
    (lambda: check_fractions(np.full((2, 2), np.nan), 2, 2), "finite"),
    (lambda: as_strains([{"lam": 0.0, "rate": 1.0}]), "a strain must be"),
])
def test_bad_layouts(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_a_mixture_changes_composition_by_each_strains_growth():
    """A 30/70 mixture at lam = 0, a = (1, 0.5): phi_1 = 0.7 e^{t/2} / (0.3 e^t + 0.7 e^{t/2}).

    Along a material path d phi_i/dt = phi_i (g_i - g) (continuum.strains.grown_fractions);
    at lam = 0 the rates are constant, so every node holds the closed form to round-off, and
    the strain phases are G_i = a_i t.
    """
    sim = _grow(mixture(0.3, 0.7), lam=0.0, strains=((0.0, 1.0), (0.0, 0.5)))
    t = sim.state.t
    exact = 0.7 * np.exp(t / 2) / (0.3 * np.exp(t) + 0.7 * np.exp(t / 2))
    assert t > 2 and sim.state.phi[:, 1] == pytest.approx(exact, abs=1e-12)
    phases = np.tile([t, t / 2], (len(sim.state.G_strains), 1))
    np.testing.assert_allclose(sim.state.G_strains, phases, atol=1e-12)
    areas = sim.state.strain_areas
    assert areas[1] / areas.sum() == pytest.approx(exact, abs=1e-12)


def test_polygon_layout_against_shapes_by_hand():
    """polygon(): even-odd inside test, a strain per polygon, the last one winning."""
    from continuum.strains import inside_polygon, polygon

    square = [(0, 0), (2, 0), (2, 2), (0, 2)]
    notch = [(0, 0), (4, 0), (4, 4), (2, 1), (0, 4)]  # non-convex: its notch holds (2, 3)
    x = np.array([1.0, 3.0, 1.0, 2.0, 3.5, 1.0])
    y = np.array([1.0, 1.0, 1.9, 3.0, 3.0, 3.0])  # the notch's edges: y = 1 + 1.5 |x - 2|
    assert inside_polygon(x, y, square).tolist() == [True, False, True, False, False, False]
    assert inside_polygon(x, y, notch).tolist() == [True, True, True, False, True, False]
    phi = polygon(notch, square)(x, y)
    assert phi.argmax(axis=1).tolist() == [2, 1, 2, 0, 1, 0]
    with pytest.raises(ValueError, match="at least 3 finite vertices"):
        polygon([(0, 0), (1, 1)])
