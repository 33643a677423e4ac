"""The benchmark scripts run small, the package's and the measurements of docs/measurements/.

The package's run as ``python -m cases.bench.NAME``, the measurements (not in the package) as
``python docs/measurements/NAME.py``: the tests load them from their files.

The continuum target run to radius 150 is marked slow; the others run a few steps of small
colonies and check that the scripts' numbers add up.
"""

import shutil
from dataclasses import replace
from pathlib import Path

import numba
import numpy as np
import pytest

import particles
from particles import Config, run
from tests.measurements import measurement


@pytest.mark.slow
def test_target_run_radius_150_rings():
    """The benchmark target (cases.bench.continuum): lam = 1e-2 to radius 150, default settings.

    The two outer rings lie within 1% of the local ring spacing of the 1D reference at the same
    radius (measured 0.50% and 0.35%, 86 s CPU, see the report in the README).
    """
    from cases.bench.continuum import target_run

    r = target_run(150.0)
    assert r["outer_max_rel_err"] < 0.01, r["rings"][-2:]
    assert r["all_max_rel_err"] < 0.015, r["rings"]


def test_bench_particles_both_solvers_same_states(tmp_path):
    """cases.bench.particles (issue 4): both solvers on the same grown and CSV states."""
    from cases.bench import particles as bench_particles

    config = particles.Config(lam=1e-2, time=1e9, dt=bench_particles.FIXED_DT,
                              step_control="fixed")
    grown = bench_particles.grow_states(config, [60], tmp_path)
    state, *_ = bench_particles.load_state(grown[0])
    csv = tmp_path / "colony.csv"
    np.savetxt(csv, np.c_[state.x, state.y, state.theta, state.length], delimiter=",",
               header="x,y,theta,length", comments="")
    threads = ["1", "2"] if numba.config.NUMBA_NUM_THREADS >= 2 else ["1"]
    res = bench_particles.main(["--sizes", "60", "--state", str(csv), "--steps", "2",
                                "--folder", str(tmp_path), "--threads", *threads])
    assert sorted(res) == sorted(["apgd", "bbpgd"] + [f"{s}@2" for s in ("apgd", "bbpgd")
                                                      if threads == ["1", "2"]])
    if len(threads) == 2:  # the same iterates on two threads
        assert [r["iterations"] for r in res["bbpgd"]] == [r["iterations"]
                                                           for r in res["bbpgd@2"]]
    for rows in res.values():
        assert [r["N"] for r in rows] == [state.n, state.n]  # the same two states, both solvers
        assert all(r["iterations"] > 0 and r["contacts"] > 0 for r in rows)
    # every measurement in a fresh process, thread counts alternating
    secs = bench_particles.main(["--sizes", "60", "--steps", "1", "--folder", str(tmp_path),
                                 "--threads", *threads, "--alternate", "1"])
    assert sorted(secs) == [int(t) for t in threads]
    assert all(list(v) == [state.n] and len(v[state.n]) == 1 for v in secs.values())
    with pytest.raises(SystemExit):
        bench_particles.main(["--state", str(tmp_path / "missing.csv")])


def test_bench_timestep_small(tmp_path, capsys):
    """The step-policy benchmark docs/measurements/timestep.py (issue 4).

    Every run reaches the radius, the work adds up, the uncapped variant runs, a bad policy is
    a usage error.
    """
    bench_timestep = measurement("timestep")

    out = tmp_path / "b.csv"
    rows = bench_timestep.main(["--radius", "4", "--lams", "1e-2", "--policies", "fixed:0.02",
                                "cost:0.08", "--uncapped", "--out", str(out)])
    assert [(r["policy"], r["uncapped"]) for r in rows] == [
        ("fixed:0.02", False), ("fixed:0.02", True), ("cost:0.08", False)]
    for r in rows:
        assert r["main_iterations"] > 0 and r["steps"] > 10 and r["n_particles"] > 4
    assert rows[0]["t_at_radius"] == pytest.approx(rows[2]["t_at_radius"], rel=0.05)
    assert len(np.genfromtxt(out, delimiter=",", names=True, dtype=None)) == 3
    assert "| 0.01 | cost:0.08 |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        bench_timestep.main(["--policies", "fixed:abc"])


def _whole_and_stopped(cfg, tmp_path, steps: int):
    """(the uninterrupted run of cfg, the folder of the same run stopped after ``steps``)."""
    full, part = tmp_path / "full", tmp_path / "part"
    full.mkdir(parents=True)
    part.mkdir()
    whole = run(cfg, full)
    run(cfg, part, max_steps=steps)
    return whole, part


def test_bench_timestep_from_checkpoint(tmp_path, capsys):
    """The step-policy benchmark from a checkpoint (docs/measurements/timestep.py --checkpoint).

    With the run's own step it continues the run exactly (same iterations and particles as the
    uninterrupted run's next steps); a policy with half the step takes twice the steps; a
    missing checkpoint is a usage error.
    """
    bench_timestep = measurement("timestep")

    cfg = Config(lam=1e-2, time=3.6, dt=0.02, seed=3, step_control="fixed")
    a, part = _whole_and_stopped(cfg, tmp_path, 150)
    rows = bench_timestep.main(["--checkpoint", str(part / "checkpoint.npz"), "--duration",
                                "0.2", "--policies", "fixed:0.02", "fixed:0.01", "--out",
                                str(tmp_path / "c.csv")])
    same, half = rows
    nxt = a.history[150:160]
    assert same["steps"] == 10 and half["steps"] == 20 and same["duration"] == pytest.approx(0.2)
    assert same["main_per_time"] * 0.2 == pytest.approx(
        sum(r["iterations"] - r["pass_iterations"] for r in nxt))
    assert same["n_particles"] == nxt[-1]["n_particles"] > 4
    assert 0 < same["rotation_q999"] <= same["max_rotation"]
    assert "| fixed:0.01 | 20 |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        bench_timestep.main(["--checkpoint", str(tmp_path / "none.npz")])
    # the overlap control continues from the run's own last step: the run's next steps exactly;
    # a lower target (third field) takes shorter steps
    ocfg = replace(cfg, step_control="overlap", seed=4)
    b, opart = _whole_and_stopped(ocfg, tmp_path / "overlap", 100)
    nxt = b.history[100:110]
    span = nxt[-1]["t"] - b.history[99]["t"]
    same, low = bench_timestep.main(["--checkpoint", str(opart / "checkpoint.npz"), "--duration",
                                     str(span), "--policies", "overlap:0.02",
                                     "overlap:0.02:1e-5", "--out", str(tmp_path / "o.csv")])
    assert same["steps"] == 10 and same["main_per_time"] * span == pytest.approx(
        sum(r["iterations"] - r["pass_iterations"] for r in nxt))
    assert low["steps"] > same["steps"]
    for bad in ("fixed:0.01:0.1", "overlap:0.02:0", "overlap:0.02:x", "overlap:0.02:0.1:2"):
        with pytest.raises(ValueError, match="CONTROL:DT"):
            bench_timestep.parse_policy(bad)
    # --history: the segments of a run resumed with another dt add up to its history
    run(replace(cfg, dt=0.01), part, change_step_policy=True)
    seg = bench_timestep.main(["--history", str(part)])
    h = np.genfromtxt(part / "history.csv", delimiter=",", names=True)
    assert [(r["first_step"], r["last_step"]) for r in seg] == [(1, 150), (151, len(h))]
    assert [r["dt_max"] for r in seg] == pytest.approx([0.02, 0.01])
    work = h["iterations"] + h["failed_iterations"]
    assert sum(r["per_time"] * r["steps"] * r["dt_max"] for r in seg) == pytest.approx(
        work.sum(), rel=1e-6)
    with pytest.raises(SystemExit):
        bench_timestep.main(["--history", str(tmp_path / "none")])


def test_bench_psi_transport_labels_exact(capsys):
    """The transport by labels exact at every node (docs/validation.md's table).

    At a radius before the first remesh; the remeshes are tested in
    tests/continuum/test_psi_characteristics.py.
    """
    main = measurement("psi_transport").main

    (labels,) = main(["--radius", "8"])
    assert labels["transport"] == "characteristics-labels" and labels["nodes"] > 100
    assert labels["max_all"] < 1e-10 and labels["total_length_spread"] < 1e-10
    assert "| transport |" in capsys.readouterr().out


def test_bench_elements_small(capsys):
    """docs/measurements/elements.py: a row per element and a mode rate near the exact K / 2.

    The two P1 assemblies print equal errors, P2 a smaller pressure error.
    """
    main = measurement("elements").main

    main(["--sizes", "300", "--repeats", "1", "--radius", "0", "--modes", "2",
          "--mode-runs", "P1"])
    rows = [line.split("|")[1:-1] for line in capsys.readouterr().out.splitlines()
            if line.startswith("| P")]
    by = {r[0].strip(): r for r in rows[:3]}
    assert list(by) == ["P1", "P1-skfem", "P2"]
    assert by["P1"][7:9] == by["P1-skfem"][7:9]  # same pressure and velocity errors
    assert float(by["P2"][7]) < 0.1 * float(by["P1"][7])
    mode = rows[3]
    assert mode[0].strip() == "P1" and abs(float(mode[6]) - 1.0) < 0.02


def test_bench_handoff_table(capsys):
    """The hand-off's accuracy table (docs/validation.md) at the default alpha and bandwidth."""
    main = measurement("handoff").main

    outline, psi0 = main(["--alphas", "1", "--bandwidths", "2"])
    assert all(abs(r["area_error"]) < 0.01 for r in outline)
    assert all(r["aspect"] == pytest.approx(r["aspect_exact"], rel=0.01) for r in outline)
    (row,) = psi0
    assert row["max_mean_error"] < 1e-3
    assert row["median_spread"] == pytest.approx(row["spread_exact"], rel=0.1)
    assert row["step_width_10_90"] == pytest.approx(row["step_width_exact"], rel=0.1)
    assert "| packing |" in capsys.readouterr().out


def test_history_stretches_of_size_with_wall_times(tmp_path, capsys):
    """--sizes partitions the steps by colony size; --logs gives each stretch's wall time.

    A history of 400 steps of dt 0.01 with N = step and 10 iterations each, and a log whose
    progress lines put step 100 at 60 s and step 400 at 360 s (and the start, step 0, at 0 s):
    the stretch N in [100, 300) (steps 100-299) runs from the end of step 99 (59.4 s, linear
    between the lines) to that of step 299 (259 s), 199.6 s for 2000 iterations.
    """
    from cases import analysis as A
    bench_timestep = measurement("timestep")
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text("{}")
    step = np.arange(1, 401)
    A.write_csv(run / "history.csv", {"step": step, "t": 0.01 * step, "dt": 0.01 + 0 * step,
                                      "n_particles": step, "iterations": 10 + 0 * step,
                                      "failed_iterations": 0 * step, "substeps": 1 + 0 * step,
                                      "max_overlap": 1e-4 + 0 * step})
    log = tmp_path / "run.log"
    log.write_text("colony: radius 5 of 9, t = 1, 100 particles, step 100, dt 0.01, 60 s\r"
                   "something else\n"
                   "colony: radius 9 of 9, t = 4, 400 particles, step 400, dt 0.01, 360 s\n")
    np.testing.assert_array_equal(A.progress_wall(log)[0], [0, 100, 400])
    # a stopped and resumed run's log counts on from the last line before the stop
    resumed = tmp_path / "resumed.log"
    resumed.write_text(log.read_text().replace("step 400, dt 0.01, 360 s", "step 300, dt 0.01, "
                       "300 s\ncolony: terminated\ncolony: resuming\n"
                       "colony: radius 9 of 9, t = 4, 400 particles, step 400, dt 0.01, 70 s"))
    np.testing.assert_array_equal(A.progress_wall(resumed)[1], [0, 60, 300, 370])
    rows = bench_timestep.main(["--history", str(run), "--sizes", "100", "300",
                                "--logs", str(log)])
    assert [(r["first_step"], r["last_step"]) for r in rows] == [(1, 99), (100, 299), (300, 400)]
    assert rows[1]["wall_s"] == pytest.approx(199.6)
    assert rows[1]["ms_per_iteration"] == pytest.approx(99.8)
    assert rows[0]["wall_s"] == pytest.approx(60 * 99 / 100)
    assert rows[1]["per_time"] == pytest.approx(1000)
    assert "| 100-299 | 100-299 | 1.00-2.99 |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        bench_timestep.main(["--history", str(run), "--logs", str(log), str(log)])


def test_bench_contact_solvers_small(tmp_path):
    """docs/measurements/contact_solvers.py (issue 4): both solvers, cold and warm, meet the tol.

    The removed two-level solver (issue 43) is no longer a choice: a usage error.
    """
    import csv

    contact_solvers = measurement("contact_solvers")

    out = tmp_path / "solvers.csv"
    contact_solvers.main(["--sizes", "400", "--tol", "1e-3", "--repeat", "1", "--out", str(out)])
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {(r["solver"], r["start"]) for r in rows} == {
        (s, start) for s in ("bbpgd", "apgd") for start in ("cold", "warm")}
    assert all(int(r["iterations"]) > 0 and float(r["residual"]) <= 1e-3 for r in rows)
    with pytest.raises(SystemExit):
        contact_solvers.main(["--solvers", "twolevel"])


def test_bench_cost_growth_fits_a_power_law(tmp_path, capsys):
    """Progress lines on W = 2 (R/10)^3.5, N = 4 R^2: the fitted exponents and the projection."""
    cost_growth = measurement("cost_growth")
    run = tmp_path / "run"
    data = Path(__file__).parents[2] / "cases" / "data" / "particles_paper"
    shutil.copytree(data / "lam=0.001", run)
    radii = np.arange(50.0, 151.0, 5.0)  # the history ends at R = 150.07: no end point added
    law = 2 * (radii / 10) ** 3.5
    (run / "progress.log").write_text("".join(
        f"colony: radius {r:.2f} of 150, t = 1, {4 * r * r:.0f} particles, step {k + 1}, "
        f"dt 0.001, {w:.0f} s\n" for k, (r, w) in enumerate(zip(radii, law, strict=True))))
    (run / "time.txt").write_text("\tUser time (seconds): 3000.0\n"
                                  "\tElapsed (wall clock) time (h:mm:ss or m:ss): 25:00\n"
                                  "\tMaximum resident set size (kbytes): 500000\n")
    row, = cost_growth.main(["--runs", str(run), "--radii", "100", "200", "--target", "260"])
    assert abs(row["wall_exponent"] - 3.5) < 2e-3  # whole seconds in the log
    assert abs(row["particle_exponent"] - 2) < 1e-4
    assert row["wall_s at R=100"] == pytest.approx(2 * 10**3.5, abs=0.5)
    assert np.isnan(row["wall_s at R=200"])
    assert row["busy_threads"] == pytest.approx(2.0)
    assert row["target_wall_h"] == pytest.approx(2 * 26**3.5 / 3600, rel=5e-3)
    assert row["target_core_h"] == pytest.approx(2 * row["target_wall_h"])
    assert row["target_particles"] == pytest.approx(4 * 260**2, rel=1e-3)
    assert row["target_peak_mb"] == pytest.approx(500 * (260 / 150) ** 2, rel=1e-3)
    assert "2688 core hours" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        cost_growth.main(["--runs", str(run), "--fit", "200", "250"])
    assert "need 3 to fit" in capsys.readouterr().err


def test_bench_particles_reads_a_run_checkpoint(tmp_path):
    """``--state checkpoint.npz``: a run's state, time and warm start, as the run resumes it."""
    from cases.bench.particles import load_state

    sim = run(Config(lam=1e-2, time=1.0), tmp_path, max_steps=30)
    state, t, warm, _ = load_state(tmp_path / "checkpoint.npz")
    np.testing.assert_array_equal(state.x, sim.state.x)
    assert state.next_id == sim.state.next_id and t == sim.state.t
    np.testing.assert_array_equal(warm[1], sim.state.warm_gamma)


def test_stream_triad_counts_24_bytes_an_element(capsys):
    """docs/measurements/stream.py: the triad's result, and B(1) = 1 in its table."""
    stream = measurement("stream")
    a, b, c = np.zeros(5), np.arange(5.0), np.ones(5)
    stream.triad(a, b, c, 3.0)
    np.testing.assert_array_equal(a, b + 3.0)
    ((threads, bw),) = stream.main(["--threads", "1", "--mb", "1", "--repeats", "2"])
    assert threads == 1 and bw > 0
    row = capsys.readouterr().out.splitlines()[2]
    assert row.startswith("| 1 | ") and row.endswith(" | 1.00 |")


def test_phases_split_a_step_and_add_up(tmp_path, capsys):
    """docs/measurements/phases.py: exclusive phases whose sum is the step's CPU time."""
    phases = measurement("phases")
    run(Config(lam=1e-2, radius=5), tmp_path, progress=False)  # 32 cells in contact
    for gather in (False, True):
        med = phases.main(["--state", str(tmp_path / "checkpoint.npz"), "--steps", "1",
                           *(["--gather"] if gather else [])])[str(tmp_path / "checkpoint.npz")]
        timed = sum(v for k, v in med.items() if k not in (
            "wall", "cpu", "iterations", "contacts", "N") and not k.startswith("cell sort"))
        assert 0.5 * med["cpu"] < timed <= med["cpu"] * (1 + 1e-9) + 1e-6, med
        assert med["BBPGD kernel"] > 0 and med["iterations"] > 0
        text = capsys.readouterr().out
        assert "serial fraction s = " in text and ("gather" if gather else "scatter") in text
