"""Whole runs: invariants, determinism, outputs, checkpoint-resume equality."""

import json
import math
from dataclasses import replace
from pathlib import Path

import gsd.hoomd
import numba
import numpy as np
import pytest

import particles.stepping as stepping
from particles import Config, Simulation, run
from particles.config import upgrade
from particles.division import divide
from particles.geometry import generalised_forces, max_overlap
from particles.output import frame_count
from particles.simulation import initial_state
from particles.solvers import ContactSolveError, solve_contacts
from particles.stepping import MAX_HALVINGS, next_dt, step


def test_lam0_total_length_is_exp_t():
    sim = run(Config(lam=0.0, time=3.0, dt=0.01))
    c = sim.state
    assert c.t == pytest.approx(3.0, abs=1e-12)
    assert abs(c.length.sum() / np.exp(3.0) - 1) < 1e-3
    t = np.array([r["t"] for r in sim.history])
    total = np.array([r["total_length"] for r in sim.history])
    np.testing.assert_allclose(total, np.exp(t), rtol=1e-12)  # exact exponential update
    assert c.n == 16  # synchronous divisions at t = k ln 2


@pytest.mark.parametrize("lam,nmax", [(0.0, 130), (1e-2, 300)])
def test_every_step_overlap_and_balance(lam, nmax):
    cfg = Config(lam=lam, time=100.0, dt=0.01)
    state = initial_state(cfg)
    rng = np.random.default_rng(0)
    warm = (np.zeros(0, dtype=np.int64), np.zeros(0))
    steps = 0
    while state.n < nmax:
        x0, y0 = state.x.copy(), state.y.copy()
        info, warm = step(state, cfg, cfg.dt, warm)
        c, g = info["contacts"], info["gamma"]
        fx, fy, tz = generalised_forces(c, g, state.n)
        scale = max(1.0, np.abs(g).sum())
        assert abs(fx.sum()) < 1e-13 * scale and abs(fy.sum()) < 1e-13 * scale
        rmax = np.max(np.hypot(x0, y0)) + 2
        assert abs(np.sum(x0 * fy - y0 * fx + tz)) < 1e-13 * scale * rmax
        assert info["max_overlap"] <= cfg.tol
        assert max_overlap(state.x, state.y, state.theta, state.length) <= cfg.tol
        divide(state, rng, cfg.division_noise)
        steps += 1
    assert steps > 100


def test_determinism_and_seed():
    a = run(Config(lam=1e-2, time=4.0, dt=0.01, seed=3)).state
    b = run(Config(lam=1e-2, time=4.0, dt=0.01, seed=3)).state
    d = run(Config(lam=1e-2, time=4.0, dt=0.01, seed=4)).state
    for k in ("x", "y", "theta", "length", "stress"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert a.n > 25 and not np.array_equal(a.theta[: min(a.n, d.n)], d.theta[: min(a.n, d.n)])


def test_radius_stop():
    sim = run(Config(lam=1e-2, radius=3.0, dt=0.01))
    c = sim.state
    assert c.enclosing_radius() >= 3.0 > sim.history[-2]["radius"]
    assert sim.history[-1]["radius"] == c.enclosing_radius()
    assert c.hull_radius() <= c.enclosing_radius()


@pytest.mark.parametrize("control,dt,stop", [("fixed", 0.01, 123), ("cost", 0.08, 30),
                                             ("overlap", 0.04, 60)])
def test_outputs_and_checkpoint_resume(tmp_path, control, dt, stop):
    cfg = Config(lam=1e-2, time=3.5, dt=dt, output_every=0.5, seed=2, step_control=control)
    full = tmp_path / "full"
    part = tmp_path / "part"
    full.mkdir()
    part.mkdir()
    a = run(cfg, full)
    b1 = run(cfg, part, max_steps=stop)
    assert not b1.finished and len(b1.history) == stop
    b = run(cfg, part)
    assert b.finished
    for name in ("history.csv", "particles.csv", "config.json"):
        assert (full / name).read_bytes() == (part / name).read_bytes(), name
    for k in ("x", "y", "theta", "length", "stress"):
        np.testing.assert_array_equal(getattr(a.state, k), getattr(b.state, k))
    with (
        gsd.hoomd.open(str(full / "trajectory.gsd")) as ta,
        gsd.hoomd.open(str(part / "trajectory.gsd")) as tb,
    ):
        # a frame at t = 0 and after each step that crosses a multiple of 0.5, the last at 3.5
        t = np.array([0.0] + [r["t"] for r in a.history])
        crossed = np.flatnonzero(np.diff(np.floor(t / 0.5 + 1e-9)) > 0) + 1
        assert [f.configuration.step for f in ta] == [0, *crossed] and len(crossed) == 7
        assert [f.configuration.step for f in tb] == [0, *crossed]
        fa, fb = ta[-1], tb[-1]
        np.testing.assert_array_equal(fa.particles.position, fb.particles.position)
        np.testing.assert_allclose(fa.log["particles/length"],
                                   a.state.length.astype(np.float32))
        np.testing.assert_allclose(fa.log["particles/stress"],
                                   a.state.stress.astype(np.float32))
        q = fa.particles.orientation
        np.testing.assert_allclose(
            2 * np.arctan2(q[:, 3], q[:, 0]), np.angle(np.exp(1j * a.state.theta)), atol=1e-5
        )
        assert fa.particles.N == a.state.n and fa.configuration.step == len(a.history)
    hist = np.genfromtxt(full / "history.csv", delimiter=",", names=True)
    assert hist.size == len(a.history)
    assert np.all(hist["max_overlap"] <= cfg.tol)
    assert json.loads((full / "config.json").read_text())["lam"] == 1e-2
    parts = np.genfromtxt(full / "particles.csv", delimiter=",", names=True)
    np.testing.assert_array_equal(parts["length"], a.state.length)
    # a different configuration refuses the checkpoint
    with pytest.raises(ValueError, match="different configuration"):
        run(Config(lam=1e-3, time=3.5, dt=0.01, output_every=0.5, seed=2), part)
    if control == "cost":  # the step was adapted, and the resumed run continued with it
        dts = np.array([r["dt"] for r in a.history])
        assert dts[:-1].max() <= cfg.dt and dts[stop:-1].min() < dts[stop - 1] < cfg.dt


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
def test_resume_on_another_number_of_threads(tmp_path):
    """The settings threads and checkpoint_seconds change no result.

    A run stopped on two threads and resumed on one, checkpointing at another interval, gives
    the files of an uninterrupted one-thread run (config.json records the last setting).
    """
    cfg = Config(lam=1e-2, time=3.0, dt=0.01, seed=1)
    full, part = tmp_path / "full", tmp_path / "part"
    full.mkdir()
    part.mkdir()
    run(cfg, full)
    run(replace(cfg, threads=2, checkpoint_seconds=1.0), part, max_steps=150)
    run(cfg, part)
    for name in ("history.csv", "particles.csv"):
        assert (full / name).read_bytes() == (part / name).read_bytes(), name


def test_step_policy_changes_on_resume_only_when_asked(tmp_path):
    """A fixed-step run resumes adaptive, then with another dt, only under change_step_policy.

    Its first steps are those of the fixed run, the next ones adapted, the last ones of the new
    dt, and config.json records the changes; any other change is refused.
    """
    fixed = Config(lam=1e-2, time=3.0, dt=0.08, seed=2, step_control="fixed")
    adaptive = replace(fixed, step_control="cost")
    full, part = tmp_path / "full", tmp_path / "part"
    full.mkdir()
    part.mkdir()
    a = run(fixed, full)
    run(fixed, part, max_steps=10)
    with pytest.raises(ValueError, match=r"differs in step_control.*change_step_policy"):
        run(adaptive, part)
    with pytest.raises(ValueError, match=r"differs in seed\)$"):
        run(replace(adaptive, seed=3), part, change_step_policy=True)
    run(adaptive, part, change_step_policy=True, max_steps=30)
    b = run(replace(fixed, dt=0.04), part, change_step_policy=True)
    assert b.finished and b.history[:10] == a.history[:10]
    dts = np.array([r["dt"] for r in b.history])
    assert np.all(dts[:10] == 0.08) and dts[10:40].min() < 0.08 and np.all(dts[40:-1] == 0.04)
    config = json.loads((part / "config.json").read_text())
    assert (config["dt"], config["step_control"]) == (0.04, "fixed")
    assert config["step_policy_changes"] == [
        {"step": 10, "step_control": ["fixed", "cost"]},
        {"step": 40, "dt": [0.08, 0.04], "step_control": ["cost", "fixed"]}]


@pytest.mark.parametrize("old_step_field", [None, False])
def test_checkpoint_of_earlier_version_resumes(tmp_path, old_step_field):
    """A checkpoint of an earlier version resumes.

    Written before step_control, with its predecessor adaptive_dt = False or before that existed
    too (and the pass counts).

    It runs with the configuration it ran with (a fixed step), and the missing history entries
    are left blank.
    """
    cfg = Config(lam=1e-2, time=1.0, dt=0.01, seed=1, step_control="fixed")
    full, old = tmp_path / "full", tmp_path / "old"
    full.mkdir()
    old.mkdir()
    run(cfg, full)
    stopped = run(cfg, old, max_steps=40)
    ck = old / "checkpoint.npz"
    with np.load(ck) as z:
        arrays = dict(z)
    del arrays["sha256"]  # earlier versions: no checksum, the history rows in meta
    meta = json.loads(str(arrays.pop("meta")))
    meta["history"] = stopped.history
    del meta["config"]["step_control"], meta["dt_next"]
    if old_step_field is not None:
        meta["config"]["adaptive_dt"] = old_step_field
    for row in meta["history"]:
        del row["pass_iterations"], row["failed_iterations"], row["max_rotation"]
        del row["max_displacement"]
    np.savez(ck, meta=np.array(json.dumps(meta)), **arrays)
    run(cfg, old)
    assert (full / "particles.csv").read_bytes() == (old / "particles.csv").read_bytes()
    h = np.genfromtxt(old / "history.csv", delimiter=",", names=True)
    assert np.isnan(h["pass_iterations"][:40]).all()
    assert np.isfinite(h["pass_iterations"][40:]).all()


def test_next_dt_rules():
    """The "cost" step: halved, shrunk or grown by the solve's work, with a floor.

    Halved step -> dt/2; passes costlier than half the main solve -> shrink; cheaper than a
    quarter -> grow up to dt_max; floor dt_max / 2^(MAX_HALVINGS + 2).
    """
    def info(main, passes, sub=1):
        return {"iterations": main + passes, "pass_iterations": passes, "substeps": sub}
    assert next_dt(0.01, info(100, 10, sub=2), 0.02, "cost") == 0.005
    assert next_dt(0.01, info(100, 60), 0.02, "cost") == pytest.approx(stepping.DT_SHRINK * 0.01)
    assert next_dt(0.01, info(100, 40), 0.02, "cost") == 0.01
    assert next_dt(0.01, info(100, 10), 0.02, "cost") == pytest.approx(stepping.DT_GROWTH * 0.01)
    assert next_dt(0.02, info(100, 0), 0.02, "cost") == 0.02
    assert next_dt(1e-9, info(100, 90), 0.02, "cost") == 0.02 / 2 ** (MAX_HALVINGS + 2)


def test_next_dt_overlap():
    """The "overlap" step: dt sqrt(MAIN_OVERLAP / e) for the overlap e the last move left.

    (The overlap is second order in dt.)  At most DT_RISE times longer, at most dt_max, at most
    half after a halved step, never below the floor.
    """
    def info(e, sub=1):
        return {"main_overlap": e, "substeps": sub}
    target = stepping.MAIN_OVERLAP
    assert next_dt(0.01, info(4 * target), 0.02, "overlap") == pytest.approx(0.005)
    assert next_dt(0.01, info(target), 0.02, "overlap") == pytest.approx(0.01)
    assert next_dt(0.01, info(target / 100), 0.02, "overlap") == pytest.approx(
        stepping.DT_RISE * 0.01)
    assert next_dt(0.019, info(0.0), 0.02, "overlap") == 0.02
    assert next_dt(0.01, info(0.0, sub=2), 0.02, "overlap") == 0.005
    assert next_dt(0.01, info(1e9), 0.02, "overlap") == 0.02 / 2 ** (MAX_HALVINGS + 2)
    assert next_dt(0.01, info(1e9), 0.02, "fixed") == 0.02


def test_overlap_step_keeps_the_linearisation_error():
    """The "overlap" control keeps the overlap a step's move leaves near MAIN_OVERLAP.

    A fixed step of the same length leaves twice as much (lam = 0, dt = 0.1, to 400 particles:
    medians 0.133 and 0.29); the step follows it (shorter than dt once the colony jams, never
    longer: the shortest step 0.053 with the spatial order of 2026-12-02, below 0.05 before).
    """
    def grow(control):
        sim = Simulation(Config(lam=0.0, dt=0.1, seed=1, step_control=control))
        while sim.state.n < 400:
            sim.step()
        h = [r for r in sim.history if r["n_particles"] > 100]
        return (np.median([r["main_overlap"] for r in h]),
                np.array([r["dt"] for r in sim.history]))
    fixed, _ = grow("fixed")
    adapted, dts = grow("overlap")
    assert adapted <= stepping.MAIN_OVERLAP < fixed
    assert dts.min() < 0.75 * 0.1 and dts.max() <= 0.1


def test_init_file(tmp_path):
    f = tmp_path / "init.csv"
    f.write_text("x,y,theta,length\n0,0,0,1.5\n1.5,0,0,1.5\n")
    c = run(Config(lam=0.0, time=0.1, dt=0.01, init=str(f))).state
    assert c.n == 2 and c.x[1] - c.x[0] > 1.5
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,length\n0,0,1\n")
    with pytest.raises(ValueError, match="x,y,theta,length"):
        run(Config(lam=0.0, time=0.1, init=str(bad)))


@pytest.mark.parametrize(
    "kw",
    [
        dict(lam=-1.0, time=1.0),
        dict(lam=0.0, time=1.0, radius=2.0),
        dict(lam=0.0, time=-1.0),
        dict(lam=0.0, time=1.0, dt=0.0),
        dict(lam=0.0, time=1.0, tol=1.0),
        dict(lam=0.0, time=1.0, solver="nope"),
        dict(lam=0.0, time=1.0, init="/nonexistent.csv"),
        dict(lam=0.0, time=1.0, threads=0),
        dict(lam=0.0, time=1.0, threads=10_000),
        dict(lam=0.0, time=1.0, threads="two"),
        dict(lam=0.0, time=1.0, threads=True),
        dict(lam=float("nan"), time=1.0),
        dict(lam=0.0, time=1.0, output_every=-0.1),
        dict(lam=0.0, time=1.0, output_every=math.inf),
        dict(lam=0.0, time=1.0, output_every=1e-320),
    ],
)
def test_validate(kw):
    with pytest.raises(ValueError):  # when the configuration is made
        Config(**kw)


def test_a_run_needs_a_goal():
    with pytest.raises(ValueError, match="exactly one"):
        run(Config(lam=0.0))


def test_auto_threads_follow_the_colony_size(monkeypatch):
    """The default threads = "auto" follows the colony's size.

    One thread below THREADS_MIN_PARTICLES, every usable core (at most NUMBA_NUM_THREADS) from
    there on; a number is kept.
    """
    from particles.stepping import THREADS_MIN_PARTICLES, solver_threads
    Config(lam=0.0, time=1.0, threads="auto").validate()
    assert Config(lam=0.0).threads == "auto"
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {0, 1, 2}, raising=False)
    monkeypatch.setattr("numba.config.NUMBA_NUM_THREADS", 2)
    assert solver_threads("auto", THREADS_MIN_PARTICLES - 1) == 1
    assert solver_threads("auto", THREADS_MIN_PARTICLES) == 2  # capped by Numba's threads
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {5}, raising=False)
    assert solver_threads("auto", 10**6) == 1  # one usable core
    assert solver_threads(2, 10) == 2


def test_solver_tolerance_is_tol_and_older_runs_keep_half_of_it():
    """The solver's residual tolerance: tol by default (issue 18), tol / 2 in older runs.

    An older configuration (no solver_tol_factor) reads back with the factor it ran with.
    """
    from particles.config import upgrade
    assert Config(lam=0.0, tol=2e-3).effective_solver_tol == 2e-3
    assert Config(lam=0.0, tol=2e-3, solver_tol=1e-4).effective_solver_tol == 1e-4
    old = upgrade({"lam": 0.0, "tol": 2e-3, "solver_tol": None})
    assert Config(**old).effective_solver_tol == 1e-3
    with pytest.raises(ValueError, match="solver_tol_factor must be positive"):
        Config(lam=0.0, time=1.0, solver_tol_factor=0.0).validate()


def test_radius_of_single_particle():
    st = initial_state(Config(lam=0.0, time=1.0))
    assert st.enclosing_radius() == pytest.approx(0.5)


@pytest.mark.slow
def test_radius_40_colony(tmp_path):
    """The issue's acceptance run: lam = 1e-2 to radius 40 (about a minute on 2 cores)."""
    c = run(Config(lam=1e-2, radius=40.0), tmp_path).state
    assert c.n > 5000
    hist = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    assert np.all(hist["max_overlap"] <= 1e-3)
    assert np.all(np.diff(hist["total_length"]) > 0)  # growth never reverses
    # the stress is largest inside the colony, near zero at the edge
    r = np.hypot(c.x - c.x.mean(), c.y - c.y.mean())
    assert c.stress[r < 10].mean() > 5 * c.stress[r > 35].mean()


def test_failed_steps_are_halved():
    """With no re-solve passes allowed, overlapping steps are redone as dt/2 sub-steps."""
    c = run(Config(lam=1e-2, time=4.0, dt=0.02, max_passes=0))
    sub = np.array([r["substeps"] for r in c.history])
    assert sub.max() > 1 and np.all(np.array([r["passes"] for r in c.history]) == 0)
    assert max(r["max_overlap"] for r in c.history) <= 1e-3
    assert c.state.t == pytest.approx(4.0, abs=1e-12)
    failed = np.array([r["failed_iterations"] for r in c.history])
    # the failed attempts' work is counted, and only in halved steps (an attempt may fail
    # after 0 iterations: warm start within tolerance, overlap after the move)
    assert np.all(failed[sub == 1] == 0) and failed[sub > 1].sum() > 0


def test_a_pass_longer_than_the_main_solve_fails_the_step(monkeypatch):
    """A re-solve pass may take max(PASS_ITERATION_FLOOR, main-solve iterations) iterations.

    With a main solve that does nothing, the overlaps of growth are left to the passes, which
    succeed within the default floor and fail (ContactSolveError, so the step is halved)
    within 2.
    """
    state = run(Config(lam=1e-2, time=3.0, dt=0.02)).state
    cfg = Config(lam=1e-2, time=3.0, dt=0.05)
    warm = (np.zeros(0, dtype=np.int64), np.zeros(0))

    def no_main_solve(c, length, dt, lam, gamma0, tol, maxiter, growth, rate=1.0):
        if growth:
            return np.zeros(len(c)), np.zeros(1)
        return solve_contacts(c, length, dt, lam, gamma0, tol, maxiter, growth)

    monkeypatch.setattr(stepping, "BY_NAME", {"bbpgd": no_main_solve})
    info, _ = step(state.copy(), cfg, cfg.dt, warm)
    assert info["passes"] > 0 and 2 < info["pass_iterations"] <= info["passes"] * 1000
    monkeypatch.setattr(stepping, "PASS_ITERATION_FLOOR", 2)
    spent = [0]
    with pytest.raises(ContactSolveError, match="in 2 iterations"):
        step(state.copy(), cfg, cfg.dt, warm, spent=spent)
    assert spent[0] >= 2


def test_progress_lines_in_a_log(monkeypatch, caplog, tmp_path):
    """With progress on and stderr not a terminal (pytest captures it), run() logs progress."""
    import particles.runfiles as runfiles

    monkeypatch.setattr(runfiles, "PROGRESS_SECONDS", 0.0)
    with caplog.at_level("INFO", logger="particles.runfiles"):
        run(Config(lam=1e-2, radius=1.5, seed=0), out=tmp_path, progress=True)
    lines = [r.getMessage() for r in caplog.records if r.name == "particles.runfiles"]
    assert lines and all(m.startswith("radius ") and " of 1.5, t = " in m and " particles, "
                         in m for m in lines)
    caplog.clear()
    with caplog.at_level("INFO", logger="particles.runfiles"):
        Simulation(Config(lam=1e-2, seed=0)).advance(radius=1.5)  # progress off by default
    assert not [r for r in caplog.records if r.name == "particles.runfiles"]


def test_kept_detections_change_nothing(monkeypatch):
    """A step reuses the previous step's final contacts (stepping.Detections).

    It does when no division changed the configuration; the run is the same bit for bit as
    one detecting every time.
    """
    hits = []
    get = stepping.Detections.get

    def counted(self, state, margin):
        kept = get(self, state, margin)
        hits.append(kept is not None)
        return kept

    cfg = Config(lam=0.0, radius=6.0, seed=3)
    monkeypatch.setattr(stepping.Detections, "get", counted)
    a = run(cfg)
    monkeypatch.setattr(stepping.Detections, "get", lambda self, state, margin: None)
    b = run(cfg)
    assert sum(hits) > len(a.history) / 2  # most steps at lam = 0 start from kept contacts
    assert a.history == b.history
    for name, value in a.state.arrays().items():
        assert value.tobytes() == getattr(b.state, name).tobytes(), name


def test_a_first_run_says_it_compiles(tmp_path, monkeypatch, caplog):
    """Without the kernels in Numba's cache, a run with progress says once that it compiles."""
    import logging

    import particles.simulation as S

    assert S.kernels_cached()  # the suite has run them: the cache is written
    monkeypatch.setattr(S, "kernels_cached", lambda: False)
    with caplog.at_level(logging.INFO, logger="particles.simulation"):
        S.run(Config(lam=1e-2, time=0.04), tmp_path, progress=True)
    assert sum("compiling the engine's kernels (first run only" in r.message
               for r in caplog.records) == 1


def test_kernels_cached_reads_numbas_cache_index(tmp_path, monkeypatch):
    """kernels_cached reads Numba's cache index files, no private attribute of Numba.

    False for a __pycache__ without the solver's index file, True with it, True (unknown) when
    there is no cache folder at all.
    """
    import numba

    import particles.simulation as S
    from particles.solvers import bbpgd

    monkeypatch.setattr(bbpgd, "__file__", str(tmp_path / "bbpgd.py"))
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")
    assert S.kernels_cached()  # no __pycache__: unknown
    (tmp_path / "__pycache__").mkdir()
    (tmp_path / "__pycache__" / "bbpgd.bb_smooth-87.py311.nbi").write_bytes(b"")
    assert not S.kernels_cached()  # another kernel's index only
    (tmp_path / "__pycache__" / "bbpgd._bbpgd-141.py311.nbi").write_bytes(b"")
    assert S.kernels_cached()


def test_frames_every_output_every_of_time(tmp_path):
    """Fixed steps of 0.01 and frames every 0.05: a frame every 5 steps.

    t summed over the steps falls short of the multiples (0.1 + 0.2 != 0.3); 0: the first and
    the last frames only.
    """
    assert frame_count(sum([0.01] * 10), 0.1) == 1 > math.floor(sum([0.01] * 10) / 0.1)
    assert frame_count(0.35, 0.1) == 3 and frame_count(5.0, 0.0) == 0
    for every, steps in ((0.05, [0, 5, 10, 15, 20, 25, 30]), (0.0, [0, 30])):
        out = tmp_path / f"every{every}"
        out.mkdir()
        run(Config(lam=1e-2, time=0.3, dt=0.01, step_control="fixed", output_every=every), out)
        with gsd.hoomd.open(str(out / "trajectory.gsd")) as traj:
            assert [f.configuration.step for f in traj] == steps


def test_older_step_counts_read_as_times():
    """Before issue 43 output_every counted steps: N steps of dt are read as the time N dt."""
    assert upgrade({"lam": 0.0, "dt": 0.01, "output_every": 50})["output_every"] == 0.5
    assert upgrade({"lam": 0.0, "dt": 0.01, "output_every": 0.5})["output_every"] == 0.5
    assert Config(lam=0.0, output_every=2).output_every == 2.0  # saved as a time
    assert isinstance(Config(lam=0.0, output_every=2).output_every, float)
    data = Path(__file__).parents[2] / "cases" / "data"  # the committed particle runs
    saved = [json.loads(p.read_text()) for p in sorted(data.glob("**/config.json"))]
    older = [c for c in saved if "division_noise" in c and isinstance(c["output_every"], int)]
    assert len(older) >= 3
    for c in older:
        assert Config(**upgrade(c)).output_every == c["output_every"] * c["dt"]
