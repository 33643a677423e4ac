"""Checkpoints of a continuum run and the deferred handling of SIGINT / SIGTERM.

A checkpoint (``checkpoint.npz`` in the run folder, written atomically: a temporary file,
then ``os.replace``) holds everything the following steps depend on, so a simulation loaded
from it continues bit-identically:

- the arrays of the :class:`~continuum.state.State`: ``points``, ``tris``, ``G``, ``p``,
  ``u``, ``g``, ``psi`` (Psi's cell values), ``psi_phase`` (the phase offsets of Psi's windows
  with ``psi_transport = "characteristics"``), ``p_prev`` (when set) and ``amg``, the CSR data
  of the matrix the pressure solver's AMG hierarchy was built from (when there is one; the
  loaded solver rebuilds the identical hierarchy, continuum.pressure.amg_hierarchy);
- ``meta``, one JSON string: ``config`` (the Config fields), ``colony`` (the scalars t, nb,
  n_remesh, newton, krylov, h_mesh, hmean_mesh, dt_prev, step, timings), ``history`` (the
  rows of history.csv so far) and the run's output bookkeeping: ``frames`` (the VTU frames
  written, (t, file) pairs), ``next_frame`` (time of the next frame) and ``done`` (the goal
  was reached).

A checkpoint resumes under a configuration equal to the saved one up to ``EXECUTION_FIELDS``
(settings that do not change the result). Checkpoints of earlier versions (without ``step``)
load too (as finite volumes when their configuration has no ``psi_transport``).

:class:`StopRequest` defers SIGINT and SIGTERM to the end of the current step, so that
``continuum.run`` can write a checkpoint of a whole step before stopping.
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

from continuum.sizes import TRANSPORT_REMAP, CharacteristicSizes, LengthGrid, SizeDistribution
from continuum.state import State

__all__ = ["CHECKPOINT", "EXECUTION_FIELDS", "save", "load", "check_resumable",
           "remove_later_frames", "StopRequest"]

log = logging.getLogger(__name__)

EXECUTION_FIELDS = ("checkpoint_seconds",)
"""Configuration fields that do not change the result: a checkpoint resumes whatever they are."""

CHECKPOINT = "checkpoint.npz"
"""File name of the checkpoint in the run folder."""

# State attribute -> checkpoint name (the names of the format, kept from its first version)
_SCALARS = {"t": "t", "n_boundary": "nb", "n_remesh": "n_remesh", "newton": "newton",
            "krylov": "krylov", "h_mesh": "h_mesh", "h_mean_mesh": "hmean_mesh",
            "dt_prev": "dt_prev"}
_ARRAYS = {"points": "points", "triangles": "tris", "G": "G", "p": "p", "u": "u", "g": "g"}


def save(path: Path, config, state: State, amg: np.ndarray | None, history: list[dict],
         frames: list | None = None, next_frame: float = float("inf"), done: bool = False
         ) -> None:
    """Write a checkpoint of ``state`` (format in the module docstring) to ``path`` atomically.

    Parameters
    ----------
    path : Path
        The checkpoint file (a failed write leaves an existing one as it was).
    config : Config
        The run's configuration.
    state : State
    amg : ndarray or None
        ``PressureSolver.amg_state()``.
    history : list of dict
        The history rows so far.
    frames, next_frame, done
        The run's output bookkeeping (module docstring).
    """
    path = Path(path)
    scalars = {name: getattr(state, attr) for attr, name in _SCALARS.items()}
    scalars["step"] = state.step
    scalars["timings"] = dict(state.timings)
    arrays = {name: getattr(state, attr) for attr, name in _ARRAYS.items()}
    arrays["psi"] = state.sizes.n
    if isinstance(state.sizes, CharacteristicSizes):
        arrays["psi_phase"] = state.sizes.phase
    if state.p_prev is not None:
        arrays["p_prev"] = state.p_prev
    if amg is not None:
        arrays["amg"] = amg
    meta = {"config": asdict(config), "colony": scalars, "history": history,
            "frames": [] if frames is None else frames, "next_frame": next_frame, "done": done}
    tmp = path.with_name(path.name + ".tmp.npz")
    try:
        np.savez(tmp, meta=np.array(json.dumps(meta)), **arrays)
        os.replace(tmp, path)
    finally:  # a failed write (e.g. a full disk) leaves the previous checkpoint as it was
        tmp.unlink(missing_ok=True)
    log.debug("checkpoint at t = %.6g written to %s", state.t, path)


def load(path: Path, config=None) -> tuple:
    """Read a checkpoint written by :func:`save`.

    Parameters
    ----------
    path : Path
    config : Config, optional
        Checked against the saved configuration (:func:`check_resumable`); None: no check.

    Returns
    -------
    (config_fields, state, amg, history, frames, next_frame, done)
        ``config_fields`` the saved configuration (dict), ``amg`` the saved AMG matrix data or
        None, ``frames`` a list of (t, file) tuples.
    """
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        # checkpoints from before Config.element solved with P1 elements
        meta["config"].setdefault("element", "P1")
        if config is not None:
            check_resumable(path, meta["config"], config)
        arrays = {k: z[k] for k in z.files if k != "meta"}
    scalars = meta["colony"]
    history = meta["history"]
    grid = LengthGrid(meta["config"]["n_length_cells"])
    if "psi_phase" in arrays:
        remap = TRANSPORT_REMAP.get(meta["config"].get("psi_transport"), "cells")
        sizes = CharacteristicSizes(grid, arrays["psi"], arrays["psi_phase"], remap)
    else:
        sizes = SizeDistribution(grid, arrays["psi"])
    state = State(
        **{attr: np.array(arrays[name]) for attr, name in _ARRAYS.items()},
        sizes=sizes,
        **{attr: scalars[name] for attr, name in _SCALARS.items()},
        step=scalars.get("step", len(history) - 1),
        timings=dict(scalars["timings"]),
        p_prev=np.array(arrays["p_prev"]) if "p_prev" in arrays else None,
    )
    frames = [(t, name) for t, name in meta["frames"]]
    return (meta["config"], state, arrays.get("amg"), history, frames, meta["next_frame"],
            meta["done"])


def check_resumable(path: Path, saved: dict, config) -> None:
    """ValueError unless the saved configuration equals ``config`` up to EXECUTION_FIELDS."""
    now = json.loads(json.dumps(asdict(config)))
    wrong = sorted(
        k for k in {*saved, *now} if k not in EXECUTION_FIELDS and saved.get(k) != now.get(k)
    )
    if wrong:
        raise ValueError(
            f"checkpoint {path} belongs to a different configuration (differs in "
            f"{', '.join(wrong)}); delete it, or use another output folder, to start afresh"
        )


def remove_later_frames(out: Path, frames: list) -> None:
    """Delete the VTU frames ``fields/frame_*.vtu`` that are not in ``frames``.

    Those the run wrote after its checkpoint (a resumed run writes them again).
    """
    keep = {name for _, name in frames}
    for path in sorted((Path(out) / "fields").glob("frame_*.vtu")):
        if f"fields/{path.name}" not in keep:
            path.unlink()


class StopRequest:
    """SIGINT / SIGTERM deferred to the end of the current step (main thread only).

    ``install`` replaces the handlers; the first signal sets ``signum`` and puts the previous
    handlers back, so the run can finish its step and write a checkpoint, while a second signal
    acts at once. ``restore`` puts them back. (The twin of the particle engine's: the two
    engines do not import each other.)
    """

    def __init__(self):
        self.signum = None
        self._previous = {}

    def install(self) -> StopRequest:
        """Install the deferring handlers (in the main thread; elsewhere a no-op)."""
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signum = signum
        self.restore()

    def restore(self) -> None:
        """Put the previous handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}

    def act(self) -> None:
        """Raise for the signal received: KeyboardInterrupt (SIGINT), SystemExit(128 + signum)."""
        if self.signum == signal.SIGINT:
            raise KeyboardInterrupt
        if self.signum is not None:
            raise SystemExit(128 + self.signum)
