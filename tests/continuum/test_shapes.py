"""The shape specification (continuum.shapes): exact areas and perimeters, one-line errors."""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ellipe

from continuum import R0, Config, Simulation, shapes
from continuum import mesh as M


def perimeter(xy):
    return float(np.sum(M.boundary_spacing(xy)))


def star_perimeter(k, eps, r):
    """int_0^{2 pi} sqrt(rho^2 + rho'^2) dtheta, rho = r (1 + eps cos k theta)."""
    def ds(t):
        return r * math.hypot(1 + eps * math.cos(k * t), eps * k * math.sin(k * t))

    return quad(ds, 0, 2 * math.pi, limit=400)[0]


# (spec, exact area, exact perimeter)
EXACT = [
    ("circle", math.pi * R0**2, 2 * math.pi * R0),
    ("circle:2.5", math.pi * 2.5**2, 5 * math.pi),
    ("ellipse:3,1.5", math.pi * 3 * 1.5, 4 * 3 * ellipe(1 - (1.5 / 3) ** 2)),
    ("rectangle:4,1", 4.0, 10.0),
    ("rectangle:4,2,0.5", 8 - (4 - math.pi) * 0.25, 12 - (8 - 2 * math.pi) * 0.5),
    ("rectangle:3,2,1", 6 - (4 - math.pi), 10 - (8 - 2 * math.pi)),
    ("star:5,0.2,8", math.pi * 64 * (1 + 0.02), star_perimeter(5, 0.2, 8)),
    ("star:3,0.5", math.pi * R0**2 * (1 + 0.125), star_perimeter(3, 0.5, R0)),
]


@pytest.mark.parametrize("spec,area,length", EXACT)
def test_outline_area_and_perimeter(spec, area, length):
    xy = shapes.outline(spec)
    assert M.polygon_area(xy) > 0  # counter-clockwise
    np.testing.assert_array_equal(M.check_polygon(xy), xy)  # simple, no repeated vertex
    assert M.polygon_area(xy) == pytest.approx(area, rel=5e-4)
    assert perimeter(xy) == pytest.approx(length, rel=5e-4)


def test_sharp_rectangle_is_exact():
    xy = shapes.outline("rectangle:4,1")
    assert M.polygon_area(xy) == pytest.approx(4.0, rel=1e-14)
    assert {(x, y) for x, y in xy} >= {(2, -0.5), (2, 0.5), (-2, 0.5), (-2, -0.5)}


@pytest.mark.parametrize("build,exact", [
    (lambda n: shapes.star(5, 0.2, 8, n), math.pi * 64 * 1.02),
    (lambda n: shapes.rectangle(4, 2, 0.5, spacing=12.0 / n), 8 - (4 - math.pi) * 0.25),
])
def test_area_converges_at_second_order(build, exact):
    errors = [abs(M.polygon_area(build(n)) - exact) for n in (256, 512, 1024)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2) < 0.15), orders


def test_circle_is_the_continuum_initial_disc():
    """``circle`` is the 256-gon of radius initial_radius, as before continuum.shapes existed."""
    np.testing.assert_array_equal(Config(lam=0.0).initial_boundary(), M.circle_polygon(R0, 256))
    np.testing.assert_array_equal(Config(lam=0.0, initial_radius=2.0).initial_boundary(),
                                  shapes.outline("circle:2"))
    np.testing.assert_array_equal(shapes.outline("ellipse:2,1"), M.ellipse_polygon(2, 1, 256))
    # star:K,EPS without R takes the default radius
    np.testing.assert_array_equal(Config(lam=0.0, initial_radius=3.0,
                                         shape="star:4,0.1").initial_boundary(),
                                  shapes.star(4, 0.1, 3.0))


@pytest.mark.parametrize("spec,words", [
    ("square:1", "unknown shape"),
    ("circle:", "takes 1 number"),
    ("circle:-1", "R must be positive"),
    ("circle:1,2", "takes 1 number"),
    ("ellipse:2", "takes 2 numbers"),
    ("ellipse:2,x", "expected numbers"),
    ("ellipse:0,1", "A must be positive"),
    ("ellipse:inf,1", "finite"),
    ("rectangle:1", "takes 2 or 3 numbers"),
    ("rectangle:2,-1", "H must be positive"),
    ("rectangle:2,1,0.6", "ROUND must be in [0, min(W, H)/2 = 0.5]"),
    ("rectangle:2,1,-0.1", "ROUND must be in"),
    ("star:5", "takes 2 or 3 numbers"),
    ("star:5,1", "EPS must be in [0, 1)"),
    ("star:5,1.5,2", "EPS must be in [0, 1)"),
    ("star:2.5,0.1", "K must be an integer >= 2"),
    ("star:5,0.1,0", "R must be positive"),
    ("polygon:", "give the file"),
    ("polygon:/nonexistent/p.csv", "not found"),
    ("line:0", "N must be an integer >= 1"),
    ("line:4", "no outline"),
    ("ellipse", "needs its numbers"),
])
def test_bad_specs_one_line(spec, words):
    with pytest.raises(ValueError) as err:
        shapes.outline(spec)
    assert words in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ValueError, match="shape|polygon"):  # the continuum's Config too
        Config(lam=0.0, time=1.0, shape=spec).validate()


def test_line_parses_but_has_no_area():
    shape = shapes.parse(" line:4 ")
    assert (shape.kind, shape.values, shape.has_area) == ("line", (4,), False)


@pytest.mark.parametrize("spec", ["rectangle:3,1,0.3", "star:3,0.3,1.5"])
def test_continuum_starts_from_the_shape(spec):
    sim = Simulation(Config(lam=1e-2, shape=spec, n_nodes=300, write_fields=False))
    exact = M.polygon_area(shapes.outline(spec))
    assert sim.state.area == pytest.approx(exact, rel=1e-2)
    record = sim.step()
    assert record.t > 0 and sim.state.area > exact
