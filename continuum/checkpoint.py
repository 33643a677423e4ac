"""Checkpoints of a continuum run and the deferred handling of SIGINT / SIGTERM / SIGHUP.

A checkpoint (``checkpoint.npz`` in the run folder) holds everything the following steps depend
on, so a simulation loaded from it continues bit-identically:

- the arrays of the :class:`~continuum.state.State`: ``points``, ``tris``, ``G``, ``p``,
  ``u``, ``g``, ``psi`` (Psi's cell values), ``psi_phase`` (the phase offsets of Psi's windows
  along the characteristics) or, for the delta Psi0 (``initial_sizes =
  "delta"``), ``psi_delta`` and ``psi_log_length`` (continuum.sizes.DeltaSizes), with strains
  ``phi`` and ``G_strains`` (n, S) (continuum.strains), ``p_prev`` (when set) and ``amg``, the
  CSR data of the matrix the pressure solver's AMG hierarchy was built from (when there is one; the
  loaded solver rebuilds the identical hierarchy, continuum.pressure.amg_hierarchy);
- ``frame_times``, the times of the VTU frames written (frame k is ``fields/frame_k.vtu``,
  its name made by continuum.output.frame_name, never read from the checkpoint);
- ``meta``, one JSON string: ``config`` (the Config fields), ``colony`` (the scalars t, nb,
  n_remesh, newton, krylov, h_mesh, hmean_mesh, dt_prev, step, timings), ``history``, and
  the run's output bookkeeping: ``next_frame`` (time of the next frame) and ``done`` (the goal
  was reached);
- ``sha256``, the checksum of all the other entries (``runfiles.arrays_digest``).

The history: a run folder's checkpoint keeps only ``{"rows": n, "sha256": ...}`` of the
history.csv written just before it (``runfiles.history_record``), so its size depends
on the mesh, not on how long the colony has grown; on load the first n rows of history.csv
are checked against it and read back (``runfiles.read_history``). A checkpoint saved
elsewhere (``Simulation.save(path)``), and every checkpoint written before this, holds the
rows.

The functions, the same in the particle engine: :func:`save_checkpoint` writes a
:class:`Checkpoint` (configuration, state, history, frames, and here the AMG matrix and the
run's bookkeeping), :func:`load_checkpoint` reads one back, :func:`resume_checkpoint` finds a
run folder's.

Safety (``runfiles``, one source for both engines; :func:`resume_checkpoint`): a checkpoint is
written to a temporary file, flushed, read back and verified; only then the run folder's
``checkpoint.npz``, when intact, becomes ``checkpoint.prev.npz`` and the new file takes its name
(os.replace). Loading never unpickles (allow_pickle=False), verifies the checksum and refuses
anything damaged (emptied, cut short, bytes changed, an entry missing, an object array) with one
``runfiles.CheckpointError`` line. A run resumes from ``checkpoint.prev.npz`` (with a warning) when
``checkpoint.npz`` is damaged, so a damaged checkpoint costs one checkpoint interval; the
frames and history rows after it are dropped as after any resume. The run folder's checkpoints
are never read through a symbolic link.

A checkpoint resumes under a configuration equal to the saved one up to ``EXECUTION_FIELDS``
(settings that do not change the result). Checkpoints of earlier versions load when intact
(their zip CRCs hold): without ``sha256``, with the history and the frames ((t, file) pairs,
whose names are ignored) in ``meta``, without ``step``, and with the bump Psi0 when it has no
``initial_sizes``; those of a removed transport of Psi (continuum.sizes.REMOVED_TRANSPORTS) are
refused in one line.

``runfiles.StopRequest`` (a context manager) defers SIGINT, SIGTERM and SIGHUP to the end of the
current step, so that ``continuum.run`` can write a checkpoint of a whole step before stopping.
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from continuum.config import Config
from continuum.runfiles import (
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
from continuum.sizes import REMOVED_TRANSPORTS, CharacteristicSizes, DeltaSizes, LengthGrid
from continuum.state import State

__all__ = ["EXECUTION_FIELDS", "Checkpoint", "save_checkpoint", "load_checkpoint",
           "resume_checkpoint", "checkpoint_config", "check_resumable"]

log = logging.getLogger(__name__)

EXECUTION_FIELDS = ("checkpoint_seconds", "max_hours")
"""Configuration fields that do not change the result: a checkpoint resumes whatever they are."""

# State attribute -> checkpoint name (the names of the format, kept from its first version)
_SCALARS = {"t": "t", "n_boundary": "nb", "n_remesh": "n_remesh", "newton": "newton",
            "krylov": "krylov", "h_mesh": "h_mesh", "h_mean_mesh": "hmean_mesh",
            "dt_prev": "dt_prev"}
_ARRAYS = {"points": "points", "triangles": "tris", "G": "G", "p": "p", "u": "u", "g": "g"}


# ------------------------------------------------------------------ the continuum checkpoint


@dataclass
class Checkpoint:
    """What a checkpoint holds: everything the following steps of a run depend on.

    The first four attributes are the particle engine's ``Checkpoint``'s too.

    Attributes
    ----------
    config : Config
        The configuration it ran with.
    state : State
    history : list of dict, or dict
        The history rows so far; when saving into a run folder, the ``runfiles.history_record`` of
        the history.csv written beside it (then the checkpoint at the path becomes
        ``checkpoint.prev.npz``, :func:`write_arrays`). Loaded: the rows.
    frames : list of float
        The times of the VTU frames written.
    amg : ndarray or None
        The matrix of the pressure solver's AMG hierarchy (``PressureSolver.amg_state()``).
    next_frame : float
        Time of the next frame.
    done : bool
        Whether the run's goal was reached.
    """

    config: Config
    state: State
    history: list[dict] | dict
    frames: list[float] = field(default_factory=list)
    amg: np.ndarray | None = None
    next_frame: float = math.inf
    done: bool = False


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """Write ``checkpoint`` (format in the module docstring) to ``path`` safely.

    A failed write (e.g. a full disk) leaves the existing checkpoints as they were; a history
    record (a run folder) keeps the checkpoint at ``path`` as ``checkpoint.prev.npz``.
    """
    path, state = Path(path), checkpoint.state
    scalars = {name: getattr(state, attr) for attr, name in _SCALARS.items()}
    scalars["step"] = state.step
    scalars["timings"] = dict(state.timings)
    arrays = {name: getattr(state, attr) for attr, name in _ARRAYS.items()}
    if isinstance(state.sizes, DeltaSizes):
        arrays["psi_delta"] = state.sizes.n
        arrays["psi_log_length"] = state.sizes.log_length
    else:
        arrays["psi"], arrays["psi_phase"] = state.sizes.n, state.sizes.phase
    if state.phi is not None:
        arrays["phi"], arrays["G_strains"] = state.phi, state.G_strains
    if state.p_prev is not None:
        arrays["p_prev"] = state.p_prev
    if checkpoint.amg is not None:
        arrays["amg"] = checkpoint.amg
    arrays["frame_times"] = np.asarray(checkpoint.frames, dtype=float)
    meta = {"config": asdict(checkpoint.config), "colony": scalars,
            "history": checkpoint.history, "next_frame": checkpoint.next_frame,
            "done": checkpoint.done}
    previous = path.with_name(PREVIOUS) if isinstance(checkpoint.history, dict) else None
    write_arrays(path, {"meta": np.array(json.dumps(meta)), **arrays}, previous)
    log.debug("checkpoint at t = %.6g written to %s", state.t, path)


def _check_arrays(path: Path, arrays: dict, n_cells: int, n_strains: int = 0) -> None:
    """CheckpointError unless the state's arrays are there, of the shapes of one mesh.

    n nodes: points (n, 2), u (n, 2), G, p, g, psi_phase, p_prev (n,), psi (n, n_cells),
    with S = ``n_strains`` >= 1 strains phi and G_strains (n, S); triangles (m, 3) of node
    indices; amg and frame_times one-dimensional; all real numbers.
    """
    n = checked(path, lambda: arrays["points"].shape[0])
    shapes = {"points": (n, 2), "u": (n, 2), "G": (n,), "p": (n,), "g": (n,), "psi_phase": (n,),
              "p_prev": (n,), "psi": (n, n_cells), "psi_delta": (n,), "psi_log_length": (n,),
              "phi": (n, n_strains), "G_strains": (n, n_strains)}
    psi = ("psi_delta", "psi_log_length") if "psi_delta" in arrays else ("psi", "psi_phase")
    strains = ("phi", "G_strains") if n_strains else ()
    if not n_strains and arrays.keys() & {"phi", "G_strains"}:
        raise damaged(path, "unexpected content (phi)")
    for name in ("points", "tris", "G", "p", "u", "g", *psi, *strains):
        checked(path, lambda name=name: arrays[name])
    for name in sorted(arrays.keys() & {*shapes, "tris", "amg"}):
        a = arrays[name]
        shape = shapes.get(name, (a.size,) if name == "amg" else (a.size // 3, 3))
        if a.dtype.kind not in ("i" if name == "tris" else "f") or a.shape != shape:
            raise damaged(path, f"unexpected content ({name})")
    tris = arrays["tris"]
    if tris.size and not (0 <= tris.min() and tris.max() < n):
        raise damaged(path, "unexpected content (tris)")


def _state(arrays: dict, meta: dict, saved: dict, default_step: int) -> State:
    """The State of a checkpoint's (checked) arrays and metadata."""
    scalars = meta["colony"]
    grid = LengthGrid(saved["n_length_cells"])
    if "psi_delta" in arrays:
        sizes = DeltaSizes(arrays["psi_delta"], arrays["psi_log_length"])
    else:
        sizes = CharacteristicSizes(grid, arrays["psi"], arrays["psi_phase"])
    return State(
        **{attr: np.array(arrays[name]) for attr, name in _ARRAYS.items()},
        sizes=sizes,
        **{attr: scalars[name] for attr, name in _SCALARS.items()},
        step=scalars.get("step", default_step),
        timings=dict(scalars["timings"]),
        p_prev=np.array(arrays["p_prev"]) if "p_prev" in arrays else None,
        phi=np.array(arrays["phi"]) if "phi" in arrays else None,
        G_strains=np.array(arrays["G_strains"]) if "G_strains" in arrays else None,
    )


def _history(path: Path, saved) -> list[dict]:
    """The history rows of a checkpoint: kept in it, or those of history.csv it recorded."""
    if isinstance(saved, dict):
        return read_history(path.parent / HISTORY, saved, path)
    if not (isinstance(saved, list) and saved and all(isinstance(r, dict) for r in saved)):
        raise damaged(path, "unexpected content (history)")
    return saved


def _frame_times(path: Path, arrays: dict, meta: dict) -> list[float]:
    """The times of the frames written, checked.

    ``frame_times``, or the times of an earlier version's (t, file) pairs, whose names are
    ignored (frame k is always named by continuum.output.frame_name).
    """
    if "frame_times" in arrays:
        a = arrays["frame_times"]
        times = a.tolist() if a.ndim == 1 and a.dtype.kind == "f" else [math.nan]
    else:
        times = checked(path, lambda: [float(t) for t, _ in meta["frames"]])
    if not all(math.isfinite(t) for t in times):
        raise damaged(path, "unexpected content (frame_times)")
    return times


def _bookkeeping(path: Path, meta: dict) -> tuple[float, bool]:
    """(next_frame, done) of a checkpoint's metadata, checked."""
    next_frame, done = checked(path, lambda: (meta["next_frame"], meta["done"]))
    if type(done) is not bool or type(next_frame) not in (int, float) or math.isnan(next_frame):
        raise damaged(path, "unexpected content (next_frame, done)")
    return float(next_frame), done


def _saved_config(path: Path, arrays: dict) -> dict:
    """The configuration fields a checkpoint holds (older ones: ``element`` P1).

    ValueError for a checkpoint of a removed transport of Psi (REMOVED_TRANSPORTS; one without
    ``psi_transport`` carried Psi by finite volumes, or along characteristics with cells
    remapped when it has ``psi_phase``).
    """
    meta = read_meta(path, arrays)
    saved = checked(path, lambda: meta["config"])
    if not isinstance(saved, dict):
        raise damaged(path, "unexpected content (config)")
    saved.setdefault("element", "P1")  # checkpoints from before Config.element solved with P1
    saved.setdefault("initial_sizes", "bump")  # and from before Config.initial_sizes the bump
    saved.setdefault("strains", [])  # and from before Config.strains one strain
    saved.setdefault("layout", None)
    if "max_steps" in saved:  # Config.step_limit's former name
        saved["step_limit"] = saved.pop("max_steps")
    transport = saved.setdefault(
        "psi_transport", "characteristics" if "psi_phase" in arrays else "finite-volume")
    if transport in REMOVED_TRANSPORTS and "psi_delta" not in arrays:
        raise ValueError(f"checkpoint {path} carries Psi by the {transport!r} transport, which "
                         f"was removed ({REMOVED_TRANSPORTS[transport]}): resume it with that "
                         "commit's code")
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
    return _config(path, _saved_config(path, read_arrays(path)))


def load_checkpoint(path: Path, config: Config | None = None, *,
                    follow: bool = True) -> Checkpoint:
    """The :class:`Checkpoint` written by :func:`save_checkpoint` at ``path``.

    Parameters
    ----------
    path : Path
    config : Config, optional
        The configuration to continue with, checked against the saved one
        (:func:`check_resumable`); None: the saved one.
    follow : bool
        False: a symbolic link is refused.

    Returns
    -------
    Checkpoint
        ``config`` (the one given, else the saved one) and the saved state, history rows,
        frame times, AMG matrix and bookkeeping.

    Raises
    ------
    CheckpointError
        The file is damaged (or its history.csv does not hold the rows it recorded).
    NotCheckpointError
        The file is no checkpoint, or the particle engine's (runfiles.read_arrays, read_meta).
    ValueError
        ``config`` differs from the saved one (:func:`check_resumable`).
    """
    path = Path(path)
    arrays = read_arrays(path, follow)
    meta = read_meta(path, arrays)
    saved = _saved_config(path, arrays)
    if config is not None:
        check_resumable(path, saved, config)
    history = _history(path, checked(path, lambda: meta["history"]))
    times = _frame_times(path, arrays, meta)
    arrays.pop("frame_times", None)
    _check_arrays(path, arrays, checked(path, lambda: int(saved["n_length_cells"])),
                  checked(path, lambda: len(saved["strains"])))
    state = checked(path, lambda: _state(arrays, meta, saved, len(history) - 1))
    next_frame, done = _bookkeeping(path, meta)
    if config is None:
        config = _config(path, saved)
    return Checkpoint(config, state, history, times, arrays.get("amg"), next_frame, done)


def resume_checkpoint(out: Path, config: Config) -> tuple[Path, Checkpoint]:
    """(path, :func:`load_checkpoint` of it) of the run folder ``out``'s checkpoint.

    ``checkpoint.npz``, or ``checkpoint.prev.npz`` when that one is damaged (resume_from);
    never through a symbolic link.
    """
    return resume_from(Path(out), lambda path: load_checkpoint(path, config, follow=False))


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
