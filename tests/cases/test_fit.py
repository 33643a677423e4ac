"""``colony fit`` (cases.fit): lam from a colony's R(t), checked against the radial solution.

Synthetic colonies are the exact radial solution (continuum.radial) at a known lam, sampled in
physical units and given Gaussian noise of known sigma; the fit must recover lam within its
interval, and over many seeded realisations the 95 % interval must cover the truth at a rate
consistent with 95 % (binomial acceptance region). The paper's hand estimate from a late speed
is reproduced, and every kind of bad data is refused end to end with one line and exit 2.
"""

from __future__ import annotations

import csv
import json
import math
import os

import numpy as np
import pytest
from scipy import stats

from cases import cli, fit
from continuum import radial
from tests.measurements import measurement
from tests.pictures import assert_drawn

TAU = 54.0  # minutes: the paper's E. coli growth time
L0 = 2.0  # um: a cell length other than 1, so that the unit conversions are exercised


def synthetic(lam, s_from, s_to, n, sigma, seed, tau=TAU):
    """(t in h, R in um) of the radial solution from R0 at t = 0, noise sigma cell lengths."""
    s = np.linspace(s_from, s_to, n)
    R = radial.radius(s, lam)
    rng = np.random.default_rng(seed)
    y = R + sigma * rng.standard_normal(n)
    return s * tau / 60.0, y * L0


EXACT = {"min_radius": 0.0, "tolerance": 0.0, "noise": "independent"}
"""The fit of the exact model (the radial solution plus independent noise): no rows dropped, no
model discrepancy, independent residuals; the statistics of the interval by itself."""


def fit_h(t, R, **kw):
    return fit.fit_colony(t, R, tau_minutes=TAU, cell_length_um=L0, time_unit="h",
                          **{**EXACT, **kw})


def write_csv(path, header, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return str(path)


# --------------------------------------------------------------------------- the model


def test_warm_newton_radii_equal_the_radial_solution():
    """The fit's Newton from the last radii gives continuum.radial.radius to round-off."""
    s = np.linspace(0.0, 25.0, 40)
    for lam in (0.0, 1e-4, 1e-2, 1.0):
        pb = fit._Problem(s, np.ones_like(s), 1.0, None)
        for R1 in (0.4, 3.0, 50.0, 3.0):
            exact = radial.radius(s, lam, R1)
            np.testing.assert_allclose(pb.radii(s, lam, R1), exact, rtol=1e-13)


def test_jacobian_against_differences():
    s = np.linspace(0.0, 600.0, 12)
    pb = fit._Problem(s, np.linspace(5, 90, 12), 54.0, 5.0)
    x = np.array([math.log(4.0), 0.1])
    _, J = pb.residual_jac(3e-3, x)
    for k in range(2):
        h = np.zeros(2)
        h[k] = 1e-6
        fd = (pb.residual_jac(3e-3, x + h)[0] - pb.residual_jac(3e-3, x - h)[0]) / 2e-6
        np.testing.assert_allclose(J[:, k], fd, rtol=1e-6, atol=1e-8)


# --------------------------------------------------------------------------- recovery


WINDOWS = {1e-4: (9.0, 15.0), 1e-3: (7.0, 16.0), 1e-2: (5.0, 18.0)}


@pytest.mark.parametrize("lam", [1e-4, 1e-3, 1e-2])
@pytest.mark.parametrize("sigma", [0.5, 3.0])
def test_recovers_lam_of_the_radial_solution(lam, sigma):
    """Known lam inside the 99.9 % interval; the 95 % interval is narrow at low noise."""
    t, R = synthetic(lam, *WINDOWS[lam], 20, sigma, seed=int(1e6 * lam) + int(10 * sigma))
    wide = fit_h(t, R, level=0.999)
    assert wide.lo <= lam <= wide.hi
    res = fit_h(t, R)
    assert res.lo < res.lam < res.hi < wide.hi and res.lo > wide.lo
    rel = (res.hi - res.lo) / lam
    assert rel < (0.1 if sigma < 1 else 0.5)
    # noise and time origin (the colony was one cell at t = 0): recovered too
    assert 0.5 < res.sigma / (sigma * L0) < 1.6
    assert abs(res.t0) < 0.2 * TAU / 60.0
    assert res.R1 == pytest.approx(res.fitted[0])


def test_noiseless_data_give_lam_to_many_digits():
    t, R = synthetic(2e-3, 6.0, 15.0, 12, 0.0, seed=0)
    res = fit_h(t, R)
    assert res.lam == pytest.approx(2e-3, rel=1e-4)  # Brent's tolerance: 1e-5 in ln lam
    assert res.hi - res.lo < 1e-4 * 2e-3


@pytest.mark.parametrize("reps", [30, pytest.param(100, marks=pytest.mark.slow)])
def test_coverage_of_the_profile_interval(reps):
    """Over ``reps`` seeded realisations the 95 % interval covers the true lam as 95 % would.

    Acceptance region of Binomial(reps, 0.95), two-sided at 0.999: a correct method fails this
    seeded test with probability below 1e-3 (it is seeded: it passes or fails for good). The
    default suite draws 30 (seeds 1000 to 1029: 28 covered, region 23 to 30, so a coverage
    of 73 % or less fails it); the ``slow`` one measures the rate on 100 (97, region 87 to 100).
    """
    lam = 1e-3
    covered = 0
    for seed in range(reps):
        t, R = synthetic(lam, 6.0, 14.0, 15, 2.0, seed=1000 + seed)
        res = fit_h(t, R)
        covered += res.lo <= lam <= res.hi
    lo, hi = stats.binom.ppf([0.0005, 0.9995], reps, 0.95)
    assert lo <= covered <= hi, covered


def test_boundary_lam_zero_is_covered_conservatively():
    """True lam = 0: the interval reaches 0 at the nominal rate or more (97.5 % expected)."""
    reps, covered = 30, 0
    for seed in range(reps):
        t, R = synthetic(0.0, 6.0, 11.0, 12, 1.0, seed=2000 + seed)
        res = fit_h(t, R)
        assert res.lam >= 0.0 and res.lo >= 0.0
        covered += res.at_boundary
    assert covered >= stats.binom.ppf(0.001, reps, 0.95)


def test_tau_prior_corrects_a_wrong_tau():
    """Data grown with tau = 60 min, tau given as 54: fixed tau biases lam; a prior frees it."""
    s = np.linspace(5.0, 18.0, 25)
    rng = np.random.default_rng(3)
    R = radial.radius(s, 1e-3) + rng.standard_normal(s.size)
    t = s * 60.0
    fixed = fit.fit_colony(t, R, tau_minutes=54.0, cell_length_um=1.0, **EXACT)
    assert not fixed.lo <= 1e-3 <= fixed.hi
    free = fit.fit_colony(t, R, tau_minutes=54.0, cell_length_um=1.0, tau_prior_sd=10.0,
                          **EXACT)
    assert free.lo <= 1e-3 <= free.hi
    assert abs(free.tau_minutes - 60.0) < 3.0
    assert "tau prior" in free.method and free.record()["tau"]["fitted"]


def test_doubling_time_reading():
    """--doubling-time: tau = T / ln 2; data grown with e-folding tau fit with its doubling."""
    t, R = synthetic(1e-3, 7.0, 16.0, 20, 0.5, seed=7)
    a = fit_h(t, R)
    b = fit.fit_colony(t, R, tau_minutes=TAU * math.log(2), cell_length_um=L0, time_unit="h",
                       doubling_time=True, **EXACT)
    assert b.lam == pytest.approx(a.lam, rel=1e-6)
    assert b.tau_minutes == pytest.approx(TAU)


def test_bootstrap_agrees_with_the_profile():
    t, R = synthetic(1e-3, 7.0, 16.0, 10, 1.0, seed=11)
    prof = fit_h(t, R)
    boot = fit_h(t, R, interval="bootstrap", n_boot=24, seed=1)
    assert boot.lam == prof.lam
    assert "bootstrap" in boot.method
    assert 0.3 < (boot.hi - boot.lo) / (prof.hi - prof.lo) < 3.0


# --------------------------------------------------------------------------- from a speed


def test_paper_estimate_from_the_late_speed():
    """The paper's numbers, 54 min, 1 um and 1.3e-2 um/s, give its lam ~ 1.1e-3.

    They do when tau = 54 min is the e-folding time of dl/dt = l/tau (the model's time
    unit): v = 42.1 cell lengths per tau, lam = 2/v^2. Read as a doubling time, lam would be
    5.4e-4.
    """
    est = fit.lam_from_speed(1.3e-2, tau_minutes=54.0, cell_length_um=1.0)
    assert est.speed_model == pytest.approx(1.3e-2 * 54 * 60)
    assert round(est.lam, 4) == 1.1e-3
    assert est.lam == pytest.approx(1.127e-3, rel=1e-3)
    assert est.lam_other_reading == pytest.approx(est.lam * math.log(2) ** 2)
    assert round(est.lam_other_reading, 5) == 5.4e-4


def test_speed_at_a_radius_inverts_the_exact_rate():
    for lam in (1e-4, 1e-3, 1e-1):
        for R in (20.0, 300.0):
            v = radial.radius_rate(R, lam)  # cell lengths per tau, tau = 1 min, l0 = 1 um
            est = fit.lam_from_speed(v / 60.0, tau_minutes=1.0, cell_length_um=1.0, radius_um=R)
            assert est.lam == pytest.approx(lam, rel=1e-9)
    # far out the exact inversion approaches the late-time limit 2 / v^2
    far = fit.lam_from_speed(1.3e-2, tau_minutes=54, cell_length_um=1, radius_um=1e7)
    assert far.lam == pytest.approx(2 / (1.3e-2 * 54 * 60) ** 2, rel=1e-3)


# --------------------------------------------------------------------------- the command


def test_command_writes_fit_json_and_png(tmp_path, capsys):
    t, R = synthetic(1e-3, 7.0, 16.0, 15, 1.0, seed=5)
    data = write_csv(tmp_path / "colony.csv", ["hours", "R_um"], zip(t, R, strict=True))
    out = tmp_path / "fitted"
    status = cli.main(["fit", data, "--tau-minutes", "54", "--cell-length-um", "2",
                       "--time-unit", "h", "--time-column", "hours", "--radius-column", "R_um",
                       "--out", str(out)])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "lam = " in captured.out and "95 % interval" in captured.out
    record = json.loads((out / "fit.json").read_text())
    assert_drawn(out / "fit.png")
    same = fit.fit_file(data, time_column="hours", radius_column="R_um", tau_minutes=54.0,
                        cell_length_um=2.0, time_unit="h")
    assert record["lam"] == same.lam
    assert record["interval"] == [same.lo, same.hi]
    assert record["n_points"] == 15 and record["units"]["time"] == "h"
    assert record["sigma"]["unit"] == "um" and record["time_origin"]["unit"] == "h"
    assert record["method"].startswith("profile likelihood")
    assert record["command"].startswith("colony fit ") and "--time-column hours" in record[
        "command"]
    assert not [p for p in out.iterdir() if p.name not in ("fit.json", "fit.png")]


def test_default_out_folder_and_default_columns(tmp_path, monkeypatch, colony):
    t, R = synthetic(1e-2, 5.0, 15.0, 10, 0.5, seed=2)
    data = write_csv(tmp_path / "growth.csv", ["Time", "Radius"], zip(t * 60, R, strict=True))
    monkeypatch.chdir(tmp_path)
    status, err = colony("fit", data, "--tau-minutes", "54", "--cell-length-um", "2")
    assert status == 0, err
    record = json.loads((tmp_path / "fit-growth" / "fit.json").read_text())
    assert record["columns"] == {"time": "Time", "radius": "Radius"}


def test_speed_command(tmp_path, capsys):
    status = cli.main(["fit", "--speed", "1.3e-2", "--tau-minutes", "54", "--cell-length-um",
                       "1", "--out", str(tmp_path / "speed")])
    out = capsys.readouterr().out
    assert status == 0
    assert out.startswith("lam = 0.00113 ") and "e-folding" in out
    record = json.loads((tmp_path / "speed" / "fit.json").read_text())
    assert record["lam"] == pytest.approx(1.127e-3, rel=1e-3)


def test_outputs_replace_links_never_write_through_them(tmp_path, colony):
    t, R = synthetic(1e-3, 7.0, 16.0, 8, 1.0, seed=9)
    data = write_csv(tmp_path / "c.csv", ["t", "radius"], zip(t * 60, R, strict=True))
    outside = tmp_path / "outside.json"
    outside.write_text("keep")
    out = tmp_path / "out"
    out.mkdir()
    (out / "fit.json").symlink_to(outside)
    status, err = colony("fit", data, "--tau-minutes", "54", "--cell-length-um", "2", "--out",
                         str(out))
    assert status == 0, err
    assert outside.read_text() == "keep"
    assert not (out / "fit.json").is_symlink() and json.loads((out / "fit.json").read_text())
    linked = tmp_path / "linked"
    linked.symlink_to(out)
    status, err = colony("fit", data, "--tau-minutes", "54", "--cell-length-um", "2", "--out",
                         str(linked))
    assert status == 2 and "symbolic link" in err and len(err.splitlines()) == 1


# --------------------------------------------------------------------------- bad data


GOOD = [(60.0 * k, 10.0 + 3.0 * k) for k in range(8)]  # minutes, um: a plausible colony


def _bad_cases():
    """(name, file content (None: no file), argv after the data file, words of the message)."""
    rows = [list(r) for r in GOOD]
    shrink = [r[:] for r in rows]
    shrink[4][1], shrink[6][1] = 5.0, 12.0
    nan = [r[:] for r in rows]
    nan[2][1] = "nan"
    inf = [r[:] for r in rows]
    inf[5][0] = "inf"
    neg = [r[:] for r in rows]
    neg[0][0] = -5.0
    order = [r[:] for r in rows]
    order[3][0] = order[2][0]
    zero = [r[:] for r in rows]
    zero[0][1] = 0.0
    text = [r[:] for r in rows]
    text[3][1] = "12 um"
    hours_as_min = [(k * 2.0, 10 * math.exp(0.5 * k * 2 * 60 / 54)) for k in range(6)]
    return [
        ("decreasing radius", rows_csv(shrink), [], ["decreases", "row(s) 5, 7"]),
        ("too few points", rows_csv(rows[:3]), [], ["too few points", "3 rows"]),
        ("nan", rows_csv(nan), [], ["NaN", "row(s) 3"]),
        ("inf", rows_csv(inf), [], ["time", "NaN or infinite", "row(s) 6"]),
        ("negative time", rows_csv(neg), [], ["negative times", "row(s) 1"]),
        ("times not increasing", rows_csv(order), [], ["times must increase", "row(s) 4"]),
        ("zero radius", rows_csv(zero), [], ["positive", "row(s) 1"]),
        ("text", rows_csv(text), [], ["data row 4", "'12 um'", "not a number"]),
        ("radii in mm read as um", rows_csv([(r[0], r[1] / 1000) for r in rows]), [],
         ["radius unit implausible", "smaller than one cell", "--radius-unit"]),
        ("radii in um read as mm", rows_csv([(r[0], 1e3 * r[1]) for r in rows]),
         ["--radius-unit", "mm"], ["radius unit implausible", "beyond 1e+05"]),
        ("hours read as minutes", rows_csv(hours_as_min), [],
         ["time unit implausible", "--time-unit"]),
        ("missing column", "time,diameter\n0,1\n1,2\n2,3\n3,4\n", [],
         ["no radius column", "its columns are: time, diameter"]),
        ("missing named column", rows_csv(rows), ["--radius-column", "R"],
         ["no column 'R'", "its columns are: t, radius"]),
        ("empty file", "", [], ["is empty"]),
        ("not text", b"\xff\xfe\x00\x81binary", [], ["cannot read", "not a text CSV"]),
        ("missing file", None, [], ["cannot read", "No such file"]),
        ("a folder", "FOLDER", [], ["cannot read"]),
        ("both data and speed", rows_csv(rows), ["--speed", "0.01"], ["not both"]),
        ("bad tau", rows_csv(rows), ["--tau-minutes", "-3"], ["--tau-minutes", "positive"]),
    ]


def rows_csv(rows):
    return "t,radius\n" + "".join(f"{a},{b}\n" for a, b in rows)


@pytest.mark.parametrize("case", range(19))
def test_bad_data_one_line_exit_2(case, tmp_path, colony):
    name, content, extra, words = _bad_cases()[case]
    path = tmp_path / "data.csv"
    if content == "FOLDER":
        path.mkdir()
    elif isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    argv = ["fit", str(path), "--tau-minutes", "54", "--cell-length-um", "1",
            "--out", str(tmp_path / "out"), *extra]
    status, err = colony(*argv)
    assert status == 2, (name, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("colony: error: "), (name, err)
    for word in words:
        assert word in lines[0], (name, word, lines[0])
    assert not (tmp_path / "out").exists(), name


def test_bad_case_count_matches():
    assert len(_bad_cases()) == 19


def test_neither_data_nor_speed(colony):
    status, err = colony("fit", "--tau-minutes", "54", "--cell-length-um", "1")
    assert status == 2 and "give DATA.csv or --speed" in err and len(err.splitlines()) == 1


def test_speed_beyond_the_stress_free_limit(colony):
    status, err = colony("fit", "--speed", "1", "--tau-minutes", "54", "--cell-length-um", "1",
                         "--speed-radius", "100")
    assert status == 2 and "stress-free speed" in err and len(err.splitlines()) == 1


def test_noisy_but_growing_series_is_accepted():
    """Drops within the series' own noise are noise, not a shrinking colony."""
    t, R = synthetic(1e-3, 6.0, 14.0, 30, 2.0, seed=4)  # noise of 2 cell lengths
    assert np.any(np.diff(R) < 0)
    fit.check_series(t, R)
    R[20] = R[19] - 40.0  # a drop of 40 um, 13 % of the range: not noise
    with pytest.raises(ValueError, match=r"decreases in data row\(s\) 21 "):
        fit.check_series(t, R)


def _error_line(err):
    """The one line of stderr, ``colony: error: ...`` (asserted to be the only one)."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("colony: error: "), err
    return lines[0]


def _fit_args(data, tmp_path, *extra):
    return ("fit", str(data), "--tau-minutes", "54", "--cell-length-um", "1", "--out",
            str(tmp_path / "out"), *extra)


def test_no_growth_does_not_identify_lam(tmp_path, colony):
    """A constant radius used to give lam = 1e8 [9e7, None]; data showing no slowing, [0, inf].

    Neither is an estimate: both are refused in one line saying the data do not identify lam.
    """
    flat = tmp_path / "flat.csv"
    flat.write_text(rows_csv([(60.0 * k, 50.0) for k in range(6)]))
    status, err = colony(*_fit_args(flat, tmp_path))
    assert status == 2
    line = _error_line(err)
    assert "do not identify lam" in line and "does not grow" in line
    # GOOD read in seconds: 3-fold in 7 min, near stress-free growth, no slowing to measure
    fast = tmp_path / "fast.csv"
    fast.write_text(rows_csv(GOOD))
    status, err = colony(*_fit_args(fast, tmp_path, "--time-unit", "s"))
    assert status == 2
    line = _error_line(err)
    assert "do not identify lam" in line and "[0, inf]" in line and "--time-unit (s)" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("flag", "value"), [
    ("--tau-minutes", "1e-300"), ("--tau-minutes", "1e300"), ("--tau-minutes", "inf"),
    ("--tau-minutes", "nan"), ("--tau-minutes", "0"), ("--cell-length-um", "1e-300"),
    ("--cell-length-um", "1e300"), ("--tau-prior-sd", "0"), ("--tau-prior-sd", "1e300"),
    ("--speed", "1e-300"), ("--speed", "1e300")])
def test_absurd_numbers_are_refused_before_any_work(flag, value, tmp_path, colony):
    """--tau-minutes 1e-300 used to end in an OverflowError traceback.

    Every numeric option outside its generous physical range is refused in one line naming the
    flag and the range, before the data file is read (here it does not exist).
    """
    base = {"--tau-minutes": "54", "--cell-length-um": "1"}
    base[flag] = value
    argv = ["fit", *[w for item in base.items() for w in item]]
    if flag != "--speed":
        argv.insert(1, str(tmp_path / "missing.csv"))
    status, err = colony(*argv, "--out", str(tmp_path / "out"))
    assert status == 2
    line = _error_line(err)
    low, high, unit, _ = fit.OPTION_RANGES[flag]
    assert f"{flag} must be a positive number in [{low:g}, {high:g}] {unit}" in line, line
    assert not (tmp_path / "out").exists()


def test_bootstrap_count_above_the_cap_is_refused_at_once(tmp_path, colony):
    """--bootstrap 1000000000 used to run on for minutes; above MAX_BOOTSTRAP it is refused."""
    argv = _fit_args(tmp_path / "missing.csv", tmp_path, "--interval", "bootstrap",
                     "--bootstrap", "1000000000")
    status, err = colony(*argv)
    assert status == 2
    line = _error_line(err)
    assert "--bootstrap 1000000000" in line and f"cap of {fit.MAX_BOOTSTRAP:,}" in line
    fit._check_options(54.0, 1.0, "min", "um", None, "bootstrap", fit.MAX_BOOTSTRAP, 0.95)
    with pytest.raises(ValueError, match="above the cap"):
        fit._check_options(54.0, 1.0, "min", "um", None, "bootstrap", fit.MAX_BOOTSTRAP + 1,
                           0.95)


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy overflow warning on stderr
def test_wrong_time_unit_failure_names_the_unit(tmp_path, colony):
    """Minutes read as hours drive the radial solution out of range: the line names the unit."""
    data = tmp_path / "minutes.csv"
    data.write_text(rows_csv(GOOD))
    status, err = colony(*_fit_args(data, tmp_path, "--time-unit", "h"))
    assert status == 2
    line = _error_line(err)
    assert "times in h" in line and "--time-unit" in line, line
    assert not (tmp_path / "out").exists()


def test_ragged_rows_are_refused_with_their_line(tmp_path, colony):
    """A row with another number of fields than the header, named by its line in the file."""
    data = tmp_path / "ragged.csv"
    lines = rows_csv(GOOD).splitlines()
    lines[5] += ",7"  # data row 5
    data.write_text("# a comment\n\n" + "\n".join(lines) + "\n")  # data row 5 is line 8
    status, err = colony(*_fit_args(data, tmp_path))
    assert status == 2
    line = _error_line(err)
    assert "line 8: 3 fields" in line and "header has 2 (t, radius)" in line, line
    assert not (tmp_path / "out").exists()


def test_implausible_colony_is_a_one_line_warning(tmp_path, colony):
    """GOOD in um given as mm: 1-3 cm at 0.8 um/s, far beyond E. coli; exit 0 with a warning."""
    data = tmp_path / "good.csv"
    data.write_text(rows_csv(GOOD))
    status, err = colony(*_fit_args(data, tmp_path, "--radius-unit", "mm"))
    assert status == 0, err
    warned = [w for w in err.splitlines() if "implausible colony" in w]
    assert len(warned) == 1 and warned[0].startswith("colony: warning: "), err
    assert "--radius-unit (now mm)" in warned[0] and "times faster" in warned[0]
    record = json.loads((tmp_path / "out" / "fit.json").read_text())
    assert any("implausible colony" in w for w in record["warnings"])
    # the same numbers in um are a plausible colony: no warning
    status, err = colony(*_fit_args(data, tmp_path / "um"))
    assert status == 0 and "implausible" not in err, err


# --------------------------------------------------------------------------- particle colonies


def test_particle_table_row_reproduces_the_committed_csv(tmp_path):
    """cases/data/fit/particles.csv (docs/measurements/fit_particles.py) holds what it computes."""
    data = os.path.join(os.path.dirname(fit.__file__), "data")
    with open(os.path.join(data, "fit", "particles.csv"), newline="") as fh:
        stored = list(csv.DictReader(fh))
    row = next(r for r in stored if r["lam_true"] == "0.01" and r["column"] == "radius"
               and float(r["min_radius"]) == 0)
    (tmp_path / "lam=0.01").symlink_to(os.path.join(data, "particles_paper", "lam=0.01"))
    module = measurement("fit_particles")
    (new,) = module.particle_table(tmp_path, fits=(("radius", 0.0),))
    assert new["lam_true"] == 0.01 and new["covers"] is True  # the fit of issue 54 covers it
    for key in ("lam_fit", "lo", "hi", "sigma", "t0", "lag1"):  # to the optimisers' tolerances
        assert float(row[key]) == pytest.approx(new[key], rel=1e-4, abs=1e-5), key


# --------------------------------------------------------------------------- issue 54: coverage


def ar1_synthetic(lam, s_from, s_to, n, sigma, rho, seed):
    """(t in min, R in um; l0 = 1 um, tau = 54 min) of the radial solution plus AR(1) noise.

    Noise e_i = rho e_(i-1) + sqrt(1 - rho^2) sigma z_i, stationary from e_1 = sigma z_1.
    """
    s = np.linspace(s_from, s_to, n)
    rng = np.random.default_rng(seed)
    z = rng.standard_normal(n)
    e = np.empty(n)
    e[0] = z[0]
    for i in range(1, n):
        e[i] = rho * e[i - 1] + math.sqrt(1.0 - rho * rho) * z[i]
    return s * TAU, radial.radius(s, lam) + sigma * e


@pytest.mark.parametrize(("reps", "n_independent"), [
    (30, 30), pytest.param(60, 40, marks=pytest.mark.slow)])
def test_ar1_residuals_are_covered_at_the_stated_rate(reps, n_independent):
    """Radial solution plus AR(1) noise (rho = 0.7): the AR(1) interval covers at 95 %.

    ``reps`` seeded realisations (seeds 3000 on, 40 points over 6 to 14 growth times, sigma
    one cell length), the exact model otherwise (no rows dropped, no tau tolerance): covered
    inside the acceptance region of Binomial(reps, 0.95) at 0.999, while the interval of
    independent noise on the first ``n_independent`` covers less than that region's lower end
    (the interval of issue 54).

    The ``slow`` version measures the rate on 60 (55 covered; over seeds 3000 to 3099, 91 of
    100: the maximum-likelihood rho is biased low, 0.59 for 0.7) and the independent interval
    on 40 (25). The default suite draws 30 (AR(1): 28, region 23 to 30; independent: 20), the
    fewest at which the region still tells the two intervals apart (on 20, 19 and 16 of them
    would both pass).
    """
    lam = 1e-3
    ar1 = independent = 0
    for seed in range(reps):
        t, R = ar1_synthetic(lam, 6.0, 14.0, 40, 1.0, 0.7, seed=3000 + seed)
        res = fit.fit_colony(t, R, tau_minutes=TAU, cell_length_um=1.0, min_radius=0.0,
                             tolerance=0.0)
        assert res.noise == "ar1" and 0.0 <= res.rho <= fit.RHO_MAX
        ar1 += res.lo <= lam <= res.hi
        if seed < n_independent:
            old = fit.fit_colony(t, R, tau_minutes=TAU, cell_length_um=1.0, **EXACT)
            independent += old.lo <= lam <= old.hi
    lo, hi = stats.binom.ppf([0.0005, 0.9995], reps, 0.95)
    assert lo <= ar1 <= hi, ar1
    assert independent < stats.binom.ppf(0.0005, n_independent, 0.95), independent


def test_default_interval_is_the_hull_over_the_tau_tolerance():
    """The default interval holds the exact-tau interval and those at tau e^(+-0.1)."""
    t, R = ar1_synthetic(1e-3, 6.0, 14.0, 30, 1.0, 0.5, seed=7)
    kw = {"tau_minutes": TAU, "cell_length_um": 1.0}
    default = fit.fit_colony(t, R, **kw)
    assert default.tolerance == fit.MODEL_TOLERANCE == 0.1
    for factor in (1.0, math.exp(-0.1), math.exp(0.1)):
        one = fit.fit_colony(t, R, tau_minutes=TAU * factor, cell_length_um=1.0, tolerance=0.0)
        assert default.lo <= one.lo and one.hi <= default.hi
    assert default.lam == fit.fit_colony(t, R, **kw, tolerance=0.0).lam
    assert "hull of the intervals" in default.method and "tau +-10 %" in default.summary()


def _particle_history(cut):
    """(t in min, R in um) of the committed lam = 0.01 particle colony up to radius ``cut``."""
    data = os.path.join(os.path.dirname(fit.__file__), "data", "particles_paper", "lam=0.01")
    t, R, _ = fit.read_series(os.path.join(data, "history.csv"), "t", "radius")
    keep = R <= cut
    return t[keep] * TAU, R[keep]


def test_particle_colony_of_radius_25_is_covered():
    """Issue 54: the lam = 0.01 particle colony up to R = 25 excluded the truth; now covered.

    The exact model's interval (every row, tau exact, independent noise) lies far above 0.01;
    the default drops the rows below 10 cell lengths, models the residuals as AR(1) and the
    time scale to +-10 %, and its interval holds 0.01.
    """
    t, R = _particle_history(25.0)
    kw = {"tau_minutes": TAU, "cell_length_um": 1.0}
    old = fit.fit_colony(t, R, **kw, **EXACT)
    assert old.lo > 0.02 and old.lag1 > 0.9 and old.warnings
    new = fit.fit_colony(t, R, **kw)
    assert new.lo <= 0.01 <= new.hi
    assert new.n_dropped > 0 and new.R.min() >= 10.0 and new.rho > 0.5
    record = new.record()
    assert record["min_radius"]["rows_not_fitted"] == new.n_dropped
    assert record["noise"]["model"] == "ar1" and record["tau_tolerance"]["value"] == 0.1
    assert not any("correlated" in w for w in new.warnings)


def test_colony_too_small_to_fit_is_refused_in_one_line(tmp_path, colony):
    """Radii all below 10 cell lengths (a few hundred cells): refused, one line, exit 2."""
    data = tmp_path / "small.csv"
    data.write_text(rows_csv(GOOD))  # 10 to 31 um: 2 to 6 cell lengths of 5 um
    status, err = colony("fit", str(data), "--tau-minutes", "54", "--cell-length-um", "5",
                         "--out", str(tmp_path / "out"))
    assert status == 2
    line = _error_line(err)
    assert "too small a colony to fit" in line and "0 of 8 rows" in line, line
    assert "10 cell lengths (50 um)" in line
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="too small a colony"):
        fit.fit_colony([60.0 * k for k in range(8)], [10.0 + 3.0 * k for k in range(8)],
                       tau_minutes=54.0, cell_length_um=5.0)
    # with min_radius=0 the same rows are fitted
    fit.fit_colony([60.0 * k for k in range(8)], [10.0 + 3.0 * k for k in range(8)],
                   tau_minutes=54.0, cell_length_um=5.0, min_radius=0.0)


@pytest.mark.parametrize(("key", "value", "words"), [
    ("min_radius", -1.0, "min_radius must be"), ("tolerance", 2.0, "tolerance must lie"),
    ("noise", "red", "noise must be")])
def test_model_options_out_of_range_are_refused(key, value, words):
    with pytest.raises(ValueError, match=words):
        fit.fit_colony([0.0, 60.0, 120.0, 180.0], [20.0, 25.0, 30.0, 35.0], tau_minutes=54.0,
                       cell_length_um=1.0, **{key: value})


def test_coverage_table_row_reproduces_the_committed_csv():
    """cases/data/fit_coverage/coverage.csv holds what docs/measurements/fit_coverage.py computes.

    The issue's colony (particles_paper lam = 0.01 up to R = 25), before and after.
    """
    module = measurement("fit_coverage")
    path = os.path.join(os.path.dirname(fit.__file__), "data", "fit_coverage", "coverage.csv")
    with open(path, newline="") as fh:
        stored = [r for r in csv.DictReader(fh) if r["source"] == "paper"
                  and r["lam_true"] == "0.01" and r["seed"] == "0" and float(r["radius"]) < 30]
    t, R = module._history(module.DATA / "particles_paper" / "lam=0.01")
    keep = R <= 25.0
    for name, covered in (("before", "False"), ("after", "True")):
        (row,) = [r for r in stored if r["method"] == name]
        new = module.fit_one(t[keep], R[keep], module.METHODS[name])
        assert row["covered"] == covered
        for key in ("lam_hat", "lo", "hi", "rho"):  # to the optimisers' tolerances
            assert float(row[key]) == pytest.approx(new[key], rel=1e-4, abs=1e-6), (name, key)
