"""Lineage of the particles and the time of each trajectory frame.

Lineage: state.ParticleState.parent, .generation; division.divide. Time: log/Time. Checked by
invariants of the division tree, not by stored trajectories.
"""

import json

import gsd.hoomd
import numpy as np
import pytest

from particles import Config, run
from particles.division import divide
from particles.output import read_trajectory
from particles.state import ParticleState


@pytest.fixture(scope="module")
def grown(tmp_path_factory):
    """One cell grown to radius 6 (lam = 1e-2, a frame every 5 steps): (folder, Simulation)."""
    out = tmp_path_factory.mktemp("lineage")
    colony = run(Config(lam=1e-2, radius=6, seed=3, output_every=0.1), out)
    return out, colony


def _tree(frames):
    """Map id -> (parent, generation) over all frames, checking each id keeps its values."""
    tree = {}
    for fr in frames:
        for i, p, g in zip(fr.ids.tolist(), fr.parent.tolist(), fr.generation.tolist(),
                           strict=True):
            assert tree.setdefault(i, (p, g)) == (p, g), f"id {i} changed its lineage"
    return tree


def test_divide_gives_both_daughters_the_mother_and_generation_plus_one():
    st = ParticleState.from_arrays([0.0, 3.0, -3.0], [0.0, 0.0, 0.0], [0.0, 0.5, 1.0],
                                   [2.1, 1.2, 2.5])
    st.ids[:] = [7, 4, 9]
    st.next_id = 10
    st.parent[:] = [2, 1, 3]
    st.generation[:] = [2, 5, 3]
    assert divide(st, np.random.default_rng(0), 0.02) == 2
    # daughter 1 in the mother's slot, daughter 2 appended; new ids next_id, next_id + 1, ...
    np.testing.assert_array_equal(st.ids, [10, 4, 11, 12, 13])
    np.testing.assert_array_equal(st.parent, [7, 1, 9, 7, 9])
    np.testing.assert_array_equal(st.generation, [3, 5, 4, 3, 4])
    assert st.next_id == 14
    c = st.copy()
    c.parent[0] = -5
    assert st.parent[0] == 7 and set(c.arrays()) >= {"parent", "generation"}


def test_generation_is_the_length_of_the_parent_chain(grown):
    """Following parent ids back reaches the initial cell (id 0) in ``generation`` steps.

    Ids are unique; every mother has exactly two daughters, both of her generation + 1.
    """
    out, colony = grown
    frames = list(read_trajectory(out / "trajectory.gsd"))
    for fr in frames:
        assert np.unique(fr.ids).size == fr.n
    tree = _tree(frames)
    assert tree[0] == (-1, 0) and frames[0].ids.tolist() == [0]
    for i, (_parent, g) in tree.items():
        steps, j = 0, i
        while tree[j][0] != -1:
            j = tree[j][0]
            steps += 1
        assert (j, steps) == (0, g), f"id {i}"
    children = {}
    for i, (p, _generation) in tree.items():
        if p != -1:
            children.setdefault(p, []).append(i)
    for p, kids in children.items():
        assert len(kids) == 2 and all(tree[k][1] == tree[p][1] + 1 for k in kids)
    last = frames[-1]
    np.testing.assert_array_equal(last.ids, colony.state.ids)
    np.testing.assert_array_equal(last.parent, colony.state.parent)
    np.testing.assert_array_equal(last.generation, colony.state.generation)
    assert colony.state.parent.dtype == colony.state.generation.dtype == np.int64
    assert colony.state.n >= 64 and colony.state.generation.max() >= 6


def test_every_frame_carries_the_time_of_its_step(grown):
    out, colony = grown
    t_of = {0: 0.0} | {r["step"]: r["t"] for r in colony.history}
    with gsd.hoomd.open(str(out / "trajectory.gsd")) as traj:
        assert len(traj) == 1 + len(colony.history) // 5 + (len(colony.history) % 5 != 0)
        for fr in traj:
            assert "Time" in fr.log
            assert float(fr.log["Time"][0]) == t_of[int(fr.configuration.step)]
        assert float(traj[0].log["Time"][0]) == 0.0
        assert int(traj[-1].configuration.step) == len(colony.history)


def test_resumed_run_has_the_lineage_of_an_uninterrupted_one(tmp_path):
    cfg = Config(lam=1e-2, time=2.2, dt=0.01, seed=2, output_every=0.07)
    full, part = tmp_path / "full", tmp_path / "part"
    full.mkdir()
    part.mkdir()
    a = run(cfg, full).state
    assert not run(cfg, part, max_steps=120).finished
    b = run(cfg, part).state
    for k in ("ids", "parent", "generation"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert a.generation.max() >= 2
    with np.load(part / "checkpoint.npz") as z:
        np.testing.assert_array_equal(z["parent"], a.parent)
        np.testing.assert_array_equal(z["generation"], a.generation)
    fa = list(read_trajectory(full / "trajectory.gsd"))
    fb = list(read_trajectory(part / "trajectory.gsd"))
    assert len(fa) == len(fb)
    for x, y in zip(fa, fb, strict=True):
        assert x.t == y.t
        np.testing.assert_array_equal(x.parent, y.parent)
        np.testing.assert_array_equal(x.generation, y.generation)


def test_checkpoint_without_lineage_resumes_counting_from_its_particles(tmp_path):
    """A checkpoint written before parent and generation were saved resumes alike.

    Same result; its particles count as initial ones (parent -1, generation 0).
    """
    cfg = Config(lam=1e-2, time=2.2, dt=0.01, seed=2)
    full, old = tmp_path / "full", tmp_path / "old"
    full.mkdir()
    old.mkdir()
    a = run(cfg, full).state
    run(cfg, old, max_steps=120)
    ck = old / "checkpoint.npz"
    with np.load(ck) as z:
        arrays = dict(z)
    meta = json.loads(str(arrays["meta"]))
    saved_ids = arrays["ids"]
    saved_gen = dict(zip(saved_ids.tolist(), arrays.pop("generation").tolist(), strict=True))
    del arrays["parent"], arrays["sha256"]  # nor a checksum then
    assert max(saved_gen.values()) >= 1 and meta["step"] == 120
    np.savez(ck, **arrays)
    b = run(cfg, old).state
    assert (full / "particles.csv").read_bytes() == (old / "particles.csv").read_bytes()
    np.testing.assert_array_equal(a.ids, b.ids)
    present = np.isin(b.ids, saved_ids)
    assert np.all(b.parent[present] == -1) and np.all(b.generation[present] == 0)
    born = ~present
    assert born.any()
    np.testing.assert_array_equal(b.parent[born], a.parent[born])
    # generations restart from the saved particles: full = old + the saved ancestor's generation
    tree = _tree(read_trajectory(full / "trajectory.gsd"))
    for i, g_old, g_full in zip(b.ids.tolist(), b.generation.tolist(), a.generation.tolist(),
                                strict=True):
        j = i
        while j not in saved_gen:
            j = tree[j][0]
        assert g_full == g_old + saved_gen[j]
