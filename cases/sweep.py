"""Parameter sweeps (over lam, seeds, ...) with dask.distributed, resumable.

Each run is one call ``run_fn(params, folder)`` that writes its results into ``folder``. The
sweep gives every run its own folder under ``root``, named from its parameters
(``lam=0.01_seed=3``); a run is staged in ``<name>.partial/`` and, when ``run_fn`` returns, marked
finished by a ``DONE`` file and renamed to ``<name>/``. A folder holding ``DONE`` is skipped, so a
stopped sweep (killed job, lost node, walltime) resumes where it stopped; a left-over
``.partial`` folder is handed to the run again, so a particle run resumes from the checkpoint it
left there (the continuum, minutes per run, has none and simply rewrites its files).

Any parameter can be swept, e.g. an ensemble of particle colonies over lam and seeds::

    params = [{"engine": "particles", "lam": lam, "radius": 40.0, "seed": s}
              for lam in (1e-3, 1e-2) for s in range(8)]
    folders = sweep(run_engine, params, "runs/ensemble")   # one folder per (lam, seed)

By default the runs go to a :class:`dask.distributed.LocalCluster` of ``n_workers`` processes
with one thread each (the engines are single-threaded and Numba/BLAS threads would compete).
Given ``scheduler="tcp://host:8786"`` they go to an existing scheduler instead, so the same sweep
runs on a cluster. On SLURM, start the workers with dask-jobqueue and pass the scheduler's
address (or run the sweep in the same script)::

    from dask_jobqueue import SLURMCluster
    cluster = SLURMCluster(cores=1, processes=1, memory="4GB", walltime="12:00:00",
                           job_extra_directives=["--cpus-per-task=1"],
                           worker_extra_args=["--nthreads", "1"])
    cluster.scale(jobs=16)            # 16 single-core workers as 16 SLURM jobs
    folders = sweep(run_fn, params, root, scheduler=cluster.scheduler_address)

(``pip install dask-jobqueue``; ``cluster.adapt(minimum_jobs=0, maximum_jobs=32)`` scales with
the queue.) The workers must see the same file system as ``root`` and have this package
installed. Failed runs are reported together at the end (:class:`SweepError`); the others
still finish and count as done.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from cases import runs
from cases.rundir import stop_signals_exit

__all__ = ["SweepError", "run_name", "initial_config", "is_done", "run_one", "sweep", "DONE",
           "run_engine", "engine_runs", "finished_runs", "case_runs", "compute_case",
           "engine_pairs", "select_lams", "ENGINES", "SCALES", "scale_config"]

DONE = "DONE"


class SweepError(RuntimeError):
    """Some runs of a sweep failed; ``failures`` maps folder name to the error text."""

    def __init__(self, failures: Mapping[str, str]):
        self.failures = dict(failures)
        names = ", ".join(sorted(self.failures))
        super().__init__(f"{len(self.failures)} run(s) failed: {names}")


def _fmt(value: Any) -> str:
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        if math.isfinite(value) and value == int(value) and abs(value) < 1e6:
            return str(int(value))
        return f"{value:g}"
    return str(value)


def run_name(params: Mapping[str, Any]) -> str:
    """Folder name of a run: ``key=value`` pairs sorted by key, joined by ``_``.

    Floats are written with ``%g`` (1e-2 -> ``0.01``, 1e-4 -> ``0.0001``, 150.0 -> ``150``).
    Characters other than letters, digits and ``.-+=`` are replaced by ``-``.
    """
    if not params:
        raise ValueError("params must not be empty")
    parts = []
    for key in sorted(params):
        text = f"{key}={_fmt(params[key])}"
        parts.append("".join(ch if ch.isalnum() or ch in ".-+=" else "-" for ch in text))
    return "_".join(parts)


def initial_config(config: Mapping[str, Any]) -> dict:
    """The configuration a run started with.

    That is ``config`` (a config.json) with the step-policy changes it records
    (``step_policy_changes``, particles.output.write_config) undone.
    """
    config = dict(config)
    for change in reversed(config.pop("step_policy_changes", [])):
        config |= {k: v[0] for k, v in change.items() if k != "step"}
    return config


def is_done(folder: Path, params: Mapping[str, Any] | None = None) -> bool:
    """True when ``folder`` holds a finished run (of the sweep point ``params``, if given).

    A published engine run (its ``run.json`` says finished, ``cases.rundir``) or a run of
    another ``run_fn`` (its ``DONE`` marker). An engine run grown by hand into the sweep's
    folder (``colony particles ... --out ROOT/NAME``) counts when the configuration it started
    with (:func:`initial_config`) has the sweep's values of ``params``; one that differs is a
    ValueError naming the difference, since the sweep must neither use it nor replace it.
    """
    from cases.rundir import read_record

    folder = Path(folder)
    if (folder / DONE).is_file():
        return True
    record = read_record(folder) if folder.is_dir() and not folder.is_symlink() else None
    if record is None or record.get("status") != "finished":
        return False
    if params is not None and "engine" in params:
        config = initial_config(record.get("config", {}))
        wrong = {k: (config.get(k), v) for k, v in params.items()
                 if k != "engine" and config.get(k) != v}
        if record.get("engine") != params["engine"]:
            wrong["engine"] = (record.get("engine"), params["engine"])
        if wrong:
            text = ", ".join(f"{k} = {a!r} (sweep: {b!r})" for k, (a, b) in wrong.items())
            raise ValueError(f"{folder} holds a finished run whose configuration differs from "
                             f"the sweep's: {text}; move it away or give another --runs")
    return True


def run_one(run_fn: Callable[[dict, Path], Any], params: dict, folder: Path,
            max_hours: float | None = None) -> Path | None:
    """Run one point of a sweep into ``folder`` (staged in ``folder.partial``); skip if done.

    ``params.json`` is written next to the results; ``DONE`` marks success. A ``.partial``
    stage left by a stopped run is reused as it is (``run_fn`` resumes from what it holds).
    A ``run_fn`` with the attribute ``stages_itself`` (:func:`run_engine`) is given ``folder``
    itself and stages, records and publishes it (``cases.runs``); given ``max_hours`` (the
    engines' execution setting, not a parameter of the point) it may pause
    (``cases.rundir.RunPaused``). Returns ``folder``, or None when the run paused. Off the
    main thread (a dask worker's task) on Linux such a run runs in its thread's child Python
    (:func:`_run_in_a_process`), so that a stop signal ends it after a whole step with a
    checkpoint, as on the command line.
    """
    from cases.rundir import RunPaused

    folder = Path(folder)
    if is_done(folder, params):
        return folder
    if getattr(run_fn, "stages_itself", False):  # the engine runs: cases.runs
        extra = {} if max_hours is None else {"max_hours": max_hours}
        if LINUX and threading.current_thread() is not threading.main_thread():
            return _run_in_a_process(run_fn, dict(params) | extra, folder)
        try:
            run_fn(dict(params) | extra, folder)
        except RunPaused:
            return None
        return folder
    stage = folder.with_name(folder.name + ".partial")
    stage.mkdir(parents=True, exist_ok=True)  # a left-over stage keeps its checkpoint
    (stage / "params.json").write_text(json.dumps(params, indent=2, default=str))
    run_fn(dict(params), stage)
    (stage / DONE).write_text("")
    if folder.exists():  # a stale, unfinished folder of the same name
        shutil.rmtree(folder)
    stage.rename(folder)
    return folder


def _run_in_a_process(run_fn: Callable[[dict, Path], Any], params: dict, folder: Path
                      ) -> Path | None:
    """``run_fn(params, folder)`` in a child Python whose main thread can defer stop signals.

    The engines defer SIGINT / SIGTERM / SIGHUP to the end of a step (their ``StopRequest``)
    only in a main thread, and a dask worker runs its tasks in other threads. So each worker
    thread keeps one child (``python -m cases.sweep``, started on its first task, its imports
    paid once) that runs its tasks one at a time: each task a JSON line on the child's stdin,
    its outcome a JSON line back on a pipe of its own. The child stops as at SIGTERM when its
    worker thread ends (PR_SET_PDEATHSIG), e.g. at a walltime or when a stopped sweep closes its
    cluster: a run finishes its step and writes its checkpoint. Returns ``folder``, None when
    the run paused; a run's error is a RuntimeError with its type and message, in one line.
    """
    child = getattr(_CHILD, "process", None)
    if child is None:
        child = _CHILD.process = _start_child()
    task = {"run_fn": f"{run_fn.__module__}:{run_fn.__qualname__}", "params": params,
            "folder": str(folder)}
    try:
        child.stdin.write(json.dumps(task) + "\n")
        child.stdin.flush()
        line = child.outcomes.readline()
    except BrokenPipeError:
        line = ""
    if not line:  # the child ended: a stop signal, or a crash (the next task starts another)
        _CHILD.process = None
        child.outcomes.close()
        raise RuntimeError(f"{folder.name}: its process ended with exit status {child.wait()}")
    outcome = json.loads(line)
    if outcome["error"] is not None:
        raise RuntimeError(f"{folder.name}: {outcome['error']}")
    return None if outcome["paused"] else folder


_CHILD = threading.local()
"""The child process of each worker thread (:func:`_run_in_a_process`)."""


def _start_child() -> subprocess.Popen:
    """``python -m cases.sweep FD PID``: a child that runs tasks, its outcomes on pipe ``FD``."""
    read, write = os.pipe()
    child = subprocess.Popen([sys.executable, "-m", "cases.sweep", str(write), str(os.getpid())],
                             stdin=subprocess.PIPE, pass_fds=(write,), text=True)
    os.close(write)
    child.outcomes = os.fdopen(read)
    return child


def _serve(outcomes_fd: int, parent: int) -> int:
    """The child of :func:`_run_in_a_process`: its tasks, one per line of stdin, in turn.

    Returns its exit status when stdin ends; a stop signal during a run ends it after the
    run's checkpoint (SystemExit from the engine), one while it waits ends it at once.
    """
    import ctypes
    import importlib

    from cases.rundir import RunPaused

    def worker_died(signum, frame):  # once: Linux may send it again as the worker's threads end
        signal.signal(signal.SIGUSR2, signal.SIG_IGN)
        os.kill(os.getpid(), signal.SIGTERM)

    signal.signal(signal.SIGUSR2, worker_died)  # when the worker's thread ends
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGUSR2)
    if os.getppid() != parent:  # the worker died before prctl
        return 128 + signal.SIGTERM
    with os.fdopen(outcomes_fd, "w") as outcomes:
        for line in sys.stdin:
            task = json.loads(line)
            module, name = task["run_fn"].split(":")
            paused, error = False, None
            try:
                getattr(importlib.import_module(module), name)(task["params"],
                                                                Path(task["folder"]))
            except RunPaused:
                paused = True
            except Exception as err:  # noqa: BLE001 (reported to the worker in one line)
                error = f"{type(err).__name__}: {err}".splitlines()[0]
            outcomes.write(json.dumps({"paused": paused, "error": error}) + "\n")
            outcomes.flush()
    return 0


PR_SET_PDEATHSIG = 1
"""prctl(2)'s option: the signal a process gets when the thread that started it ends."""

LINUX = sys.platform.startswith("linux")
"""Where a sweep's engine runs are child processes told of their worker's end (prctl(2)):
elsewhere a child would outlive a killed worker, so the run stays in the worker's thread."""

#: Seconds a scheduler given by address has to answer (:func:`check_scheduler`).
CONNECT_TIMEOUT = 10.0

#: Local worker processes allowed per CPU core (:func:`check_workers`).
WORKERS_PER_CORE = 4


class SchedulerError(RuntimeError):
    """No Dask scheduler answers at a --scheduler address (:func:`check_scheduler`)."""


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def check_workers(n_workers: int) -> None:
    """Check that ``n_workers`` local worker processes fit this machine.

    At least 1 and at most WORKERS_PER_CORE per CPU core available to this process (each worker
    is a process of one thread); ValueError otherwise, before any process is started.
    """
    cores = _cores()
    if not 1 <= n_workers <= WORKERS_PER_CORE * cores:
        raise ValueError(f"--workers {n_workers}: give 1 to {WORKERS_PER_CORE * cores} local "
                         f"Dask workers ({WORKERS_PER_CORE} per CPU core, {cores} cores here)")


async def _identity(address: str, timeout: float) -> dict:
    from distributed.comm import connect
    from distributed.security import Security

    comm = await connect(address, timeout=timeout,
                         **Security().get_connection_args("client"))
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """Check that a Dask scheduler answers at ``address`` within ``timeout`` (CONNECT_TIMEOUT) s.

    Connects, shakes hands and asks its identity, all within ``timeout`` (Dask's own connect
    timeout does not bound the handshake: a silent socket or an HTTP server would hang it, and
    an HTTP answer reads as a frame of exabytes). Raises :class:`SchedulerError`, one line
    saying why, for anything else: a malformed address, nothing listening, a silent or non-Dask
    service, a worker.
    """
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    try:
        scheme, location = parse_address(address)
        get_backend(scheme)
        if scheme in ("tcp", "tls", "ws", "wss"):
            parse_host_port(location)
    except ValueError as err:
        raise SchedulerError(f"--scheduler {address!r} is not a Dask address like "
                             f"tcp://host:8786: {err}") from None

    def probe():  # in a thread of its own: the caller may be running an event loop
        return asyncio.run(asyncio.wait_for(_identity(address, timeout / 2), timeout))

    try:
        with ThreadPoolExecutor(1) as pool:
            identity = pool.submit(probe).result()
    except TimeoutError:  # (asyncio's too) connected within timeout / 2, then silence
        why = "it accepts connections but does not answer (an HTTP server or another service?)"
    except OSError:  # no connection within timeout / 2 (Dask's connect retries until then)
        why = "nothing accepts connections there (refused, or an unknown or unreachable host)"
    except Exception as err:  # noqa: BLE001 (anything else is an answer Dask cannot read)
        why = f"it does not speak Dask's protocol ({type(err).__name__} reading its answer)"
    else:
        kind = identity.get("type") if isinstance(identity, dict) else None
        if kind == "Scheduler":
            return
        why = f"it answers as {kind!r}, not as a scheduler"
    raise SchedulerError(f"no Dask scheduler answers at {address} within {timeout:g} s: {why}")


def _quiet_dask() -> bool:
    """Mute Dask's INFO messages unless the root logger is at DEBUG (``colony --verbose``).

    Importing ``distributed`` sets its logger to INFO, whatever the caller set before (that
    shows a cluster's start-up and shut-down, some 40 lines per sweep); this sets it to WARNING,
    or INFO at DEBUG. Returns whether Dask may talk.
    """
    import logging

    verbose = logging.getLogger().getEffectiveLevel() <= logging.DEBUG
    logging.getLogger("distributed").setLevel(logging.INFO if verbose else logging.WARNING)
    return verbose


_LEG_HOURS: list[float | None] = [None]
"""The ``max_hours`` of :func:`sweep` when it is given none (:func:`legs`)."""


@contextmanager
def legs(hours: float | None):
    """Every :func:`sweep` in the body gives its engine runs ``max_hours = hours`` per leg.

    ``colony case NAME --max-hours H``: the cases' sweeps, however deep, run their engine runs
    in legs of H hours, each paused run submitted again until it finishes.
    """
    before, _LEG_HOURS[0] = _LEG_HOURS[0], hours
    try:
        yield
    finally:
        _LEG_HOURS[0] = before


def local_cluster(n_workers: int):
    """A new LocalCluster of ``n_workers`` (:func:`check_workers`) processes of one thread each.

    It keeps quiet unless the logging level is DEBUG (:func:`_quiet_dask`) and serves its HTTP
    routes on a free port of 127.0.0.1 (the default, port 8787, warns when taken).
    """
    import logging

    from dask.distributed import LocalCluster

    verbose = _quiet_dask()
    check_workers(n_workers)
    return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                        dashboard_address=None,
                        silence_logs=False if verbose else logging.WARNING,
                        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})


def _client(scheduler: str | None, n_workers: int):
    """(client, cluster) of the scheduler at ``scheduler`` (checked first) or a new cluster.

    The cluster is None for a scheduler given, else a :func:`local_cluster`.
    """
    from dask.distributed import Client

    if scheduler is not None:
        _quiet_dask()
        check_scheduler(scheduler)
        return Client(scheduler, timeout=CONNECT_TIMEOUT), None
    cluster = local_cluster(n_workers)
    return Client(cluster), cluster


def sweep(
    run_fn: Callable[[dict, Path], Any],
    params: Sequence[Mapping[str, Any]],
    root: str | Path,
    scheduler: str | None = None,
    n_workers: int = 2,
    progress: bool | None = None,
    max_hours: float | None = None,
) -> list[Path]:
    """Run ``run_fn(params_i, folder_i)`` for every parameter set, in parallel, resumably.

    Parameters
    ----------
    run_fn : picklable callable writing one run's results into the given folder.
    params : parameter sets (mappings of JSON-able values); their names (:func:`run_name`) must
        be distinct.
    root : folder holding one sub-folder per run.
    scheduler : address of an existing dask scheduler, or None for a LocalCluster.
    n_workers : worker processes of the LocalCluster (one thread each).
    progress : tqdm progress bar; None shows it only on a terminal.
    max_hours : each engine run's wall-clock limit per leg (:func:`run_engine` runs; a little
        under the workers' walltime): a run that pauses is submitted again and resumes from its
        checkpoint on the next free worker, until it finishes.

    Returns
    -------
    The run folders, in the order of ``params``. Runs already done are not submitted.

    Raises
    ------
    SweepError
        After all runs ended, if any failed (their ``.partial`` folders are kept for inspection).
    """
    from dask.distributed import as_completed
    from tqdm.auto import tqdm

    if n_workers < 1:
        raise ValueError(f"n_workers must be >= 1, got {n_workers}")
    root = Path(os.path.abspath(root))  # resolved here: workers have other working folders
    names = [run_name(p) for p in params]
    if len(set(names)) != len(names):
        raise ValueError("parameter sets must have distinct names")
    folders = [root / n for n in names]
    todo = [(dict(p), f) for p, f in zip(params, folders, strict=True) if not is_done(f, p)]
    if not todo:
        return folders
    root.mkdir(parents=True, exist_ok=True)
    client, cluster = _client(scheduler, n_workers)
    failures: dict[str, str] = {}
    with stop_signals_exit():  # SIGTERM, SIGHUP: the finally below closes the cluster
        try:
            max_hours = _LEG_HOURS[0] if max_hours is None else max_hours
            points = {f: p for p, f in todo}
            legs = dict.fromkeys(points, 1)

            def submit(folder):
                return client.submit(run_one, run_fn, points[folder], folder, max_hours,
                                     key=f"run-{folder.name}-leg{legs[folder]}", pure=False)

            futures = {submit(f): f for f in points}
            bar = tqdm(total=len(folders), initial=len(folders) - len(todo), desc="sweep",
                       disable=None if progress is None else not progress)
            running = as_completed(futures)
            for fut in running:
                folder = futures.pop(fut)
                if fut.status == "error":
                    failures[folder.name] = repr(fut.exception())
                elif fut.result() is None:  # paused at max_hours: its next leg
                    legs[folder] += 1
                    futures[new := submit(folder)] = folder
                    running.add(new)
                    continue
                bar.update(1)
            bar.close()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()  # its workers' engine runs end after a step (_run_in_a_process)
    if failures:
        raise SweepError(failures)
    return folders


#: The engines' names in the order of cases.runs.ENGINES (the figure cases number them 0, 1).
ENGINES = tuple(runs.ENGINES)


def engine_pairs(lams: Sequence[float], engines: Sequence[str] = ENGINES
                 ) -> list[tuple[str, float]]:
    """The runs (engine, lam) of every lam for each of ``engines`` (a subset of ENGINES).

    A figure case given ``engines=("continuum",)`` reduces and draws the continuum only; see
    :func:`case_runs` for taking only the particle runs already finished.
    """
    engines = tuple(engines)
    bad = [e for e in engines if e not in ENGINES]
    if bad or not engines:
        raise ValueError(f"engines must be a non-empty subset of {ENGINES}, got {engines!r}")
    return [(e, float(lam)) for lam in lams for e in engines]


def run_engine(params: dict, folder: Path) -> None:
    """Sweep ``run_fn`` for either engine: ``params = {"engine": ..., "lam": ..., **config}``.

    The remaining keys are the fields of ``continuum.Config`` / ``particles.Config``
    (docs/DESIGN.md). The run is the command line's (``cases.runs``): ``folder`` is staged,
    recorded in ``run.json``, resumed from its checkpoint after a stop and published with its
    profile, rings and picture, as ``colony continuum|particles --out folder`` makes it. A
    particle run with a ``shape`` starts from the particles of cases.shapes.initial_state. A
    sweep's runs share the cores, so a particle run takes one solver thread unless ``params``
    say otherwise (``threads`` changes no result).
    """
    params = dict(params)
    engine = params.pop("engine", None)
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    if engine == "particles":
        params.setdefault("threads", 1)
    engine = runs.ENGINES[engine]
    config = engine.config(**params)  # validated when made
    engine.run(config, Path(folder), progress=False)


run_engine.stages_itself = True


#: Run sizes of the figure cases. Every case draws its runs from the same table, so cases given
#: the same ``runs`` folder share (and skip) identical runs. "lams": the three panels of Fig 2 and
#: the curves of Fig 3A-B, 4A-B (plus lam = 0 in Fig 3A-B); "scaling_lams": Fig 3C-D, Fig 4C.
#: Smoke: radius 15, larger lam so that rings form in a small colony (wavelength ~ lam^-1/2).
SCALES: dict[str, dict[str, Any]] = {
    "smoke": {
        "radius": 15.0,
        "lams": (0.03, 0.1, 0.3),
        "scaling_lams": (0.03, 0.1, 0.3),
        "continuum": {"output_every": 0.5},
        "particles": {"output_every": 0.4},
    },
    "medium": {
        # what one 2-core machine does in about an hour for both engines (particles: ~5e3
        # particles per run at radius 40)
        "radius": 40.0,
        "lams": (1e-3, 1e-2, 3e-2),
        "scaling_lams": (1e-3, 3e-3, 1e-2, 3e-2, 1e-1),
        "continuum": {"output_every": 0.5},
        "particles": {"output_every": 1.0},
    },
    "paper": {
        "radius": 150.0,
        "lams": (1e-4, 1e-3, 1e-2),
        "scaling_lams": (1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 5e-2, 1e-1),
        # continuum frames every 0.5 time units, particle frames every 0.2 (until issue 43
        # every 50 steps: 1 time unit at the start, 0.1 at R = 150, where the default overlap
        # control has shortened the step, particles.stepping.next_dt; the radius then grows
        # about 25 per unit of time).  At lam = 1e-1 the continuum run lasts t ~ 45, i.e. ~90
        # frames (~20 MB each at R = 150).
        "continuum": {"output_every": 0.5},
        "particles": {"output_every": 0.2},
    },
}


def scale_config(scale: str) -> dict[str, Any]:
    """The run sizes of ``scale`` ("smoke" or "paper"); ValueError otherwise."""
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {tuple(SCALES)}, got {scale!r}")
    return SCALES[scale]


def _engine_params(engine: str, lam: float, cfg: Mapping[str, Any]) -> dict[str, Any]:
    """The sweep parameters of run (engine, lam) at the run sizes ``cfg`` of SCALES.

    These are lam, the radius and the engine's settings (the same at every lam).
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    return {"engine": engine, "lam": float(lam), "radius": cfg["radius"], **cfg[engine]}


def engine_runs(
    runs: Sequence[tuple[str, float]],
    scale: str,
    root: str | Path,
    scheduler: str | None = None,
    n_workers: int = 2,
) -> dict[tuple[str, float], Path]:
    """Run every (engine, lam) of ``runs`` at ``scale`` (radius and engine settings of SCALES).

    One sweep for all of them; finished runs under ``root`` are reused (see :func:`sweep`).
    Returns {(engine, lam): run folder}.
    """
    cfg = scale_config(scale)
    params = [_engine_params(engine, lam, cfg) for engine, lam in runs]
    folders = sweep(run_engine, params, root, scheduler=scheduler, n_workers=n_workers)
    return {(e, float(lam)): f for (e, lam), f in zip(runs, folders, strict=True)}


def finished_runs(runs: Sequence[tuple[str, float]], scale: str, root: str | Path
                  ) -> dict[tuple[str, float], Path]:
    """The runs of ``runs`` already finished under ``root`` at ``scale`` (none is started)."""
    cfg = scale_config(scale)
    params = {(e, float(lam)): _engine_params(e, lam, cfg) for e, lam in runs}
    return {k: Path(root) / run_name(p) for k, p in params.items()
            if is_done(Path(root) / run_name(p), p)}


def select_lams(needed: Sequence[tuple[str, float]], lams: Sequence[float] | None,
                case: str = "the case") -> list[tuple[str, float]]:
    """The runs (engine, lam) of ``needed`` whose lam is one of ``lams`` (None: all of them).

    Raises ValueError for an empty ``lams`` or a lam that no run of ``needed`` has.
    """
    if lams is None:
        return list(needed)
    have = sorted({lam for _, lam in needed})
    want = {float(lam) for lam in lams}
    bad = sorted(want - set(have))
    if bad or not want:
        listed = ", ".join(f"{lam:g}" for lam in bad) or "none"
        raise ValueError(f"lam {listed} not among the lam of {case} at this scale: "
                         f"{', '.join(f'{lam:g}' for lam in have)}")
    return [r for r in needed if r[1] in want]


def case_runs(  # noqa: PLR0913 (the run options of every figure case, as the CLI's)
    case: str, needed: Sequence[tuple[str, float]], scale: str, out: str | Path,
    runs: str | Path | None = None, scheduler: str | None = None, n_workers: int = 2,
    engines: Sequence[str] = ENGINES, needs_continuum: bool = True,
    finished_only: Sequence[str] = (), lams: Sequence[float] | None = None,
) -> dict[tuple[str, float], Path]:
    """The engine runs of a figure case (run or reused under ``runs``, default ``out/runs``).

    Every figure case (fig2, fig3, fig4, crosscheck) gets its runs here. ``engines =
    ("continuum",)``: the case reduces and draws the continuum alone (particle columns nan,
    particle panels omitted and the figure says so).

    ``needs_continuum``: the case measures against the continuum (its radius is the reference),
    so ``engines`` must include it. ``finished_only``: engines whose runs are taken only where
    already finished under ``runs`` and never started (e.g. the paper-scale particle colonies,
    hours each, made one by one with ``colony particles``); the others are run as needed.
    ``lams``: only the runs of these lam (:func:`select_lams`; default all), e.g. to reduce a
    new paper colony and merge it into the committed data (``cases.figures.merge``).
    """
    needed = select_lams(needed, lams, case)
    if needs_continuum and "continuum" not in engines:
        raise ValueError(f"{case} needs the continuum runs (engines must include 'continuum')")
    bad = [e for e in finished_only if e not in ENGINES]
    if bad:
        raise ValueError(f"finished_only must be a subset of {ENGINES}, got {bad!r}")
    root = Path(runs) if runs else Path(out) / "runs"
    reused = finished_runs([r for r in needed if r[0] in finished_only], scale, root)
    started = engine_runs([r for r in needed if r[0] not in finished_only], scale, root,
                          scheduler=scheduler, n_workers=n_workers)
    return started | reused


def compute_case(  # noqa: PLR0913 (case_runs' options and the case's two steps)
    case: str, runs_needed: Callable, reduce: Callable, scale: str = "smoke",
    out: str | Path | None = None, scheduler: str | None = None, n_workers: int = 2,
    runs: str | Path | None = None, engines: Sequence[str] = ENGINES,
    finished_only: Sequence[str] = (), lams: Sequence[float] | None = None,
    needs_continuum: bool = True,
) -> Path:
    """The ``compute`` of every figure case: run (or reuse) its engine runs, reduce to out/data.

    ``runs_needed(scale, engines)`` gives the case's (lam values, (engine, lam) runs);
    :func:`case_runs` runs or reuses them under ``runs`` (default ``out/runs``; ``engines``,
    ``needs_continuum``, ``finished_only`` and ``lams`` as there); ``reduce(folders, data)``
    writes the case's CSVs into ``data = out/data`` and returns it. ``out`` defaults to
    ``runs/case-CASE-SCALE``, as on the command line.
    """
    out = Path(out) if out is not None else Path(f"runs/case-{case}-{scale}")
    needed = runs_needed(scale, tuple(engines))[1]
    folders = case_runs(case, needed, scale, out, runs, scheduler, n_workers, engines,
                        needs_continuum=needs_continuum, finished_only=finished_only, lams=lams)
    return reduce(folders, out / "data")


if __name__ == "__main__":  # a sweep's worker thread starts its child (_run_in_a_process)
    try:
        fd, parent = (int(arg) for arg in sys.argv[1:])
    except ValueError:
        print("python -m cases.sweep FD PID is the child a sweep's worker starts for its runs; "
              "sweeps start from cases.sweep.sweep or colony case", file=sys.stderr)
        sys.exit(2)
    sys.exit(_serve(fd, parent))
