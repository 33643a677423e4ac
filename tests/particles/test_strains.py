"""Strains in the particle engine (issue 32): identical strains, exact growth, inheritance, outputs.

Exact checks: two identical strains are the one-strain run bit for bit (the per-cell law is the
same numbers); at lam = 0 each strain's summed length grows exactly as exp(a_i t) (the growth
law l exp(a dt) per step, division keeps length), whatever the contacts do.
"""

import csv
from dataclasses import replace

import gsd.hoomd
import numpy as np
import pytest

import particles
from particles import Config
from particles.division import divide
from particles.strains import draw_strains, growth_law

BASE = Config(lam=1e-2, time=2.0, seed=5, threads=1)


def halves(x, y):
    """Strain 0 left of the y axis, strain 1 right of it."""
    right = (np.asarray(x) >= 0).astype(float)
    return np.stack([1 - right, right], axis=1)


@pytest.fixture(scope="module")
def grown():
    """A colony of ~40 cells grown from one (t = 3.3, lam = 1e-2)."""
    return particles.run(replace(BASE, time=3.3)).state


def _history(sim):
    keep = particles.output.HISTORY_COLUMNS
    return [{k: r[k] for k in keep if k in r} for r in sim.history]


@pytest.mark.parametrize("layout", [halves, lambda x, y: np.full((len(x), 2), 0.5)])
def test_identical_strains_are_the_one_strain_run_bit_for_bit(grown, layout):
    cfg = replace(BASE, time=grown.t + 1.0)
    one = particles.run(cfg, state=grown)
    two = particles.run(replace(cfg, strains=[(1e-2, 1.0), (1e-2, 1.0)]), state=grown,
                        layout=layout)
    assert len(one.history) > 40 and one.state.n > 2 * grown.n
    assert _history(two) == _history(one)
    for k, a in one.state.arrays().items():
        assert np.array_equal(a, getattr(two.state, k)), k
    assert set(two.state.strain) == {0, 1}  # both strains are there
    assert len(two.state.strain) == two.state.n


def test_each_strain_grows_as_exp_of_its_rate_at_lam_0(grown):
    """Lam = 0: sum of l over strain i is L_i(0) exp(a_i t) to round-off (a = 1 and 0.4)."""
    cfg = replace(BASE, lam=0.0, time=grown.t + 1.5, strains=[(0.0, 1.0), (0.0, 0.4)])
    sim = particles.Simulation(cfg, state=grown, layout=halves)
    l0 = np.bincount(sim.state.strain, weights=sim.state.length, minlength=2)
    sim.advance()
    l1 = np.bincount(sim.state.strain, weights=sim.state.length, minlength=2)
    t = sim.state.t - grown.t
    assert t == pytest.approx(1.5) and sim.state.n > 2 * grown.n
    np.testing.assert_allclose(l1 / l0, np.exp(np.array([1.0, 0.4]) * t), rtol=1e-12)
    last = sim.history[-1]
    assert last["n_strain_0"] + last["n_strain_1"] == sim.state.n
    assert last["total_length_1"] == pytest.approx(l1[1], rel=1e-15)


def test_daughters_inherit_the_strain(grown):
    state = grown.copy()
    state.strain = np.arange(state.n) % 3
    state.length[:] = 2.0  # every cell divides
    mother = dict(zip(state.ids, state.strain, strict=True))
    m = divide(state, np.random.default_rng(0), 0.02)
    assert m == grown.n and state.n == 2 * grown.n
    assert all(s == mother[p] for p, s in zip(state.parent, state.strain, strict=True))


def test_growth_law_and_draws():
    assert growth_law((), 0.3, None) == (0.3, 1.0)
    lam, rate = growth_law(((0.0, 1.0), (0.5, 2.0)), 9.0, np.array([1, 0, 1]))
    assert lam.tolist() == [0.5, 0.0, 0.5] and rate.tolist() == [2.0, 1.0, 2.0]
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, 20000)
    s = draw_strains(lambda x, y: np.tile([0.25, 0.75], (len(x), 1)), x, x, 2, rng)
    assert abs(s.mean() - 0.75) < 0.02  # 5 sigma = 0.015
    pure = draw_strains(halves, x, x, 2, rng)
    assert np.array_equal(pure, (x >= 0).astype(int))


def test_outputs_carry_the_strain_and_resume_bit_for_bit(grown, tmp_path):
    (tmp_path / "one").mkdir()  # a one-strain run beside it: its frames carry no strain
    particles.run(replace(BASE, time=grown.t + 0.1), tmp_path / "one", state=grown)
    cfg = replace(BASE, time=grown.t + 0.6, strains=[(0.0, 1.0), (1e-2, 1.0)], output_every=0.1)
    full, part = tmp_path / "full", tmp_path / "part"
    full.mkdir()
    part.mkdir()
    a = particles.run(cfg, full, state=grown, layout=halves)
    particles.run(cfg, part, state=grown, layout=halves, max_steps=20)
    b = particles.run(cfg, part)  # resumes from the checkpoint, strains included
    assert len(a.history) > 20
    for k, v in a.state.arrays().items():
        assert np.array_equal(v, getattr(b.state, k)), k
    for name in ("history.csv", "particles.csv"):
        assert (full / name).read_bytes() == (part / name).read_bytes()
    with open(full / "particles.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(float(r["strain"])) for r in rows] == a.state.strain.tolist()
    with open(full / "history.csv") as fh:
        header = next(csv.reader(fh))
    assert header[-4:] == ["n_strain_0", "n_strain_1", "total_length_0", "total_length_1"]
    with gsd.hoomd.open(str(full / "trajectory.gsd")) as traj:
        last = traj[-1]
        assert last.particles.types == ["strain_0", "strain_1"]
        assert np.array_equal(last.particles.typeid, a.state.strain)
    frames = list(particles.read_trajectory(full / "trajectory.gsd"))
    assert np.array_equal(frames[-1].strain, a.state.strain)
    assert next(particles.read_trajectory(tmp_path / "one" / "trajectory.gsd")).strain is None
    assert '"strains"' in (full / "config.json").read_text()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"layout": halves}, "need strains in the Config"),
    ({"config": replace(BASE, strains=[(0.0,)]), "layout": np.array([0, 1])},
     "integers in"),
    ({"config": replace(BASE, strains=[(0.0,), (0.1,)]), "layout": lambda x, y: x},
     "must be finite, of shape"),
    ({"config": replace(BASE, strains=[(0.0,), (0.1,)]),
      "layout": lambda x, y: np.tile([0.7, 0.7], (len(x), 1))}, "sum to 1"),
])
def test_bad_strains_are_refused_in_one_line(grown, kwargs, match):
    config = kwargs.pop("config", BASE)
    with pytest.raises(ValueError, match=match):
        particles.Simulation(config, state=grown, **kwargs)


@pytest.mark.parametrize(("strains", "match"), [
    ("0.1", "list of strains"), ([(0.1, 0.0)], r"growth must be in \(0, 100\]"),
    ([(0.1, 1e300)], r"growth must be in \(0, 100\]"), ([(0.0,)] * 65, "65 given, at most 64"),
    ([(-1.0,)], "lam must be >= 0"), ([(1, 2, 3)], "must be"), ([(float("nan"),)], "finite"),
])
def test_bad_strain_configs(strains, match):
    with pytest.raises(ValueError, match=match):
        Config(lam=0.0, strains=strains)
