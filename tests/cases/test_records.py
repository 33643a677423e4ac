"""docs/measurements/records.py (small data of big runs); a hand-grown run taken by a sweep."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cases import analysis as A
from cases.sweep import finished_runs, initial_config, is_done, run_name
from tests.measurements import measurement

records = measurement("records")


def fake_run(folder, **config):
    """A finished particle run folder (run.json, config.json, history, profile) of ``config``."""
    folder.mkdir(parents=True)
    config = {"lam": 0.1, "radius": 15.0, "dt": 0.01, "output_every": 0.4, **config}
    (folder / "config.json").write_text(json.dumps(config))
    (folder / "run.json").write_text(json.dumps({"engine": "particles", "config": config,
                                                 "status": "finished"}))
    n = 5000
    A.write_csv(folder / "history.csv", {"step": np.arange(n) + 1, "t": 0.01 * np.arange(n),
                                         "dt": np.full(n, 0.01),
                                         "radius": np.linspace(0.5, 15, n),
                                         "n_particles": 20.0 * np.arange(n) + 1.0,
                                         "iterations": np.full(n, 100.0),
                                         "failed_iterations": np.where(np.arange(n) < 100, 50, 0),
                                         "substeps": np.where(np.arange(n) < 100, 2, 1),
                                         "max_overlap": np.full(n, 5e-4)})
    A.write_csv(folder / "profile.csv", {"r": [1.0, 2.0], "mean_length": [1.5, 1.4]})
    return folder


def test_a_run_grown_into_the_sweeps_folder_is_the_sweeps(tmp_path):
    """``colony particles ... --out ROOT/NAME`` with the sweep's configuration counts as done.

    The name and command are ``colony case NAME --print-runs``; a run there whose configuration
    differs is refused with the difference named, and not touched.
    """
    params = {"engine": "particles", "lam": 0.1, "radius": 15.0, "output_every": 0.4}
    run = fake_run(tmp_path / "runs" / run_name(params))
    assert is_done(run, params) and is_done(run)
    assert finished_runs([("particles", 0.1)], "smoke", tmp_path / "runs") == {
        ("particles", 0.1): run}
    other = fake_run(tmp_path / "other" / run_name(params), radius=40.0)
    with pytest.raises(ValueError, match=r"differs from the sweep's: radius = 40.0 .sweep: 15.0"):
        is_done(other, params)
    with pytest.raises(ValueError, match=r"engine = 'particles' .sweep: 'continuum'"):
        is_done(run, {**params, "engine": "continuum"})
    (run / "run.json").write_text(json.dumps({"engine": "particles", "status": "stopped"}))
    assert not is_done(run, params)


def test_print_runs_gives_the_sweeps_folders_and_commands(tmp_path, capsys):
    from cases import cli

    assert cli.main(["case", "fig2", "--scale", "smoke", "--print-runs", "--runs",
                     str(tmp_path / "runs"), "--lams", "0.1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    params = {"engine": "particles", "lam": 0.1, "radius": 15.0, "output_every": 0.4}
    assert (f"colony particles --lam 0.1 --radius 15 --set output_every=0.4 --out "
            f"{tmp_path / 'runs' / run_name(params)}") in lines
    assert len(lines) == 2 and not (tmp_path / "runs").exists()


def test_record_copies_the_small_data(tmp_path):
    run = fake_run(tmp_path / "by_hand")
    log = tmp_path / "time.log"
    log.write_text("\tCommand being timed: \"a\"\n\tUser time (seconds): 1.0\n"
                   "\tCommand being timed: \"b\"\n\tUser time (seconds): 2.0\n")
    dest = records.record(run, tmp_path / "data", log)
    assert dest == tmp_path / "data" / "lam=0.1"
    h = A.read_csv(dest / "history.csv")
    np.testing.assert_array_equal(h["step"], np.arange(1, 5001))  # every step
    np.testing.assert_allclose(h["t"], A.read_csv(run / "history.csv")["t"], rtol=1e-8)
    assert (dest / "profile.csv").read_text() == (run / "profile.csv").read_text()
    assert (dest / "time.txt").read_text().count("Command being timed") == 2
    work = A.read_csv(dest / "work.csv")  # all steps, then N >= 6e4 (steps from 3000 on)
    np.testing.assert_array_equal(work["min_particles"], [0, 6e4])
    np.testing.assert_array_equal(work["steps"], [5000, 2000])
    np.testing.assert_array_equal(work["halved"], [100, 0])
    np.testing.assert_allclose(work["per_time"], [(5e5 + 5e3) / 50, 1e4])
    np.testing.assert_allclose(work["failed_share"], [5e3 / 5.05e5, 0])


def test_record_refuses_what_is_not_a_finished_run(tmp_path, capsys):
    assert records.main([str(tmp_path / "nothing")]) == 2
    assert "not a finished run folder" in capsys.readouterr().err
    run = fake_run(tmp_path / "r")
    assert records.main([str(run), "--data", str(tmp_path / "d"), "--time-log", "nope"]) == 2
    assert "no log file nope" in capsys.readouterr().err and not (tmp_path / "d").exists()


def test_the_sweep_checks_the_configuration_the_run_started_with(tmp_path):
    """A run resumed with another step is checked against the sweep with its starting step.

    The changes are config.json's step_policy_changes (here of dt and of the former
    adaptive_dt); the paper scale's particle runs set only lam, radius and output_every.
    """
    paper = {"lam": 1e-3, "radius": 150.0, "output_every": 50}
    changes = [{"step": 100, "adaptive_dt": [False, True]},
               {"step": 150, "dt": [0.005, 0.0025], "adaptive_dt": [True, False]}]
    run = fake_run(tmp_path / "resumed", **paper, dt=0.0025, adaptive_dt=False,
                   step_policy_changes=changes)
    assert initial_config(json.loads((run / "config.json").read_text())) == {
        **paper, "dt": 0.005, "adaptive_dt": False}
    assert is_done(run, {"engine": "particles", **paper})
    wrong = fake_run(tmp_path / "wrong", **{**paper, "output_every": 100}, dt=0.0025,
                     step_policy_changes=changes)
    with pytest.raises(ValueError, match=r"output_every = 100 .sweep: 50"):
        is_done(wrong, {"engine": "particles", **paper})


def test_summary_and_table_of_recorded_runs(tmp_path):
    target = fake_run(tmp_path / "by_hand")
    log = tmp_path / "time.log"
    report = ("\tCommand being timed: \"colony\"\n\tUser time (seconds): {u}\n"
              "\tElapsed (wall clock) time (h:mm:ss or m:ss): {w}\n"
              "\tMaximum resident set size (kbytes): {m}\n")
    log.write_text(report.format(u=100.5, w="1:02:03", m=400000)
                   + report.format(u=10.0, w="0:59.50", m=500000))
    progress = tmp_path / "progress.log"
    progress.write_text("colony: radius 15 of 15, t = 49.99, 99981 particles, step 5000, "
                        "dt 0.01, 5000 s\n")
    dest = records.record(target, tmp_path / "data", log, progress)
    assert (dest / "progress.log").read_text() == progress.read_text()
    work = A.read_csv(dest / "work.csv")  # 1 s per step; 5000 * 100 + 100 * 50 iterations
    np.testing.assert_allclose(work["wall_s"], [5000, 2000])  # N >= 6e4 from step 3001
    np.testing.assert_allclose(work["ms_per_iteration"], [5e6 / 505000, 10])
    row = records.summary(dest)
    assert row["lam"] == 0.1 and row["particles"] == 99981 and row["steps"] == 5000
    assert row["halved"] == 100 and row["max_overlap"] == 5e-4 and row["reports"] == 2
    assert row["wall_s"] == pytest.approx(3723 + 59.5) and row["user_s"] == 110.5
    assert row["peak_mb"] == 500
    assert row["per_time_large"] == pytest.approx(1e4) and row["failed_share_large"] == 0
    lines = records.table(tmp_path / "data").splitlines()
    assert len(lines) == 3
    assert lines[2].startswith("| 0.1 | 99,981 | 49.99 | 5000 | 100 | 1:03:02 (2")
    (dest / "work.csv").unlink()
    with pytest.raises(ValueError, match="no work.csv"):
        records.summary(dest)


def test_packaged_readme_holds_the_table_of_its_recorded_runs():
    """cases/data/particles_paper/README.md quotes `records.py --table`."""
    data = Path(__file__).resolve().parents[2] / "cases" / "data" / "particles_paper"
    readme = (data / "README.md").read_text()
    rows = records.table(data).splitlines()[2:]
    assert rows
    for row in rows:
        assert row in readme


def record_of(folder, lam, radius, stress, length):
    """A record DATA/lam=LAM: R(t) = radius(t) on t in [0, 10], a profile on r = 1 ... 8."""
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps({"lam": lam}))
    t = np.linspace(0.0, 10.0, 1001)
    A.write_csv(folder / "history.csv", {"t": t, "radius": radius(t),
                                         "n_particles": np.round(100 * t) + 1})
    r = np.arange(1.0, 9.0)
    A.write_csv(folder / "profile.csv", {"r": np.append(r, 9.0), "count": np.append(10 + 0 * r, 0),
                                         "stress": np.append(stress(r), np.nan),
                                         "mean_length": np.append(length(r), np.nan)})
    return folder


def test_compare_two_records_of_one_lam(tmp_path, capsys):
    """Times at radius, central stress and profile changes against hand-computed values."""
    old = record_of(tmp_path / "old", 0.0, lambda t: 16 * t, lambda r: 100 - r**2,
                    lambda r: 1.5 + 0 * r)
    new = record_of(tmp_path / "new", 0.0, lambda t: 15 * t, lambda r: 90 - 0.9 * r**2,
                    lambda r: 1.65 + 0 * r)
    c = records.compare(old, new)
    # R = 16 t and 15 t reach 50, 100, 150 at R / 16 and R / 15
    np.testing.assert_allclose(c["old"]["t_at"], np.array([50, 100, 150]) / 16)
    np.testing.assert_allclose(c["new"]["t_at"], np.array([50, 100, 150]) / 15)
    assert c["old"]["particles"] == 1001 and c["new"]["t"] == 10.0
    # the stress is 0.9 times the old one everywhere: a 10 % mean change; lengths + 10 %
    assert c["d_stress"] == pytest.approx(0.1) and c["d_mean_length"] == pytest.approx(0.1)
    assert c["old"]["p0"] == pytest.approx(100) and c["new"]["p0"] == pytest.approx(90)
    assert records.main(["--compare", str(old), str(new)]) == 0
    assert "| 0 | 1,001 / 1,001 | 10.000 / 10.000 | 3.125 / 3.333 |" in capsys.readouterr().out
    other = record_of(tmp_path / "other", 1e-2, lambda t: t, lambda r: r, lambda r: r)
    assert records.main(["--compare", str(old), str(other)]) == 2
    assert records.main(["--compare", str(old), str(tmp_path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert "different lam" in err[0] and "is not a record" in err[1]


def test_record_of_a_run_with_frames_keeps_the_pooled_profile(particle_run, tmp_path):
    """profile_pooled.csv: the profile the figures draw (pooled over the last frames)."""
    dest = records.record(particle_run, tmp_path / "data")
    pooled = A.read_csv(dest / "profile_pooled.csv")
    expected = A.final_particle_profile(particle_run, growth_window=1.0)
    assert set(pooled) == set(expected)
    for k, v in expected.items():
        np.testing.assert_allclose(pooled[k], v, rtol=1e-7)


# ------------------------------------------------- the radius-260 colony's tables (colony_260)


def test_colony_260_tables_on_exact_data(tmp_path, capsys):
    """docs/measurements/colony_260.py on constructed data with known answers.

    Progress lines on W = 3 (R/10)^4, N = 5 R^2: the wall and cells at each radius and a = 4;
    a particle history on the continuum's R(t) with 1.05 times its mean pressure: no time
    offset, +5 % mean stress; rings 20 apart; a pooled profile of (1 + r/R) times the
    continuum's pressure: the bands' pooled ratios and +0 % at the centre by one estimator.
    """
    colony = measurement("colony_260")
    radii = np.arange(45.0, 240.0, 1.0)
    progress = tmp_path / "progress.log"
    progress.write_text("".join(
        f"colony: radius {r:.2f} of 260, t = 1, {5 * r * r:.0f} particles, step {k + 1}, "
        f"dt 0.001, {3 * (r / 10) ** 4:.0f} s\n" for k, r in enumerate(radii)))
    rows = colony.cost_rows(A.progress_lines(progress), radii=(40.0, 100.0, 200.0, 260.0))
    assert rows[0] == ["40", "", "", ""] and rows[3] == ["260", "", "", ""]
    assert rows[1] == ["100", "30,000", "50,000", "4.00"]  # fitted on R = 45 ... 100
    assert rows[2] == ["200", "480,000", "200,000", "4.00"]
    run = {"sessions": [{"wall_seconds": 3000.0, "cpu_seconds": 2000.0, "peak_memory_mb": 900.0},
                        {"wall_seconds": 600.0, "cpu_seconds": 1600.0, "peak_memory_mb": 1000.0}]}
    assert colony.session_totals(run) == {"sessions": 2, "wall_s": 3600.0, "cpu_s": 3600.0,
                                          "peak_mb": 1000.0}

    from cases.studies.ensemble import mean_stress_ratio
    continuum = A.read_csv(colony.DATA / "continuum_lam=0.001" / "history.csv")
    history = {"t": continuum["t"], "radius": continuum["radius"],
               "mean_stress": np.ones_like(continuum["t"])}
    history["mean_stress"] = 1.05 / mean_stress_ratio(history, colony.LAM)["now"]
    growth = colony.growth_rows(history, continuum, radii=(100.0, 200.0))
    assert [row[3:] for row in growth] == [["+0.00 %", "+5.0 %"]] * 2

    rings = {"radius": np.array([99.0, 150.0, 201.0]), "wavelength": np.array([20.0, np.nan,
                                                                                 21.0])}
    assert colony.ring_rows(rings, radii=(50.0, 100.0, 150.0, 200.0)) == [  # none near 50, 150
        ["100", "99.0", "20.00", f"{A.exact_wavelength(1e-3, 99.0):.2f}"],
        ["200", "201.0", "21.00", f"{A.exact_wavelength(1e-3, 201.0):.2f}"]]

    cprof = A.read_csv(colony.DATA / "continuum_lam=0.001" / "profile.csv")
    factor = 1 + cprof["r"] / 260.0
    profile = {"r": cprof["r"], "stress": factor * cprof["pressure"],
               "count": np.full(cprof["r"].size, 10.0)}
    expected = []
    for lo, hi in colony.BANDS:
        sel = (cprof["r"] >= lo * 260) & (cprof["r"] < hi * 260)
        ratio = np.sum(factor[sel] * cprof["pressure"][sel]) / np.sum(cprof["pressure"][sel])
        assert lo < ratio - 1 < hi
        expected.append(f"{100 * (ratio - 1):+.1f} %")
    assert [row[2] for row in colony.profile_rows(profile, cprof, 260.0)] == expected
    flat = dict(profile, stress=1.1 * cprof["pressure"])
    central = colony.central_stress(flat, cprof, 260.0)
    assert central["particles"] == pytest.approx(1.1 * central["continuum"], rel=1e-12)
    assert central["continuum"] == pytest.approx(cprof["pressure"][0], rel=1e-2)

    record = tmp_path / "record"  # the whole script on a record folder of these pieces
    record.mkdir()
    A.write_csv(record / "history.csv", history | {
        "step": np.arange(history["t"].size), "n_particles": np.full(history["t"].size, 9)})
    A.write_csv(record / "rings.csv", rings)
    A.write_csv(record / "profile_pooled.csv", flat)
    (record / "run.json").write_text(json.dumps(run))
    text = colony.main(["--particles", str(record), "--progress", str(progress)])
    assert "| 200 | 480,000 | 200,000 | 4.00 |" in text and "1.00 CPU h" in text
    assert "continuum" in text and "+10.0 %." in text and "| 0-0.25 |" in text
    capsys.readouterr()


def test_colony_260_record_gives_its_readme_numbers(capsys):
    """The finished radius-260 colony's committed record gives the numbers its README quotes."""
    colony = measurement("colony_260")
    text = colony.main([])
    capsys.readouterr()
    readme = (colony.DATA / "README.md").read_text()
    for row in ("| 260 | 16.728 | 16.622 | +0.63 % | +5.3 % |", "| 0.75-0.9 | 75,115 | +2.4 % |",
                "| 260 | 260.0 | 20.63 | 19.41 |", "| 260 | 52,831 | 298,248 | 3.40 |"):
        assert row in text and row in readme
    assert "15 sessions: 14.78 h wall, 17.04 CPU h, peak 1078 MB" in text
    assert "particles 2610.4 +- 4.2, continuum 2482.6" in text and "+5.1 %." in text


def test_thinning_a_history_aliases_the_division_waves():
    """Every k-th step misses the stress collapse after each wave; a smooth stress does not."""
    from cases.studies import ensemble

    period, steps, t = ensemble.DIVISION_PERIOD, [], 0.0
    while t < 5.0:  # small steps just after each wave, as the engine takes them
        steps.append(t)
        t += 5e-4 if (t % period) < 0.05 else 1e-2
    t = np.array(steps)
    radius = np.exp(t / 2)
    dip = np.exp(-(t % period) / 0.01)  # the stress collapses at each wave and recovers
    history = {"step": np.arange(1, t.size + 1), "t": t, "radius": radius,
               "mean_stress": ensemble.continuum_mean_pressure(radius, 0.0) * (1.08 - 0.8 * dip)}
    whole = ensemble.mean_stress_ratio(history, 0.0)["cycle"][-1]
    bias = records.thinning_bias(history, 0.0)
    assert t.size > 1000 and bias["stride"] == 3
    assert bias["full"] == pytest.approx(whole - 1.0, abs=1e-15)
    assert bias["lowest"] <= bias["thinned"] <= bias["highest"]
    spread = bias["highest"] - bias["lowest"]
    assert spread > 1e-3  # how the rows fall on the waves matters
    smooth = dict(history, mean_stress=1.08 * ensemble.continuum_mean_pressure(radius, 0.0))
    assert abs(records.thinning_bias(smooth, 0.0)["thinned"]) < 1e-2 * spread


def test_make_whole_takes_only_the_same_colonys_history(tmp_path, capsys):
    """A thinned record gets every step of its colony; another colony's is refused."""
    n = np.arange(1, 1201)
    whole = {"step": n, "t": 0.01 * n, "radius": np.sqrt(n), "n_particles": n // 7 + 1.0,
             "mean_stress": np.sin(n) + 2.0, "max_stress": np.cos(n) + 3.0}
    A.write_csv(tmp_path / "whole.csv", whole)
    dest = tmp_path / "lam=0"
    dest.mkdir()
    A.write_csv(dest / "history.csv", A.thin_rows({k: v[:1000] for k, v in whole.items()}))
    thinned = (dest / "history.csv").read_bytes()
    other = dict(whole, mean_stress=whole["mean_stress"] * (1 + 1e-6))
    A.write_csv(tmp_path / "other.csv", other)
    assert records.main(["--make-whole", str(dest), str(tmp_path / "other.csv")]) == 2
    assert "is not the history of" in capsys.readouterr().err
    assert (dest / "history.csv").read_bytes() == thinned  # untouched
    assert records.main(["--make-whole", str(dest), str(tmp_path / "whole.csv")]) == 0
    made = A.read_csv(dest / "history.csv")
    np.testing.assert_array_equal(made["step"], n[:1000])
    A.write_csv(tmp_path / "again.csv", A.thin_rows(made))
    assert (tmp_path / "again.csv").read_bytes() == thinned  # the old record, row for row

    data = Path(records.__file__).resolve().parents[2] / "cases" / "data"
    record = A.read_csv(data / "particles_paper" / "lam=0.001" / "history.csv")
    grown_on = A.read_csv(data / "colony_260" / "particles_lam=0.001" / "history.csv")
    assert np.all(np.diff(record["step"]) == 1) and records.same_colony(record, grown_on)
