"""Checkpoints of a particle simulation (``checkpoint.npz``) and deferred stop signals.

A checkpoint saves the one state object (``state.ParticleState``: particle arrays, t, step,
random generator, warm start, next dt) with the configuration it ran with, the history rows and
the trajectory bookkeeping (frames written, step of the last frame), atomically (written to a
temporary file, then renamed).  Format: ``np.savez`` with a JSON ``meta`` (config, t, step,
next_id, rng, history, frames, dt_next), ``warm_keys``, ``warm_gamma`` and the particle arrays.
Older checkpoints load: without ``parent``/``generation`` (initial particles: -1, 0), without
``dt_next`` (``Config.dt``) or fields added to or renamed in ``Config`` since (``config.upgrade``).

SIGINT / SIGTERM during a run are deferred to the end of the current step (:class:`StopRequest`)
so that the run writes a checkpoint of a whole step before stopping.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import threading
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .config import EXECUTION_FIELDS, STEP_POLICY_FIELDS, Config, upgrade
from .geometry import canonical_keys
from .state import ParticleState

log = logging.getLogger(__name__)

NO_FRAMES = (0, -1)
"""Trajectory bookkeeping of a simulation without output: no frame written."""


def save_checkpoint(path: Path, config: Config, state: ParticleState, history: list[dict],
                    frames=NO_FRAMES) -> None:
    """Write ``state`` (with ``config``, ``history`` and ``frames``) to ``path`` atomically.

    A failed write (e.g. a full disk) leaves the previous checkpoint as it was.
    """
    dt_next = config.dt if state.dt_next is None else state.dt_next
    meta = {"config": asdict(config), "t": state.t, "step": state.step, "next_id": state.next_id,
            "rng": state.rng.bit_generator.state, "history": history, "frames": list(frames),
            "dt_next": dt_next}
    tmp = path.with_name(path.name + ".tmp.npz")
    try:
        np.savez(tmp, meta=np.array(json.dumps(meta)), warm_keys=state.warm_keys,
                 warm_gamma=state.warm_gamma, **state.arrays())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    log.debug("checkpoint at t = %.6g (step %d) written to %s", state.t, state.step, path)


def _saved_config(meta: dict) -> dict:
    """The configuration fields a checkpoint's metadata holds, in today's names (upgrade)."""
    return upgrade(meta["config"])


def checkpoint_config(path: Path) -> Config:
    """The configuration the checkpoint at ``path`` was written with."""
    with np.load(path) as z:
        return Config(**_saved_config(json.loads(str(z["meta"]))))


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


def load_checkpoint(path: Path, config: Config, change_step_policy: bool = False
                    ) -> tuple[ParticleState, list[dict], list[int]]:
    """(state, history, frames) saved by :func:`save_checkpoint`, for ``config``.

    Raises ValueError when ``config`` differs from the checkpoint's in a field other than
    ``EXECUTION_FIELDS`` (and ``STEP_POLICY_FIELDS`` with ``change_step_policy``).  A
    checkpoint written before the lineage was tracked has no ``parent`` and ``generation``
    arrays: the particles then present are loaded as initial ones (parent -1, generation 0),
    and their daughters count generations from them.  With ``change_step_policy`` the next
    step follows ``config``'s policy: ``dt_next`` is ``config.dt`` with a fixed step, else the
    saved ``dt_next`` capped at ``config.dt``.
    """
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        _check_config(path, _saved_config(meta), config, change_step_policy)
        lineage = {k: z[k] for k in ("parent", "generation") if k in z.files}
        rng = np.random.default_rng(config.seed)
        rng.bit_generator.state = meta["rng"]
        state = ParticleState(z["x"], z["y"], z["theta"], z["length"], z["stress"], z["ids"],
                              int(meta["next_id"]), **lineage, t=meta["t"], step=meta["step"],
                              rng=rng, warm_keys=canonical_keys(z["warm_keys"]),
                              warm_gamma=z["warm_gamma"],
                              dt_next=meta.get("dt_next", config.dt))
    if change_step_policy:
        state.dt_next = (config.dt if config.step_control == "fixed"
                         else min(state.dt_next, config.dt))
    return state, meta["history"], meta["frames"]


class StopRequest:
    """SIGINT / SIGTERM deferred to the end of the current step (main thread only).

    ``install`` replaces the handlers; the first signal sets ``signum`` and puts the previous
    handlers back, so the run can write a checkpoint of a whole step before stopping, while a
    second signal acts at once. ``restore`` puts them back when no signal came.  Also a
    context manager (install on entry, restore on exit).
    """

    def __init__(self):
        self.signum = None
        self._previous = {}

    def install(self) -> StopRequest:
        """Catch SIGINT and SIGTERM (from the main thread only); returns self."""
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signum = signum
        self.restore()

    def restore(self) -> None:
        """Put the previous signal handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}

    def __enter__(self) -> StopRequest:
        return self.install()

    def __exit__(self, *exc) -> None:
        self.restore()

    def reraise(self) -> None:
        """Re-raise the signal that came, after the final checkpoint.

        KeyboardInterrupt for SIGINT, SystemExit(128 + signal) for SIGTERM, nothing when no
        signal came.
        """
        if self.signum == signal.SIGINT:
            raise KeyboardInterrupt
        if self.signum is not None:
            raise SystemExit(128 + self.signum)
