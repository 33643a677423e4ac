"""cases.analysis on synthetic data with known answers."""

import math

import numpy as np
import pytest

from cases import analysis as A
from continuum.growth import mean_length


def _uniform_disc(n: int, R: float, rng: np.random.Generator) -> np.ndarray:
    """Draw n points uniform in the disc of radius R (r = R sqrt(U))."""
    r = R * np.sqrt(rng.random(n))
    phi = 2 * np.pi * rng.random(n)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi)])


# ---------------------------------------------------------------- equal-area annuli


def test_annuli_have_equal_area_and_edge_width_rule():
    R = 37.0
    for w in (0.05, 0.3, 1.0, 5.0):
        N = A.annuli_for_edge_width(R, w)
        edges = R * np.sqrt(np.arange(N + 1) / N)
        areas = np.pi * np.diff(edges**2)
        np.testing.assert_allclose(areas, np.pi * R**2 / N, rtol=1e-12)
        assert edges[-1] - edges[-2] <= w
        if N > 1:  # N is the smallest such number
            assert R * (1 - math.sqrt(1 - 1 / (N - 1))) > w
    assert A.annuli_for_edge_width(1.0, 2.0) == 1


def test_equal_area_annuli_counts_means_and_std_exact():
    R, N = 10.0, 7
    # two samples per annulus, placed inside it, with values k and k + 2 (mean k + 1, std 1)
    k = np.repeat(np.arange(N), 2)
    r = R * np.sqrt((k + np.tile([0.25, 0.75], N)) / N)
    v = k + np.tile([0.0, 2.0], N)
    r_mid, mean, std, count = A.equal_area_annuli(r, v, radius=R, n_annuli=N)
    np.testing.assert_array_equal(count, 2)
    np.testing.assert_allclose(mean, np.arange(N) + 1.0)
    np.testing.assert_allclose(std, 1.0)
    # r_mid halves each annulus' area
    edges = R * np.sqrt(np.arange(N + 1) / N)
    np.testing.assert_allclose(r_mid**2, 0.5 * (edges[:-1] ** 2 + edges[1:] ** 2))


def test_equal_area_annuli_weights_edge_sample_and_empty_annulus():
    r = np.array([0.1, 0.1, 1.0, 5.0])  # r = R goes into the last annulus; r > R is ignored
    v = np.array([1.0, 4.0, 7.0, 100.0])
    w = np.array([2.0, 1.0, 1.0, 1.0])
    _, mean, std, count = A.equal_area_annuli(r, v, weights=w, radius=1.0, n_annuli=3)
    assert mean[0] == pytest.approx(2.0)  # (2*1 + 4)/3
    assert std[0] == pytest.approx(math.sqrt((2 * 1 + 4) / 3))
    assert np.isnan(mean[1]) and count[1] == 0
    assert mean[2] == 7.0 and count.tolist() == [2, 0, 1]


def test_uniform_disc_fills_annuli_equally():
    rng = np.random.default_rng(0)
    xy = _uniform_disc(40000, 20.0, rng)
    prof = A.radial_profile(xy, {"one": np.ones(len(xy))}, center=np.zeros(2), radius=20.0,
                            n_annuli=20)
    # multinomial counts: mean 2000, std ~ 44; every annulus within 5 sigma
    assert np.all(np.abs(prof["count"] - 2000) < 5 * math.sqrt(2000))
    assert set(prof) == {"r", "one", "one_std", "count"}
    np.testing.assert_allclose(prof["one"], 1.0)
    np.testing.assert_allclose(prof["one_std"], 0.0, atol=1e-12)


def test_radial_profile_recovers_radial_function_about_offset_centroid():
    rng = np.random.default_rng(1)
    xy = _uniform_disc(200000, 30.0, rng)
    xy += [5.0, -3.0]
    r = np.hypot(xy[:, 0] - 5.0, xy[:, 1] + 3.0)
    prof = A.radial_profile(xy, {"f": r**2}, edge_width=0.5)  # centre = centroid
    # in an annulus, <r^2> = (r_k^2 + r_{k+1}^2)/2 = r_mid^2 exactly for uniform density
    np.testing.assert_allclose(prof["f"], prof["r"] ** 2, rtol=0.02, atol=0.5)


def test_bad_input_errors():
    with pytest.raises(ValueError, match="exactly one"):
        A.equal_area_annuli([1.0], [1.0])
    with pytest.raises(ValueError, match="differ"):
        A.equal_area_annuli([1.0, 2.0], [1.0], n_annuli=2)
    with pytest.raises(ValueError, match="radius"):
        A.annuli_for_edge_width(-1.0, 0.1)
    with pytest.raises(ValueError, match="shape"):
        A.radial_profile(np.zeros((3, 3)), {"a": np.zeros(3)}, n_annuli=2)


# ---------------------------------------------------------------- ring peaks / wavelength


@pytest.mark.parametrize("w", [3.0, 5.0, 12.0])
def test_ring_wavelength_of_noisy_cosine_from_particles(w):
    """Particles uniform in a disc with a radial length wave, binned like the real data.

    Length 1.5 + 0.25 cos(2 pi r / w) + noise(0.15), equal-area annuli: the wavelength is w
    within 3 %, and every peak where the annuli resolve the wave (width <= w/4) is found, none
    spurious.
    """
    rng = np.random.default_rng(int(w * 10))
    R = 60.0
    xy = _uniform_disc(60000, R, rng)
    r = np.hypot(*xy.T)
    length = 1.5 + 0.25 * np.cos(2 * np.pi * r / w) + rng.normal(0, 0.15, r.size)
    prof = A.radial_profile(xy, {"mean_length": length}, center=np.zeros(2), radius=R,
                            edge_width=0.25)
    se = prof["mean_length_std"] / np.sqrt(prof["count"])
    lam_w = A.profile_rings(prof, R).outer_pair
    assert abs(lam_w - w) < 0.03 * w
    peaks = A.ring_peaks(prof["r"], prof["mean_length"], stderr=se)
    N = prof["r"].size
    r_min = R**2 / (2 * N) / (w / 4)  # annulus width ~ R^2 / (2 N r) <= w/4 beyond r_min
    expected = w * np.arange(1, int(R / w) + 1)
    expected = expected[(expected > r_min) & (expected < prof["r"].max() - 0.5)]
    found = peaks[peaks > r_min - 0.25 * w]
    assert found.size == expected.size
    np.testing.assert_allclose(found, expected, atol=0.05 * w)


def test_noise_threshold_uses_standard_errors():
    """A weak wave (amplitude 0.05) under noise 0.03 per sample.

    Without stderr the noise makes spurious peaks; with stderr the 3-sigma prominence rejects
    them and finds the wave.
    """
    rng = np.random.default_rng(5)
    r = np.linspace(0, 40, 800)
    f = 1.5 + 0.05 * np.cos(2 * np.pi * r / 8.0) + rng.normal(0, 0.03, r.size)
    se = np.full(r.size, 0.03)
    peaks = A.ring_peaks(r, f, stderr=se, smoothing=1.0)
    np.testing.assert_allclose(peaks, 8.0 * np.arange(1, 5), atol=0.4)
    assert A.ring_peaks(r, f, smoothing=0.1, min_prominence=0.0).size > 10


def test_ring_peaks_exact_on_smooth_profile_and_parabolic_refinement():
    r = np.linspace(1, 20, 3801)
    f = np.cos(2 * np.pi * (r - 0.3) / 4.0)
    peaks = A.ring_peaks(r, f, smoothing=0.2)
    np.testing.assert_allclose(peaks, 0.3 + 4.0 * np.arange(1, 5), atol=2e-3)


def test_pure_noise_and_short_profiles_give_nan():
    rng = np.random.default_rng(3)
    r = np.linspace(0, 50, 500)
    noise = 1.5 + rng.normal(0, 0.02, r.size)
    se = np.full(r.size, 0.02)
    assert A.ring_peaks(r, noise, stderr=se).size == 0
    rings = A.profile_rings({"r": r, "f": noise, "f_std": se, "count": np.ones(r.size)}, 50.0,
                            name="f", min_count=1)
    assert math.isnan(rings.outer_pair) and rings.reason.startswith("no significant peak")
    short = A.profile_rings({"r": np.array([0.0, 1.0]), "f": np.array([1.0, 2.0])}, 1.0,
                            name="f", noisy=False)
    assert math.isnan(short.outer_pair) and short.reason == "no ring peak"
    one_bump = np.exp(-((r - 25) ** 2) / 4.0)
    assert A.ring_peaks(r, one_bump).size == 1
    rings = A.profile_rings({"r": r, "f": one_bump}, 50.0, name="f", noisy=False)
    assert math.isnan(rings.outer_pair) and rings.reason.startswith("1 ring (r = 25")


def test_ring_coherence_is_standard_normal_on_noise_and_large_on_rings():
    """The z of ring_coherence: mean 0, standard deviation 1 on noise; z >> 3 on rings.

    Over 300 colonies of noise on a radial trend its mean is 0 and its standard deviation 1
    (the normalisation of the docstring); concentric rings under three times their amplitude
    in noise give z >> 3, C near the expected correlation.
    """
    rng = np.random.default_rng(11)
    R = 60.0
    zs = []
    for _ in range(300):
        xy = _uniform_disc(8000, R, rng)
        r = np.hypot(*xy.T)
        zs.append(A.ring_coherence(*xy.T, 1.3 + 0.004 * r + rng.normal(0, 0.2, r.size))[1])
    assert abs(np.mean(zs)) < 0.2 and 0.8 < np.std(zs) < 1.2
    xy = _uniform_disc(40000, R, rng) + [5.0, -3.0]
    r = np.hypot(*(xy - xy.mean(axis=0)).T)
    C, z = A.ring_coherence(*xy.T, 1.5 + 0.1 * np.cos(2 * np.pi * r / 6.0)
                            + rng.normal(0, 0.3, r.size))
    # per annulus and sector ~ 40000 * 2 r / (4 R^2) particles: signal variance 0.005 against
    # noise variance 0.09 / count, so C ~ 0.005 / (0.005 + 0.09 / count) > 0.7 at r > 30;
    # n = 29 annuli of width 1 in [30, 59], P = 6 pairs: z = C sqrt(174) > 9
    assert C > 0.7 and z > 9
    assert all(math.isnan(v) for v in A.ring_coherence(*xy.T, np.full(r.size, 1.149)))
    with pytest.raises(ValueError, match="too small"):
        A.ring_coherence([0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="sectors"):
        A.ring_coherence(*xy.T, r, sectors=1)


def test_ring_peaks_ignores_nan_annuli():
    r = np.linspace(0, 30, 601)
    f = np.cos(2 * np.pi * r / 6.0)
    f[::7] = np.nan
    rings = A.profile_rings({"r": r, "f": f}, 30.0, name="f", noisy=False, smoothing=0.3)
    assert rings.outer_pair == pytest.approx(6.0, abs=0.01)


def test_smooth_profile_is_exact_for_lines_on_nonuniform_samples():
    r = np.sqrt(np.linspace(0, 400, 300))  # equal-area spacing
    grid = np.linspace(1, 19, 50)
    fs, es = A.smooth_profile(r, 2 * r - 1, 0.7, grid, stderr=np.full(r.size, 0.1))
    np.testing.assert_allclose(fs, 2 * grid - 1, atol=1e-9)
    # standard error of a local fit over ~ n_eff samples: 0.1 / sqrt(n_eff), n_eff in (1, 300)
    assert np.all((es > 0.1 / np.sqrt(300)) & (es < 0.1))


# ---------------------------------------------------------------- time series, fits


def test_late_slope_of_exact_line_and_late_window():
    t = np.linspace(0, 10, 101)
    R = np.where(t < 8, np.exp(t / 2), np.exp(4) + 3.0 * (t - 8))
    assert A.late_slope(t, R, fraction=0.2) == pytest.approx(3.0, rel=1e-12)
    assert A.late_slope(t, 2 * t + 1, fraction=1.0) == pytest.approx(2.0, rel=1e-12)
    with pytest.raises(ValueError):
        A.late_slope([1.0], [2.0])


def test_max_value_and_power_law_fit():
    assert A.max_value([1.0, np.nan, 3.0, -np.inf]) == 3.0
    with pytest.raises(ValueError):
        A.max_value([np.nan])
    x = np.logspace(-4, -2, 5)
    a, C = A.power_law_fit(x, 0.7 * x**-0.5)
    assert a == pytest.approx(-0.5, abs=1e-12) and C == pytest.approx(0.7, rel=1e-10)
    with pytest.raises(ValueError):
        A.power_law_fit([1.0, 1.0], [2.0, 3.0])


def test_ecoli_lambda_is_the_papers_estimate():
    # v = 1.3e-2 um/s * 3240 s / 1 um = 42.12; lam = 2 / v^2 = 1.127e-3 (paper: ~1.1e-3)
    lam = A.ecoli_lambda()
    assert lam == pytest.approx(2 / 42.12**2, rel=1e-12)
    assert round(lam, 4) == 1.1e-3
    # consistency: the asymptotic speed sqrt(2/lam) returns the measured one
    assert math.sqrt(2 / lam) * 1.0 / (54 * 60) == pytest.approx(1.3e-2, rel=1e-12)
    with pytest.raises(ValueError):
        A.ecoli_lambda(tau_min=0)


@pytest.mark.parametrize("lam, R", [(1e-2, 150.0), (0.1, 30.0)])
def test_wavelength_of_exact_radial_profile_matches_ring_spacing(lam, R):
    """The 1D radial reference lbar(r): its last two peaks are its last two rings' spacing.

    lbar(r) is a sawtooth dropping from 2 to 1 at each ring; the distance between its last two
    peaks is the spacing of its last two rings within 3 % (smoothing over b = 0.5 moves each
    peak inwards by a fraction of b).
    """
    from continuum import radial

    r = np.linspace(0, R, 6001)
    w = A.profile_rings({"r": r, "f": radial.mean_length_profile(lam, r, radius=R)}, R,
                        name="f", noisy=False).outer_pair
    assert w == pytest.approx(A.exact_wavelength(lam, R), rel=0.03)


def test_csv_round_trip_and_reproducible_gzip(tmp_path):
    """write_csv/read_csv round trip, plain and gzipped; equal data give equal .gz bytes."""
    cols = {"x": np.array([0.0, 1.5, -2.25]), "y": np.array([1e-9, 2.0, 3.0])}
    for name in ("a.csv", "a.csv.gz"):
        back = A.read_csv(A.write_csv(tmp_path / name, cols))
        for k in cols:
            np.testing.assert_array_equal(back[k], cols[k])
    first = (tmp_path / "a.csv.gz").read_bytes()
    import time
    time.sleep(1.1)  # a gzip header time stamp would differ now
    assert A.write_csv(tmp_path / "a.csv.gz", cols).read_bytes() == first
    with pytest.raises(ValueError, match="differ in length"):
        A.write_csv(tmp_path / "b.csv", {"x": np.zeros(2), "y": np.zeros(3)})


def test_read_csv_blank_cells_are_nan(tmp_path):
    """History rows of a run resumed from an older checkpoint leave new columns blank."""
    path = tmp_path / "h.csv"
    path.write_text("step,passes,pass_iterations\n1,2,\n2,0,15\n")
    h = A.read_csv(path)
    np.testing.assert_array_equal(h["step"], [1, 2])
    assert np.isnan(h["pass_iterations"][0]) and h["pass_iterations"][1] == 15
    path.write_text("step,passes\n1,2\n2,0,15\n")
    with pytest.raises(ValueError):
        A.read_csv(path)
    path.write_text("step,passes\n")
    assert A.read_csv(path)["step"].size == 0


def test_markdown_rows():
    """Header, rule and rows of a markdown table, cells converted with str."""
    assert A.markdown_rows(("a", "b"), [(1, "x"), (2.5, "y")]) == (
        "| a | b |\n|---|---|\n| 1 | x |\n| 2.5 | y |")
    assert A.markdown_rows(("a",), []) == "| a |\n|---|"


# ---------------------------------------------------------------- continuum rings from G


def _disc(R: float, h: float):
    from continuum import mesh as M

    bnd = M.resample_polygon(M.circle_polygon(R, 2048), spacing=h, min_points=16)
    return M.triangulate(bnd, h)


def test_field_profile_maps_the_mean_phase():
    """<G> is smooth: 2^frac(<G>/ln 2) keeps the rings at their radii; <lbar> does not."""
    pts, tri = _disc(10.0, 0.25)
    r = np.hypot(*pts.T)
    G = math.log(2) * (0.3 + r / 1.7)  # rings G = k ln 2 at r_k = 1.7 (k - 0.3)
    prof = A.field_profile(pts, tri, {"mean_length": mean_length(G), "G": G},
                           edge_width=0.05)
    assert list(prof)[-2:] == ["mean_length_phase", "count"]
    np.testing.assert_allclose(prof["mean_length_phase"], mean_length(prof["G"]))
    radii, k = A.profile_ring_radii(prof["r"], prof["G"])
    exact = 1.7 * (k - 0.3)
    assert k.tolist() == [1, 2, 3, 4, 5, 6]
    np.testing.assert_allclose(radii, exact, atol=0.01)
    # the annulus mean of the sawtooth lbar is smeared over the annulus straddling each ring
    # (largest value 1.884 here); the mapped mean phase reaches 2 - O(w / 1.7) (1.986)
    assert np.nanmax(prof["mean_length"]) < 1.9
    assert np.nanmax(prof["mean_length_phase"]) > 1.97


def test_continuum_rings_from_rings_csv_or_last_frame(tmp_path):
    from continuum.output import FieldWriter, write_rings
    from continuum.rings import ring_table

    pts, tri = _disc(6.0, 0.3)
    r = np.hypot(*pts.T)
    w = FieldWriter(tmp_path)
    for t in (0.0, 1.0):
        w.write(t, pts, tri, {"G": math.log(2) * (t + r / 1.5), "p": 0 * r})
    G = math.log(2) * (1.0 + r / 1.5)  # rings at r = 1.5 (k - 1), k = 2..5
    from_frame = A.continuum_rings(tmp_path)  # no rings.csv: the last VTU frame
    direct = ring_table(pts, tri, G)
    assert from_frame["k"].tolist() == direct["k"].tolist() == [2, 3, 4, 5]
    np.testing.assert_allclose(from_frame["mean_radius"], direct["mean_radius"], rtol=1e-12)
    write_rings(tmp_path, pts, tri, G)
    from_csv = A.continuum_rings(tmp_path)
    for c in ("k", "mean_radius", "length", "cx"):
        np.testing.assert_allclose(from_csv[c], direct[c], rtol=1e-14, atol=1e-15)
    assert A.continuum_wavelength(tmp_path).outer_pair == pytest.approx(1.5, abs=0.01)
    series = A.continuum_wavelength_series(tmp_path)
    np.testing.assert_array_equal(series["t"], [0.0, 1.0])
    np.testing.assert_allclose(series["wavelength"], 1.5, atol=0.01)


def test_field_profile_of_the_transported_psi_pools_the_cells_of_an_annulus():
    """mean_length_psi, length_std_psi: the mean and spread of all the cells of an annulus.

    One cell per area (N = 1): the annulus mean of the nodal means, and by the law of total
    variance sqrt(s^2 + the annulus variance of the means) (to 2.2e-4 here: Q is interpolated
    linearly, the square of the interpolated mean is not). Twice as many cells outside: the
    mean is weighted by the number (against the generic columns of N m and N).
    """
    pts, tri = _disc(5.0, 0.1)
    r = np.hypot(*pts.T)
    m, sd = 1.0 + r / 5.0, np.full(len(r), 0.1)
    for N in (np.ones(len(r)), 1.0 + r / 5.0):
        prof = A.field_profile(pts, tri, {"number": N, "mean_length_psi": m,
                                          "length_std_psi": sd, "m": m, "Nm": N * m})
        assert list(prof)[-3:] == ["mean_length_psi", "length_std_psi", "count"]
        assert "mean_length_psi_std" not in prof and "L" not in prof
        ok = prof["count"] > 0
        if np.all(N == 1):
            np.testing.assert_allclose(prof["mean_length_psi"][ok], prof["m"][ok], rtol=1e-12)
            np.testing.assert_allclose(prof["length_std_psi"][ok],
                                       np.hypot(0.1, prof["m_std"][ok]), atol=5e-4)
        else:
            np.testing.assert_allclose(prof["mean_length_psi"][ok],
                                       prof["Nm"][ok] / prof["number"][ok], rtol=1e-12)
            assert np.all(prof["mean_length_psi"][ok] > prof["m"][ok])  # weighted outwards


def test_continuum_profile_holds_the_flows_strain_rate(continuum_run):
    """The profile's (profile.csv's) e_rr, e_tt of a disc against the radial closed form.

    The run (lam = 1e-2, radius 2, P1) is a disc, so the annulus means of the recovered strain
    rate follow continuum.strain_rate.radial_strain_rate within the P1 recovery error (a few
    percent of div u = g ~ 1), at every annulus but the outermost two.
    """
    from continuum.strain_rate import radial_strain_rate

    profile = A.final_continuum_profile(continuum_run)
    R = float(A.read_csv(continuum_run / "history.csv")["radius"][-1])
    exact = radial_strain_rate(profile["r"], R, 1e-2)
    inner = slice(0, -2)
    for name in ("e_rr", "e_tt"):
        np.testing.assert_allclose(profile[name][inner], exact[name][inner], atol=0.03)
    np.testing.assert_allclose(profile["e_rr"] + profile["e_tt"], 1.0, atol=0.05)  # div u = g
