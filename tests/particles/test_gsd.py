"""The trajectory.gsd file (particles/output.py), read back by gsd and by OVITO.

The HOOMD frames read back exactly, and OVITO's GSD reader draws each particle as a
sphero-cylinder of its own length lying in the plane along theta.

The OVITO tests need the optional ``ovito`` module (skipped without it); they open the file with
``ovito.io.import_file`` alone, as a user would, so they check the file, not a helper pipeline.
"""

from __future__ import annotations

import numpy as np
import pytest

from particles.output import (
    BOX_MARGIN,
    append_frame,
    box_edge,
    count_frames,
    read_trajectory,
    rod_quaternion,
    truncate_trajectory,
)
from particles.state import B, ParticleState


def rod_axis(q: np.ndarray) -> np.ndarray:
    """Image of the local z axis under unit quaternions (w, x, y, z), shape (n, 3).

    R(q) e_z = (2 (x z + w y), 2 (y z - w x), 1 - 2 (x^2 + y^2)).
    """
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.column_stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def _states():
    """Two frames: 3 rods, then 4 (one divided: new ids), angles in all four quadrants."""
    a = ParticleState.from_arrays([0.0, 2.0, -1.5], [0.0, 0.5, 3.0], [0.3, 2.5, -2.0],
                                  [1.2, 1.9, 1.5])
    a.stress[:] = [0.1, 0.2, 0.3]
    b = a.copy()
    b.x = np.append(b.x, 4.0)
    b.y = np.append(b.y, -3.0)
    b.theta = np.append(b.theta, -0.7)
    b.length = np.append(b.length, 1.05)
    b.stress = np.append(b.stress, 0.0)
    b.ids = np.array([0, 3, 2, 4])
    b.next_id = 5
    b.parent = np.where(b.ids > 2, 1, -1)
    b.generation = (b.ids > 2).astype(np.int64)
    return [(a, 0, 0.0), (b, 10, 0.25)]


def _write(path, with_lineage=False):
    for state, step, t in _states():
        if with_lineage:  # fields a state may carry (written when present)
            state.parent = np.where(state.ids > 2, 1, -1)
            state.generation = (state.ids > 2).astype(np.int64)
        append_frame(path, state, step, t=t)
    return path


def test_quaternion_turns_local_z_into_the_rod_axis():
    theta = np.linspace(-np.pi, np.pi, 9)
    q = rod_quaternion(theta)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(rod_axis(q), np.column_stack(
        [np.cos(theta), np.sin(theta), np.zeros_like(theta)]), atol=1e-15)
    np.testing.assert_allclose(2 * np.arctan2(q[:, 3], q[:, 0]), theta, atol=1e-15)


def test_frames_read_back(tmp_path):
    path = _write(tmp_path / "trajectory.gsd", with_lineage=True)
    assert count_frames(path) == 2
    frames = list(read_trajectory(path))
    for fr, (state, step, t) in zip(frames, _states(), strict=True):
        assert fr.step == step and fr.t == t and fr.n == state.n
        for k in ("x", "y", "length", "stress"):
            np.testing.assert_allclose(getattr(fr, k), getattr(state, k), rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose(np.angle(np.exp(1j * (fr.theta - state.theta))), 0, atol=1e-6)
        np.testing.assert_array_equal(fr.ids, state.ids)
        np.testing.assert_array_equal(fr.parent, np.where(state.ids > 2, 1, -1))
        np.testing.assert_array_equal(fr.generation, (state.ids > 2).astype(int))
    assert [f.step for f in read_trajectory(path, frames=[1])] == [10]


def test_time_from_history_without_log_time(tmp_path):
    path = tmp_path / "trajectory.gsd"
    for state, step, _ in _states():
        state.parent = state.generation = None  # as written before lineage was tracked
        append_frame(path, state, step)  # t not given
    (tmp_path / "history.csv").write_text("step,t\n5,0.1\n10,0.3\n")
    frames = list(read_trajectory(path))
    assert [f.t for f in frames] == [0.0, 0.3]
    assert frames[0].parent is None and frames[0].generation is None


def test_truncate_keeps_the_new_fields(tmp_path):
    path = _write(tmp_path / "trajectory.gsd")
    truncate_trajectory(path, 1)
    (fr,) = list(read_trajectory(path))
    assert fr.step == 0 and fr.t == 0.0 and list(fr.ids) == [0, 1, 2]


def test_missing_trajectory_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="trajectory not found"):
        list(read_trajectory(tmp_path / "nope.gsd"))


def test_box_keeps_periodic_images_apart():
    for state, _, _ in _states():
        ends = np.concatenate([
            np.column_stack([state.x + s * 0.5 * (state.length - B) * np.cos(state.theta),
                             state.y + s * 0.5 * (state.length - B) * np.sin(state.theta)])
            for s in (-1, 1)])
        reach = float(np.max(np.abs(ends))) + B / 2  # farthest particle point from the axes
        assert box_edge(state) == pytest.approx(2 * (reach + BOX_MARGIN))


def _ovito_frames(path):
    ovito_io = pytest.importorskip("ovito.io")
    pipeline = ovito_io.import_file(str(path))
    return [pipeline.compute(i) for i in range(pipeline.num_frames)]


def test_ovito_reads_rods_in_the_plane(tmp_path):
    from_ovito = _ovito_frames(_write(tmp_path / "trajectory.gsd", with_lineage=True))
    from ovito.vis import ParticlesVis

    assert len(from_ovito) == 2
    for data, (state, step, t) in zip(from_ovito, _states(), strict=True):
        part = data.particles
        assert part.count == state.n
        assert data.attributes["Timestep"] == step and data.attributes["Time"] == t
        np.testing.assert_allclose(part.positions[:, :2], np.column_stack([state.x, state.y]),
                                   atol=1e-6)
        np.testing.assert_array_equal(part["Particle Identifier"], state.ids)
        np.testing.assert_array_equal(part["parent"], np.where(state.ids > 2, 1, -1))
        # the type is a sphero-cylinder; its axis is the local z axis turned by Orientation,
        # OVITO's quaternion (x, y, z, w)
        (rod,) = part.particle_types.types
        assert rod.name == "rod" and rod.shape == ParticlesVis.Shape.Spherocylinder
        qx, qy, qz, qw = np.asarray(part["Orientation"], dtype=float).T
        axis = rod_axis(np.column_stack([qw, qx, qy, qz]))
        np.testing.assert_allclose(axis, np.column_stack(
            [np.cos(state.theta), np.sin(state.theta), 0 * state.theta]), atol=1e-6)
        # Aspherical Shape (radius, -, cylinder length) and Radius give l = L + b, diameter b
        shape = np.asarray(part["Aspherical Shape"], dtype=float)
        np.testing.assert_allclose(shape[:, 0], B / 2)
        np.testing.assert_allclose(shape[:, 2] + 2 * shape[:, 0], state.length, atol=1e-6)
        np.testing.assert_allclose(part["Radius"], B / 2)
        np.testing.assert_allclose(part["length"], state.length, atol=1e-6)
        # OVITO takes the cell as periodic: the images (shifted by the cell vectors) must not
        # reach the colony, i.e. the colony's span plus b is less than each cell edge
        cell = np.asarray(data.cell)
        assert data.cell.is2D
        ends = np.concatenate([part.positions[:, :2] + s * 0.5 * shape[:, 2:3] * axis[:, :2]
                               for s in (-1, 1)])
        span = ends.max(axis=0) - ends.min(axis=0) + B
        assert np.all(span + 2 * BOX_MARGIN <= np.diag(cell[:2, :2]) + 1e-6)
