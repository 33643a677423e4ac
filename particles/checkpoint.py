"""Checkpoints of a particle simulation (``checkpoint.npz``) and deferred stop signals.

A checkpoint saves the one state object (``state.ParticleState``: particle arrays, t, step,
random generator, warm start, next dt) with the configuration it ran with and the trajectory
bookkeeping (frames written, step of the last frame).  Format: ``np.savez`` with a JSON ``meta``
(config, t, step, next_id, rng, history, frames, dt_next), ``warm_keys``, ``warm_gamma``, the
particle arrays and ``sha256``, the checksum of all the others
(``runfiles.arrays_digest``).

The history: a run folder's checkpoint keeps only ``{"rows": n, "sha256": ...}`` of the
history.csv written just before it (the record of the steps; ``runfiles.history_record``), so its
size depends on the colony, not on how long it has run; on load the first n rows of history.csv
are checked against it and read back (``runfiles.read_history``).  A checkpoint saved
elsewhere (``Simulation.save(path)``), and every checkpoint written before this, holds the rows
in ``meta``.

The functions, the same in the continuum engine: :func:`save_checkpoint` writes a
:class:`Checkpoint` (configuration, state, history, frames), :func:`load_checkpoint` reads one
back, :func:`resume_checkpoint` finds a run folder's.

Safety (``runfiles``, one source for both engines; :func:`resume_checkpoint`): a checkpoint is
written to a temporary file, flushed, read back and verified; only then the run folder's
``checkpoint.npz``, when intact, becomes ``checkpoint.prev.npz`` and the new file takes its name
(os.replace).  Loading never unpickles (allow_pickle=False), verifies the checksum and refuses
anything damaged (emptied, cut short, bytes changed, an entry missing, an object array) with one
``runfiles.CheckpointError`` line.  A run resumes from ``checkpoint.prev.npz`` (with a warning) when
``checkpoint.npz`` is damaged, so a damaged checkpoint costs one checkpoint interval; the run's
resume then truncates the trajectory and the history to that earlier state.  Checkpoints
written before the checksum load when their zip CRCs hold.  The run folder's checkpoints are
never read through a symbolic link.

Older checkpoints load: without ``parent``/``generation`` (initial particles: -1, 0), without
``dt_next`` (``Config.dt``) or fields added to or renamed in ``Config`` since (``config.upgrade``).

SIGINT / SIGTERM / SIGHUP (a closed terminal or ssh session) during a run are deferred to the
end of the current step (``runfiles.StopRequest``) so that the run writes a checkpoint of a whole
step before stopping.
"""

from __future__ import annotations

import json
import logging
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .config import EXECUTION_FIELDS, STEP_POLICY_FIELDS, Config, upgrade
from .geometry import canonical_keys
from .runfiles import (
    HISTORY,
    PREVIOUS,
    checked,
    damaged,
    read_arrays,
    read_history,
    read_meta,
    resume_from,
    write_arrays,
)
from .state import OPTIONAL_ARRAYS, PARTICLE_ARRAYS, ParticleState

__all__ = ["EXECUTION_FIELDS", "Checkpoint", "save_checkpoint", "load_checkpoint",
           "resume_checkpoint", "checkpoint_config"]

log = logging.getLogger(__name__)

NO_FRAMES = (0, -1)
"""Trajectory bookkeeping of a simulation without output: no frame written."""


# ------------------------------------------------------------------ the particle checkpoint


@dataclass
class Checkpoint:
    """What a checkpoint holds: everything the following steps of a run depend on.

    The first four attributes are the continuum engine's ``Checkpoint``'s too.

    Attributes
    ----------
    config : Config
        The configuration it ran with.
    state : ParticleState
    history : list of dict, or dict
        The history rows so far; when saving into a run folder, the ``runfiles.history_record`` of
        the history.csv written beside it (then the checkpoint at the path becomes
        ``checkpoint.prev.npz``, :func:`write_arrays`). Loaded: the rows.
    frames : list of int
        The trajectory bookkeeping: [frames written, step of the last frame, bytes of the
        trajectory] (NO_FRAMES: none; the bytes are missing in older checkpoints).
    """

    config: Config
    state: ParticleState
    history: list[dict] | dict
    frames: list[int] = field(default_factory=lambda: list(NO_FRAMES))


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """Write ``checkpoint`` (format in the module docstring) to ``path`` safely.

    A failed write (e.g. a full disk) leaves the existing checkpoints as they were; a history
    record (a run folder) keeps the checkpoint at ``path`` as ``checkpoint.prev.npz``.
    """
    path, config, state = Path(path), checkpoint.config, checkpoint.state
    dt_next = config.dt if state.dt_next is None else state.dt_next
    meta = {"config": asdict(config), "t": state.t, "step": state.step, "next_id": state.next_id,
            "rng": state.rng.bit_generator.state, "history": checkpoint.history,
            "frames": list(checkpoint.frames), "dt_next": dt_next}
    previous = path.with_name(PREVIOUS) if isinstance(checkpoint.history, dict) else None
    write_arrays(path, {"meta": np.array(json.dumps(meta)), "warm_keys": state.warm_keys,
                        "warm_gamma": state.warm_gamma, **state.arrays()}, previous)
    log.debug("checkpoint at t = %.6g (step %d) written to %s", state.t, state.step, path)


def _saved_config(path: Path, meta: dict) -> dict:
    """The configuration fields a checkpoint's metadata holds, in today's names (upgrade)."""
    saved = checked(path, lambda: upgrade(meta["config"]))
    if not isinstance(saved, dict):
        raise damaged(path, "unexpected content (config)")
    return saved


def _config(path: Path, saved: dict) -> Config:
    """The Config of saved fields (CheckpointError when they are not Config's).

    A value Config refuses raises its ValueError.
    """
    try:
        return Config(**saved)
    except TypeError:
        raise damaged(path, "unexpected content (config)") from None


def checkpoint_config(path: Path) -> Config:
    """The configuration the checkpoint at ``path`` was written with."""
    path = Path(path)
    return _config(path, _saved_config(path, read_meta(path, read_arrays(path))))


def _check_config(path: Path, saved: dict, config: Config, change_step_policy: bool) -> None:
    """ValueError unless ``config`` equals the saved one up to the fields free on resume."""
    now = json.loads(json.dumps(asdict(config)))
    free = EXECUTION_FIELDS + (STEP_POLICY_FIELDS if change_step_policy else ())
    for k in free:
        saved.pop(k, None)
        now.pop(k)
    if saved != now:
        wrong = sorted(k for k in {*saved, *now} if saved.get(k) != now.get(k))
        hint = ("; a changed step policy resumes with change_step_policy=True "
                "(colony particles --change-step-policy)"
                if set(wrong) <= set(STEP_POLICY_FIELDS) else "")
        raise ValueError(f"checkpoint {path} belongs to a different configuration "
                         f"(differs in {', '.join(wrong)}){hint}")


def _particle_arrays(path: Path, arrays: dict) -> dict[str, np.ndarray]:
    """The particle arrays of a checkpoint (parent, generation, strain when saved), checked.

    One-dimensional, of one length, real numbers; the warm start's two arrays of one length.
    """
    optional = ("parent", "generation", *OPTIONAL_ARRAYS)
    names = [k for k in PARTICLE_ARRAYS if k in arrays or k not in optional]
    found = checked(path, lambda: {k: arrays[k] for k in [*names, "warm_keys", "warm_gamma"]})
    n, warm = found["x"].shape, found["warm_keys"].shape
    for k, a in found.items():
        if a.ndim != 1 or a.dtype.kind not in "iuf" or a.shape != (warm if "warm" in k else n):
            raise damaged(path, f"unexpected content ({k})")
    return found


def _state(path: Path, arrays: dict, meta: dict, config: Config) -> ParticleState:
    """The ParticleState of a checkpoint's arrays and metadata."""
    found = _particle_arrays(path, arrays)
    warm_keys, warm_gamma = found.pop("warm_keys"), found.pop("warm_gamma")
    rng = np.random.default_rng(config.seed)
    rng.bit_generator.state = meta["rng"]
    return ParticleState(**found, next_id=int(meta["next_id"]), t=float(meta["t"]),
                         step=int(meta["step"]), rng=rng, warm_keys=canonical_keys(warm_keys),
                         warm_gamma=warm_gamma, dt_next=float(meta.get("dt_next", config.dt)))


def _history(path: Path, saved) -> list[dict]:
    """The history rows of a checkpoint: kept in it, or those of history.csv it recorded."""
    if isinstance(saved, dict):
        return read_history(path.parent / HISTORY, saved, path)
    if not (isinstance(saved, list) and all(isinstance(row, dict) for row in saved)):
        raise damaged(path, "unexpected content (history)")
    return saved


def _frames(path: Path, saved) -> list[int]:
    """The trajectory bookkeeping [frames written, step of the last frame(, bytes)], checked."""
    if not (isinstance(saved, list) and len(saved) in (2, 3)
            and all(type(v) is int for v in saved) and saved[0] >= 0):
        raise damaged(path, "unexpected content (frames)")
    return saved


def load_checkpoint(path: Path, config: Config | None = None, *, follow: bool = True,
                    change_step_policy: bool = False) -> Checkpoint:
    """The :class:`Checkpoint` written by :func:`save_checkpoint` at ``path``.

    ``config``: the configuration to continue with, equal to the checkpoint's up to
    ``EXECUTION_FIELDS`` (and ``STEP_POLICY_FIELDS`` with ``change_step_policy``; ValueError
    otherwise); None: the checkpoint's.  Raises CheckpointError when the file is damaged (or
    its history.csv does not hold the rows it recorded), NotCheckpointError when it is no
    checkpoint, or the continuum's (runfiles.read_arrays, read_meta).  A checkpoint written
    before the lineage was tracked has no ``parent`` and ``generation`` arrays: the particles
    then present are loaded as initial ones (parent -1, generation 0), and their daughters
    count generations from them.  With ``change_step_policy`` the next step follows ``config``'s
    policy: ``dt_next`` is ``config.dt`` with a fixed step, else the saved ``dt_next`` capped
    at ``config.dt``.  ``follow`` False: a symbolic link is refused.
    """
    path = Path(path)
    arrays = read_arrays(path, follow)
    meta = read_meta(path, arrays)
    saved = _saved_config(path, meta)
    if config is None:
        config = _config(path, dict(saved))
    _check_config(path, saved, config, change_step_policy)
    state = checked(path, lambda: _state(path, arrays, meta, config))
    frames = _frames(path, checked(path, lambda: meta["frames"]))
    history = _history(path, checked(path, lambda: meta["history"]))
    if change_step_policy:
        state.dt_next = (config.dt if config.step_control == "fixed"
                         else min(state.dt_next, config.dt))
    return Checkpoint(config, state, history, frames)


def resume_checkpoint(out: Path, config: Config, *, change_step_policy: bool = False
                      ) -> tuple[Path, Checkpoint]:
    """(path, :func:`load_checkpoint` of it) of the run folder ``out``'s checkpoint.

    ``checkpoint.npz``, or ``checkpoint.prev.npz`` when that one is damaged (resume_from);
    never through a symbolic link.
    """
    return resume_from(Path(out), lambda path: load_checkpoint(
        path, config, follow=False, change_step_policy=change_step_policy))
