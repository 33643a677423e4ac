"""The stress sensitivity lam of a measured colony, from its radius R(t) (``colony fit``).

A user with a time series of colony radii (time-lapse microscopy) fits the radial solution of
the continuum model (:mod:`continuum.radial`) to it and gets lam with a 95 % interval; or,
from one late radial speed alone, the paper's hand estimate.

Units. The model's units are the birth length l0 (``cell_length_um``) and the growth time tau
of the growth law dl/dt = (l/tau) exp(-lam sigma) (paper, Eq. 1; model.md: "growth time
tau = 1"). tau is therefore the **e-folding time** of a free cell's length, not its doubling
time: a free cell doubles in tau ln 2. ``--tau-minutes`` is read as that e-folding time; with
``--doubling-time`` it is a doubling time and tau = T / ln 2. The particle width is b = l0/2
and the one-cell colony has the radius R0 = sqrt(b/pi) l0 (``continuum.radial.R0``). The
dimensionless lam is the paper's lam' = (tau / (xi l0^2)) lam.

The radial solution. A disc colony of radius R grows at dR/dt = R / (1 + w),
w = sqrt(1 + lam R^2/2), whose exact integral is t(R) = F(R) - F(R_a) + t_a,
F(R) = 2 ln R + w - ln(1 + w) (:func:`continuum.radial.time_to_radius`, inverted by
:func:`continuum.radial.radius`). At late times (lam R^2 >> 1) dR/dt -> sqrt(2/lam): the colony
grows linearly, which is the paper's estimate (:func:`lam_from_speed`). lam = 0 is exponential
growth, R ~ exp(t / 2).

The fit. Data (t_i, y_i), i = 1..n, in the model's units (t_i / tau, y_i / l0). The model is ::

    y_i = R(t_i; lam, R_1) + e_i,    e_i ~ N(0, sigma^2) independent,

with R(t; lam, R_1) the radial solution through R_1 at the first time t_1
(``radius(t - t_1, lam, R0=R_1)``). The unknowns are lam >= 0, R_1 > 0 and sigma; the time
origin t0 (when the model colony was one cell, R = R0) is t0 = t_1 - (F(R_1) - F(R0)) tau.
Optionally tau is an unknown too, with a Gaussian prior of mean T and standard deviation s
(``tau_prior_sd``). Maximum likelihood with sigma profiled out minimises ::

    Q(lam, R_1[, tau]) = n ln RSS + ((tau - T) / s)^2,    sigma^2 = RSS / n.

Interval: profile likelihood. The profile Q_p(lam) minimises Q over the other unknowns at
each lam; the deviance D(lam) = Q_p(lam) - min Q_p; the interval is every lam >= 0 with
D(lam) <= c, c = n ln(1 + q / (n - p)), q the ``level`` quantile of Fisher's F(1, n - p) and
p the number of unknowns in R(t) (2, or 3 with tau): the profile-t interval of nonlinear least
squares (Bates & Watts 1988, ch. 6), exact for a linear model and the chi-square
likelihood-ratio interval (c -> 3.84) for large n. Its ends are found by Brent's root finder
on D in ln lam between points of a logarithmic grid (which also brackets the estimate); an
end that D does not cross up to lam = 1e8 is reported as infinity (the data do not bound lam).

What the radial solution misses of a discrete colony (issue 54; docs/validation.md, "colony
fit: coverage"). Fitted as above to the project's own particle and continuum colonies (lam
1e-4 to 0.1, radius 25 to 260), the 95 % interval held the true lam in none of them; with the
three additions below, all defaults, it holds it in every one:

- Rows of a radius below :data:`MIN_RADIUS` = 10 cell lengths are not fitted (``min_radius``).
  A colony grown from one cell is a line of rods, then a buckled chain that fills in; its
  radius stalls meanwhile (half the radial solution's speed between R = 5 and 10), a stage
  the continuum's disc does not have. Fewer than :data:`MIN_POINTS` rows above it: refused.
- The residuals are continuous-time AR(1) (``noise="ar1"``): division waves make R(t) step
  and the residuals correlate over a division time. Their lag-1 correlation rho is an unknown
  profiled with R_1 (:meth:`_Problem.use_ar1`, the exact Gaussian likelihood), and c has
  n - p - 1 degrees of freedom.
- Model discrepancy in the time scale (``tolerance``, :data:`MODEL_TOLERANCE` = 0.1): a
  discrete colony's edge advances a few per cent slower than the radial solution's at the
  same lam, which a fit with tau fixed reads as a larger lam (by a factor 1.5 to 3 at R = 25,
  where lam shows only in the onset of the bend). The interval is the hull of the intervals
  at tau e^(-0.1), tau and tau e^(+0.1); lam_hat is the one at tau.

``min_radius=0, tolerance=0, noise="independent"`` is the fit of the exact model: its interval
assumes the radial solution plus independent noise, and residuals that are correlated (a
lag-1 autocorrelation beyond 3/sqrt(n), :attr:`ColonyFit.warnings`) mean that R(t) deviates
systematically from the radial solution, and then that interval is too narrow.

The boundary lam = 0 is handled as it is: lam is never negative; when D(0) <= c the interval
is [0, hi] (``at_boundary``: the data do not exclude growth without stress inhibition). There
the likelihood ratio at a true lam = 0 is distributed as (chi2_0 + chi2_1)/2 (Self & Liang
1987), so such an interval covers a true lam = 0 with 97.5 %, not 95 %: conservative, never
too short.

``interval="bootstrap"`` instead: a residual bootstrap (refit to the fitted curve plus
residuals drawn with replacement, scaled by sqrt(n / (n - p)), seeded), the percentile
interval of the refitted lam; slower (one fit per replicate), and at the boundary not to be
trusted (a percentile interval of an estimate held at lam >= 0 can exclude a true lam = 0).
It resamples the residuals as independent (the AR(1) model is the profile interval's); the
rows below ``min_radius`` and the hull over the tau tolerance apply to it as well.

Bad data (:func:`read_series`, :func:`check_series`) is refused with a ValueError of one line
naming the rows or columns: missing columns, an unreadable file, a ragged row (another number
of fields than the header, its file line named), text or NaN/inf, fewer than 4 points,
negative or non-increasing times, radii that are not positive or that decrease beyond noise
(5 % of their range, or less for a smooth series), a radius that does not grow (the data do not
identify lam), radii implausible for the cell length (smaller than one cell, or beyond 1e5 cell
lengths) and growth faster than the stress-free limit allows (time unit or tau wrong). Before
any of it, options out of their physical range (:data:`OPTION_RANGES`: tau in [1e-3, 1e6] min,
the cell length in [1e-2, 1e4] um, ...) and more than :data:`MAX_BOOTSTRAP` replicates are
refused. A fit whose best lam is the largest searched, or whose interval is [0, inf], is
refused too (:func:`_check_identified`: no estimate), and a numerical failure of the fit is
reported in one line naming the time and radius units (:func:`_fit_failure`). A colony far from
what E. coli colonies do (mean radial speed over its radii 30 times off, or beyond 1 cm:
:func:`_implausible_colony`) gives a warning naming --time-unit and --radius-unit.

Outputs (:func:`write_fit`): ``fit.json`` and ``fit.png`` in the output folder, each written
to a temporary file in that folder and renamed over its namesake (``os.replace``: a link
there is replaced, never followed; a folder that is a link is refused).
"""

from __future__ import annotations

import csv
import json
import math
import numbers
import os
import shlex
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, stats

from cases.analysis.statistics import ecoli_lambda
from cases.rundir import check_output, replace_file
from continuum import radial

__all__ = [
    "TIME_UNITS",
    "RADIUS_UNITS",
    "MIN_POINTS",
    "ColonyFit",
    "SpeedEstimate",
    "read_series",
    "check_series",
    "radius_curve",
    "fit_colony",
    "fit_file",
    "lam_from_speed",
    "write_fit",
    "plot_fit",
]

TIME_UNITS = {"s": 1.0 / 60.0, "min": 1.0, "h": 60.0}
"""Minutes per time unit of the data (``--time-unit``)."""

RADIUS_UNITS = {"um": 1.0, "mm": 1000.0}
"""Micrometres per radius unit of the data (``--radius-unit``)."""

MIN_POINTS = 4
"""Fewest data points a fit accepts (two unknowns in R(t), sigma, and one degree of freedom)."""

MAX_CELL_LENGTHS = 1e5
"""Largest plausible colony radius in cell lengths (10 cm for l0 = 1 um)."""

LAM_MAX = 1e8
"""Largest lam searched; an interval end beyond it is infinite (the data do not bound lam)."""

NOISE_FACTOR = 5.0
DROP_SHARE = 0.05
"""A drop of the radius between two rows is an error beyond the smaller of
NOISE_FACTOR sqrt(2) sigma_noise and DROP_SHARE (R_max - R_min)."""

MIN_GROWTH = 1e-6
"""A series whose last radius exceeds its first by no more than the drop tolerance, or by no
more than MIN_GROWTH of the largest radius, does not grow (:func:`_check_growth`)."""

OPTION_RANGES = {
    "--tau-minutes": (1e-3, 1e6, "min", "a growth time from 0.06 s to 2 years"),
    "--tau-prior-sd": (1e-3, 1e6, "min", "a spread of the growth time from 0.06 s to 2 years"),
    "--cell-length-um": (1e-2, 1e4, "um", "a cell from 10 nm to 1 cm long"),
    "--speed": (1e-6, 1e3, "um/s", "from 0.1 um a day to 1 mm/s"),
}
"""Accepted range of each numeric option (:func:`_check_option`): physically generous; beyond
it the number is a typo or a unit slip, and the arithmetic would overflow or take forever."""

MAX_BOOTSTRAP = 10_000
"""Most bootstrap replicates (``--bootstrap``): each is a full refit (about 0.03 s for 20
points), so 10,000 take minutes; 1,000-2,000 already give a stable 95 % percentile interval."""

ECOLI_LAM = ecoli_lambda()
"""The paper's E. coli lam, 2 / v^2 = 1.13e-3 (cases.analysis.ecoli_lambda: tau = 54 min,
l0 = 1 um, late speed 1.3e-2 um/s)."""

SPEED_FACTOR = 30.0
"""A colony growing over its radii more than SPEED_FACTOR times faster or slower than one of
lam = ECOLI_LAM (with the given tau and cell length) is implausible (a warning): lam within
about a factor 1000 of E. coli's (the paper's 1e-4 to 0.1 with margin) stays inside."""

ECOLI_MAX_RADIUS_UM = 1e4
"""Largest plausible E. coli colony radius (1 cm, a warning beyond): at the paper's late speed
of 1.3e-2 um/s a colony needs 9 days to reach it."""

MIN_RADIUS = 10.0
"""Smallest radius fitted, in cell lengths (``min_radius``). A colony grown from one cell is a
line of rods, then a buckled chain that fills in; its radius (the farthest cell) stalls while
it does. The particle colonies of this project advance at 0.50 to 0.71 times the radial
solution's speed between R = 5 and 10 cell lengths, 0.65 to 0.92 between 10 and 15, and within
about 10 % of it beyond (cases/data/fit_coverage/speeds.csv; docs/validation.md, "colony fit:
coverage"): below 10 cell lengths (about 400 cells) the colony is not the continuum's disc."""

MODEL_TOLERANCE = 0.1
"""Model discrepancy (``tolerance``): the interval is the hull of the intervals at the growth
times tau e^(-0.1), tau and tau e^(+0.1). The radial solution describes a discrete colony's R(t)
only up to its time scale: the particle colonies' edges advance at 0.87 to 1.06 times the radial
solution's speed at the same lam over R = 15 to 150 (one band, R = 25 to 30, 0.76 to 1.17:
a division wave; cases/data/fit_coverage/speeds.csv), and a colony's growth time is itself
rarely known better than 10 %."""

PSI_START = 6.0
"""A warm start of the AR(1) unknown psi is clipped to [-6, 6] (rho from 0.0025 to 0.9875):
beyond, rho's derivative vanishes and Levenberg-Marquardt would not move it."""

RHO_MAX = 0.99
"""Largest lag-1 autocorrelation of the AR(1) residual model (``noise="ar1"``): a numerical
guard (the likelihood stays bounded as rho -> 1), rho = RHO_MAX / (1 + e^(-psi))."""

TIME_COLUMNS = ("t", "time")
RADIUS_COLUMNS = ("radius", "r")


# --------------------------------------------------------------------------- data


def read_series(
    path: str | os.PathLike, time_column: str | None = None, radius_column: str | None = None
) -> tuple[NDArray, NDArray, tuple[str, str]]:
    """Times and radii from a CSV file with a header row.

    Lines starting with ``#`` and empty lines are skipped. The default columns are the first of
    ``t``, ``time`` and of ``radius``, ``r`` (in any case).

    Returns
    -------
    t, R : ndarray
        The two columns, in file order (data row k is index k - 1).
    columns : tuple of str
        The names of the two columns used.

    Raises
    ------
    ValueError
        One line: the file cannot be read, a column is missing (the columns found are named),
        a row has another number of fields than the header (its line named,
        :func:`_check_ragged`), or a cell is not a number (its row and column named).
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            lines = [(reader.line_num, r) for r in reader if r and any(c.strip() for c in r)
                     and not r[0].lstrip().startswith("#")]
    except OSError as err:
        raise ValueError(f"cannot read {path}: {err.strerror or err}") from None
    except (UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f"cannot read {path}: not a text CSV file ({err})") from None
    if not lines:
        raise ValueError(f"{path} is empty: expected a header row and at least {MIN_POINTS} "
                         "rows of times and radii")
    _check_ragged(path, lines)
    rows = [r for _, r in lines]
    header = [c.strip() for c in rows[0]]
    found = ", ".join(header)

    def column(given: str | None, defaults: tuple[str, ...], what: str, flag: str) -> int:
        if given is not None:
            if given not in header:
                raise ValueError(f"{path} has no column {given!r} ({flag}); its columns are: "
                                 f"{found}")
            return header.index(given)
        lower = [h.lower() for h in header]
        for name in defaults:
            if name in lower:
                return lower.index(name)
        raise ValueError(f"{path} has no {what} column ({' or '.join(defaults)}; name it with "
                         f"{flag}); its columns are: {found}")

    it = column(time_column, TIME_COLUMNS, "time", "--time-column")
    ir = column(radius_column, RADIUS_COLUMNS, "radius", "--radius-column")
    if it == ir:
        raise ValueError(f"the time and the radius column are the same ({header[it]!r})")
    values = np.empty((len(rows) - 1, 2))
    for k, row in enumerate(rows[1:], start=1):
        for j, (col, name) in enumerate(((it, "time"), (ir, "radius"))):
            text = row[col].strip() if col < len(row) else ""
            try:
                values[k - 1, j] = float(text)
            except ValueError:
                raise ValueError(f"{path}, data row {k}: {name} {text!r} (column "
                                 f"{header[col]!r}) is not a number") from None
    return values[:, 0], values[:, 1], (header[it], header[ir])


def _check_ragged(path: Path, lines: list[tuple[int, list[str]]]) -> None:
    """Refuse a row with another number of fields than the header (its file line named).

    ``lines`` are (line number in the file, fields) of the header and the data rows. A ragged
    row means a shifted or half-written line: its values would be read from the wrong columns.
    """
    (_, header), *data = lines
    for number, row in data:
        if len(row) != len(header):
            raise ValueError(
                f"{path}, line {number}: {len(row)} field{'s' * (len(row) != 1)}, but the header "
                f"has {len(header)} ({', '.join(c.strip() for c in header)}); every row needs "
                "one value per column")


def _rows(index: NDArray, limit: int = 6) -> str:
    """Data rows (1-based) of the indices, at most ``limit`` named."""
    rows = [str(i + 1) for i in np.asarray(index).ravel()]
    more = f" and {len(rows) - limit} more" if len(rows) > limit else ""
    return ", ".join(rows[:limit]) + more


def _noise_scale(t: NDArray, R: NDArray) -> float:
    """Robust noise level of a series: each interior radius against its neighbours' chord.

    e_i = R_i - (a R_{i-1} + b R_{i+1}), a + b = 1 the linear interpolation weights, has the
    variance sigma^2 (1 + a^2 + b^2) for independent noise; sigma = 1.4826 times the median
    of abs(e) / sqrt(1 + a^2 + b^2).
    A curved but smooth series gives a larger value (conservative for the drop test).
    """
    if t.size < 3:
        return 0.0
    b = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
    a = 1.0 - b
    e = R[1:-1] - (a * R[:-2] + b * R[2:])
    return float(1.4826 * np.median(np.abs(e) / np.sqrt(1.0 + a * a + b * b)))


def check_series(t: ArrayLike, R: ArrayLike, radius_unit: str = "um") -> None:
    """Refuse a series a growing colony cannot have made (ValueError, one line).

    In order: NaN or infinite values, fewer than :data:`MIN_POINTS` rows, negative times, times
    that do not increase, radii that are not positive, radii that decrease by more than
    noise: a drop R_{i-1} - R_i between two rows beyond both 5 sqrt(2) sigma_noise
    (sigma_noise the robust scatter about the neighbours' chord, :func:`_noise_scale`) and
    5 % of the range R_max - R_min (exact data may not decrease at all; one or two outliers
    in a short series inflate sigma_noise, not the range), and a radius that does not grow
    (:func:`_check_growth`). Rows are data rows counted from 1 below the header.
    """
    t = np.asarray(t, dtype=float)
    R = np.asarray(R, dtype=float)
    for name, v in (("time", t), ("radius", R)):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ValueError(f"{name} is NaN or infinite in data row(s) {_rows(bad)}")
    if t.size < MIN_POINTS:
        raise ValueError(f"too few points: {t.size} rows, a fit needs at least {MIN_POINTS}")
    bad = np.flatnonzero(t < 0)
    if bad.size:
        raise ValueError(f"negative times in data row(s) {_rows(bad)} (the first: "
                         f"{t[bad[0]]:g}); times count from the start of the recording")
    bad = np.flatnonzero(np.diff(t) <= 0) + 1
    if bad.size:
        raise ValueError(f"times must increase: data row(s) {_rows(bad)} not after the row "
                         f"before (row {bad[0] + 1}: {t[bad[0]]:g} after {t[bad[0] - 1]:g})")
    bad = np.flatnonzero(R <= 0)
    if bad.size:
        raise ValueError(f"radii must be positive: data row(s) {_rows(bad)} (the first: "
                         f"{R[bad[0]]:g})")
    tol = min(NOISE_FACTOR * math.sqrt(2.0) * _noise_scale(t, R),
              DROP_SHARE * float(R.max() - R.min()))
    bad = np.flatnonzero(np.diff(R) < -tol) + 1
    if bad.size:
        i = bad[0]
        raise ValueError(
            f"the radius decreases in data row(s) {_rows(bad)} (row {i + 1}: {R[i]:g} after "
            f"{R[i - 1]:g} {radius_unit}), beyond noise ({tol:.3g} {radius_unit}): a growing "
            "colony's radius does not shrink; check the rows and the columns")
    _check_growth(R, tol, radius_unit)


def _check_growth(R: NDArray, tol: float, radius_unit: str) -> None:
    """Refuse a radius that does not grow: the data then do not identify lam.

    The last radius must exceed the first by more than ``tol`` (the noise tolerance of the drop
    test in :func:`check_series`) and by more than :data:`MIN_GROWTH` of the largest radius
    (round-off). lam is read from how growth slows; without growth the best fit runs to the
    largest lam searched, which is no estimate.
    """
    growth = float(R[-1] - R[0])
    if growth <= max(tol, MIN_GROWTH * float(R.max())):
        raise ValueError(
            f"the data do not identify lam: the radius does not grow ({R[0]:g} {radius_unit} in "
            f"data row 1, {R[-1]:g} in data row {R.size}, within noise {tol:.3g} {radius_unit}); "
            "lam is read from how a growing colony slows (no growth, or no slowing: no lam)")


def _check_units(s: NDArray, y: NDArray, cell_length_um: float, radius_unit: str,
                 time_unit: str) -> None:
    """Radii and times plausible for the cell length and tau (model units s, y)."""
    per_um = RADIUS_UNITS[radius_unit] / cell_length_um  # cell lengths per radius unit
    if y.min() < 0.5 * radial.R0:
        raise ValueError(
            f"radius unit implausible: the smallest radius, {y.min() / per_um:g} {radius_unit}, "
            f"is {y.min():.3g} cell lengths of {cell_length_um:g} um, smaller than one cell "
            f"(R0 = {radial.R0:.3f} cell lengths); are the radii in another unit "
            "(--radius-unit um|mm) or is --cell-length-um right?")
    if y.max() > MAX_CELL_LENGTHS:
        raise ValueError(
            f"radius unit implausible: the largest radius, {y.max() / per_um:g} {radius_unit}, "
            f"is {y.max():.3g} cell lengths of {cell_length_um:g} um, beyond "
            f"{MAX_CELL_LENGTHS:.0e}; are the radii in another unit (--radius-unit um|mm) or is "
            "--cell-length-um right?")
    span = s[-1] - s[0]
    if math.log(y[-1] / y[0]) > math.log(4.0) + span / 2.0:  # in logs: no overflow
        raise ValueError(
            f"time unit implausible: the radius grows {y[-1] / y[0]:.3g}-fold in {span:.3g} "
            f"growth times, faster than stress-free growth allows (R ~ exp(t / (2 tau)), "
            f"{math.exp(span / 2.0):.3g}-fold); is --time-unit ({time_unit}) or --tau-minutes "
            "right?")


def _implausible_colony(t: NDArray, R: NDArray, time_unit: str, radius_unit: str,
                        tau_minutes: float, cell_length_um: float) -> str | None:
    """One line when the implied colony is far from what E. coli colonies do, else None.

    Two checks, from the paper's E. coli numbers (:data:`ECOLI_LAM`, :data:`SPEED_FACTOR`,
    :data:`ECOLI_MAX_RADIUS_UM`): the time the data take to grow from their first to their last
    radius against the time a colony of lam = ECOLI_LAM (the given tau and cell length) takes
    between the same radii (its mean radial speed, more than 30 times slower or faster), and the
    largest radius beyond 1 cm. Either points to a wrong --time-unit or --radius-unit, which
    the line names with their values.
    """
    to_um = RADIUS_UNITS[radius_unit]
    y_first, y_last = R[0] * to_um / cell_length_um, R[-1] * to_um / cell_length_um
    data_min = float(t[-1] - t[0]) * TIME_UNITS[time_unit]
    reasons = []
    grows = 0 < y_first < y_last and data_min > 0  # else check_series refused it (check=False)
    ecoli_min = (float(radial.time_to_radius(y_last, ECOLI_LAM, y_first)) * tau_minutes
                 if grows else math.nan)
    speed = (R[-1] - R[0]) * to_um / (data_min * 60.0) if grows else math.nan
    if grows and not 1.0 / SPEED_FACTOR <= data_min / ecoli_min <= SPEED_FACTOR:
        ratio = data_min / ecoli_min
        how = f"{ratio:.3g} times slower" if ratio > 1 else f"{1 / ratio:.3g} times faster"
        reasons.append(
            f"its mean radial speed, {speed:.3g} um/s, is {how} than an E. coli colony's over "
            f"these radii (lam = {ECOLI_LAM:.3g}, tau = {tau_minutes:g} min: "
            f"{ecoli_min:.3g} min from {R[0]:g} to {R[-1]:g} {radius_unit}, the data take "
            f"{data_min:.3g} min)")
    if R.max() * to_um > ECOLI_MAX_RADIUS_UM:
        reasons.append(f"its largest radius, {R.max() * to_um:g} um, is beyond the "
                       f"{ECOLI_MAX_RADIUS_UM:g} um an E. coli colony reaches in 9 days")
    if not reasons:
        return None
    return (f"implausible colony: {'; '.join(reasons)}; check --time-unit (now {time_unit}) and "
            f"--radius-unit (now {radius_unit})")


# --------------------------------------------------------------------------- model


def radius_curve(s: ArrayLike, lam: float, R1: float) -> NDArray:
    """Radial solution R(s) through R(0) = R1, s >= 0 in growth times (model units).

    :func:`continuum.radial.radius` with ``R0 = R1``: F(R) = F(R1) + s,
    F(R) = 2 ln R + w - ln(1 + w), w = sqrt(1 + lam R^2 / 2).
    """
    return np.asarray(radial.radius(np.asarray(s, dtype=float), float(lam), float(R1)))


class _Problem:
    """Q(lam, phi, theta) = n ln RSS + prior of one data set (model units).

    phi = ln R_1 (radius at the first time), theta = ln(tau / T) (0 unless tau is free).
    Derivatives of R at time s (from F(R) - F(R_1) = s, dF/dR = (1 + w)/R):
    dR/dphi = R (1 + w_1)/(1 + w) and, s = (t - t_1)/tau, dR/dtheta = -s R/(1 + w).
    """

    def __init__(self, dt_min: NDArray, y: NDArray, tau_min: float, prior_sd: float | None):
        self.dt = dt_min  # minutes since the first data time
        self.y = y  # radii in cell lengths
        self.T = tau_min
        self.sd = prior_sd
        self.free_tau = prior_sd is not None
        self.n = y.size
        self.p = 3 if self.free_tau else 2
        self.floor = self.n * (1e-13 * float(np.max(np.abs(y)))) ** 2
        self._last: NDArray | None = None  # radii of the last evaluation: Newton's start
        self._cache: tuple | None = None
        self.ar1 = False  # AR(1) residuals, their correlation an unknown (:meth:`use_ar1`)
        self.k: NDArray | None = None

    def use_ar1(self) -> None:
        """From now on the residuals are continuous-time AR(1), their correlation profiled.

        The last unknown becomes psi, rho = RHO_MAX / (1 + e^(-psi)) the lag-1 correlation at
        the median time step; rows i - 1 and i correlate as a_i = rho^(dt_i / median dt)
        (Ornstein-Uhlenbeck). With the whitened residuals u (Prais-Winsten: e_1, then
        (e_i - a_i e_(i-1)) / sqrt(1 - a_i^2), independent with the variance of e), -2 ln L
        with sigma profiled is n ln sum u^2 + sum ln(1 - a_i^2) = n ln sum v^2,
        v = u prod(1 - a_i^2)^(1/(2n)): still a sum of squares, which Levenberg-Marquardt
        minimises over (phi[, theta], psi).
        """
        steps = np.diff(self.dt)
        self.k = steps / float(np.median(steps))
        self.ar1 = True
        self._cache = None

    @property
    def n_active(self) -> int:
        """Number of unknowns besides lam: phi[, theta][, psi]."""
        return 1 + int(self.free_tau) + int(self.ar1)

    def _scaled(self, e: NDArray, psi: float) -> NDArray:
        rho = RHO_MAX / (1.0 + math.exp(-psi))
        a = rho ** self.k
        s = np.sqrt(1.0 - a * a)
        u = np.concatenate((e[:1], (e[1:] - a * e[:-1]) / s))
        return u * math.exp(float(np.sum(np.log(s))) / self.n)

    def curve(self, lam: float, phi: float, theta: float, dt: NDArray | None = None) -> NDArray:
        s = (self.dt if dt is None else dt) / (self.T * math.exp(theta))
        return radius_curve(s, lam, math.exp(phi))

    def radii(self, s: NDArray, lam: float, R1: float) -> NDArray:
        """R(s; lam, R1) at the data times, by Newton from the last radii.

        Solves t(R) = F(R) - F(R1) = s (:func:`continuum.radial.time_to_radius`) in x = ln R,
        dt/dx = 1 + w = R / (dR/dt) (:func:`continuum.radial.radius_rate`); F is convex in x,
        so Newton converges from any start (quadratically, in 2-4 steps from a near one).
        Without a start, or should it not converge in 30 steps, :func:`radius_curve`.
        """
        if self._last is None:
            R = radius_curve(s, lam, R1)
        else:
            x = np.log(self._last)
            for _ in range(30):
                R = np.exp(x)
                dx = (radial.time_to_radius(R, lam, R1) - s) * radial.radius_rate(R, lam) / R
                x = x - dx
                if np.all(np.abs(dx) <= 1e-14 * np.maximum(1.0, np.abs(x))):
                    R = np.exp(x)
                    break
            else:  # pragma: no cover - Newton on a convex function from a finite start
                R = radius_curve(s, lam, R1)
        self._last = R
        return R

    def residual_jac(self, lam: float, x: NDArray) -> tuple[NDArray, NDArray]:
        """Residuals and their Jacobian in (phi[, theta][, psi]) at fixed lam.

        With AR(1) residuals (:meth:`use_ar1`) the scaled whitened residuals v, their psi
        column by central differences.
        """
        key = (lam, *x)
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        phi, theta = x[0], (x[1] if self.free_tau else 0.0)
        s = self.dt / (self.T * math.exp(theta))
        R1 = math.exp(phi)
        R = self.radii(s, lam, R1)
        w = np.sqrt(1.0 + 0.5 * lam * R * R)
        w1 = math.sqrt(1.0 + 0.5 * lam * R1 * R1)
        cols = [R * (1.0 + w1) / (1.0 + w)]
        if self.free_tau:
            cols.append(-s * R / (1.0 + w))
        e, J = R - self.y, np.column_stack(cols)
        if self.ar1:
            psi, h = x[-1], 1e-6
            v = self._scaled(e, psi)
            Jv = np.column_stack([self._scaled(c, psi) for c in J.T])  # v is linear in e
            dpsi = (self._scaled(e, psi + h) - self._scaled(e, psi - h)) / (2.0 * h)
            e, J = v, np.column_stack((Jv, dpsi))
        out = (e, J)
        self._cache = (key, out)
        return out

    def prior(self, theta: float) -> float:
        return 0.0 if not self.free_tau else ((self.T * (math.exp(theta) - 1.0)) / self.sd) ** 2

    def q(self, lam: float, x: NDArray) -> float:
        r, _ = self.residual_jac(lam, x)
        return self.n * math.log(max(float(r @ r), self.floor)) + self.prior(
            x[1] if self.free_tau else 0.0)

    def profile(self, lam: float, x0: NDArray) -> tuple[float, NDArray]:
        """(Q_p(lam), the minimising (phi[, theta])) from the start x0."""
        x0 = np.asarray(x0, dtype=float)[: self.n_active]
        sol = optimize.least_squares(
            lambda x: self.residual_jac(lam, x)[0], x0,
            jac=lambda x: self.residual_jac(lam, x)[1], method="lm", xtol=1e-10, ftol=1e-12,
            gtol=1e-10)
        x = sol.x
        if self.free_tau:  # least squares without the prior is the start; then Q itself

            def fun(z):
                r, J = self.residual_jac(lam, z)
                rss = max(float(r @ r), self.floor)
                g = self.n * 2.0 * (J.T @ r) / rss
                e = math.exp(z[1])
                g[1] += 2.0 * self.T * (self.T * (e - 1.0)) / self.sd ** 2 * e
                return self.n * math.log(rss) + self.prior(z[1]), g

            best = min((x0, x), key=lambda z: self.q(lam, z))
            res = optimize.minimize(fun, best, jac=True, method="BFGS",
                                    options={"gtol": 1e-10, "maxiter": 500})
            x = res.x if res.fun <= self.q(lam, best) else best
        return self.q(lam, x), x


# --------------------------------------------------------------------------- results


@dataclass
class ColonyFit:
    """The stress sensitivity lam fitted to a colony's R(t), with its interval (data units).

    Attributes
    ----------
    lam, lo, hi : float
        Maximum-likelihood lam and its interval [lo, hi] (hi may be inf: not bounded).
    level : float
        Confidence level of the interval.
    method : str
        How the interval was found (profile likelihood or bootstrap), in words.
    at_boundary : bool
        lo = 0: the data are consistent with lam = 0.
    t0 : float
        Time origin: when the fitted colony had the radius of one cell, R0 l0 (time unit).
    R1 : float
        Fitted radius at the first data time (radius unit).
    sigma : float
        Maximum-likelihood noise sigma = sqrt(RSS / n) (radius unit).
    tau_minutes : float
        Growth (e-folding) time used, fitted when ``tau_prior_sd`` was given.
    noise, rho : str, float
        Residual model ("ar1" or "independent") and the AR(1) lag-1 correlation used (0: none).
    tolerance : float
        Model discrepancy in the time scale: the interval is the hull over tau e^(+-tolerance).
    lo_at_tau, hi_at_tau : float
        The interval at tau itself, where the profile deviance D(lam) crosses ``threshold``
        (equal to lo, hi when ``tolerance`` is 0).
    min_radius, n_dropped : float, int
        Smallest radius fitted (cell lengths) and the number of rows below it, not fitted
        (``t``, ``R`` and ``fitted`` hold the fitted rows only).
    """

    lam: float
    lo: float
    hi: float
    level: float
    method: str
    at_boundary: bool
    t0: float
    R1: float
    sigma: float
    tau_minutes: float
    tau_given_minutes: float
    tau_prior_sd: float | None
    doubling_time: bool
    cell_length_um: float
    time_unit: str
    radius_unit: str
    t: NDArray = field(repr=False)
    R: NDArray = field(repr=False)
    fitted: NDArray = field(repr=False)
    threshold: float = field(repr=False)
    q_min: float = field(repr=False)
    noise: str = "independent"
    rho: float = 0.0
    tolerance: float = 0.0
    lo_at_tau: float = math.nan
    hi_at_tau: float = math.nan
    min_radius: float = 0.0
    n_dropped: int = 0
    columns: tuple[str, str] = ("t", "radius")
    source: str = ""
    _prof: _Profile | None = field(default=None, repr=False, compare=False)

    def _curve(self, lam: float, t: NDArray) -> NDArray:
        """Profiled R(t) at this lam (data units), at times t >= the first data time."""
        pb = self._prof.pb
        x = self._prof.x(lam)
        dt = (np.asarray(t, dtype=float) - self.t[0]) * TIME_UNITS[self.time_unit]
        curve = pb.curve(lam, x[0], x[1] if pb.free_tau else 0.0, dt)
        return curve * self.cell_length_um / RADIUS_UNITS[self.radius_unit]

    def band(self, n: int = 200) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """(t, best curve, band low, band high) in data units.

        The band is the envelope of the profiled curves R(t) of 11 lam spread over the interval
        (geometrically; an infinite end: up to 1e3 lam_hat): the curves the data do not exclude.
        """
        tt = np.linspace(self.t[0], self.t[-1], n)
        top = self.hi if math.isfinite(self.hi) else max(self.lam, 1e-12) * 1e3
        bottom = max(self.lo, top * 1e-4)
        lams = [self.lam, self.lo, *np.geomspace(bottom, top, 9), top]
        curves = np.array([self._curve(m, tt) for m in lams])
        return tt, curves[0], curves.min(axis=0), curves.max(axis=0)

    def profile_curve(self, n: int = 41) -> tuple[NDArray, NDArray, bool]:
        """(lam, deviance D(lam), whether to draw lam on a log axis) around the interval.

        A bounded interval away from 0 spans [lo - w, hi + w], w = hi - lo (linear); otherwise
        logarithmically from hi / 1e4 (or lo / 10) to 10 hi (or 1e3 lam_hat).
        """
        if self.lo > 0 and math.isfinite(self.hi) and self.hi < 3 * self.lo:
            w = self.hi - self.lo
            lams = np.linspace(max(self.lo - w, 0.0), self.hi + w, n)
            log = False
        else:
            top = 10 * self.hi if math.isfinite(self.hi) else max(self.lam, 1e-12) * 1e3
            bottom = self.lo / 10 if self.lo > 0 else top * 1e-5
            lams = np.geomspace(bottom, top, n)
            log = True
        return lams, np.array([self._prof(m) - self.q_min for m in lams]), log

    @property
    def n(self) -> int:
        """Number of data points."""
        return int(self.t.size)

    @property
    def lag1(self) -> float:
        """Lag-1 autocorrelation of the residuals, sum r_i r_(i+1) / sum r_i^2.

        About 0 (within 1/sqrt(n)) for independent noise; near 1 when the model misses a
        systematic part of R(t).
        """
        r = self.R - self.fitted
        rr = float(r @ r)
        return float(r[1:] @ r[:-1]) / rr if rr > 0 else 0.0

    @property
    def warnings(self) -> list[str]:
        """What the interval does not account for, one line each.

        Residuals correlated beyond 3/sqrt(n) when the interval assumed independent noise
        (``noise="independent"``, or an AR(1) estimate of rho = 0), and a colony implausible
        for E. coli (:func:`_implausible_colony`: probably a wrong unit flag).
        """
        found = []
        if self.rho == 0 and self.lag1 > 3.0 / math.sqrt(self.n):
            found.append(f"the residuals are correlated (lag-1 autocorrelation {self.lag1:.2f}, "
                         f"independent noise: |r| < {3.0 / math.sqrt(self.n):.2f}): R(t) "
                         "deviates systematically from the radial solution, and the interval, "
                         "which assumes independent noise, is too narrow")
        implausible = _implausible_colony(self.t, self.R, self.time_unit, self.radius_unit,
                                          self.tau_minutes, self.cell_length_um)
        return found + ([implausible] if implausible else [])

    def summary(self) -> str:
        """One line: lam, its interval and the method."""
        hi = "inf" if math.isinf(self.hi) else f"{self.hi:.3g}"
        return (f"lam = {self.lam:.3g}, {100 * self.level:g} % interval [{self.lo:.3g}, {hi}] "
                f"({'profile likelihood' if self.method.startswith('profile') else 'bootstrap'}"
                f"{', reaches lam = 0' if self.at_boundary else ''}), n = {self.n}"
                + (f" (radius >= {self.min_radius:g} cell lengths; {self.n_dropped} "
                   f"row{'s' * (self.n_dropped != 1)} below not fitted)" if self.n_dropped
                   else "")
                + f", sigma = {self.sigma:.3g} {self.radius_unit}"
                + (f", AR(1) rho = {self.rho:.2f}" if self.rho > 0 else "")
                + (f", tau +-{100 * self.tolerance:g} %" if self.tolerance > 0 else ""))

    def record(self, command: str | None = None) -> dict:
        """The JSON record (``fit.json``)."""
        return {
            "lam": self.lam,
            "interval": [self.lo, None if math.isinf(self.hi) else self.hi],
            "interval_upper_bounded": not math.isinf(self.hi),
            "level": self.level,
            "method": self.method,
            "at_boundary": self.at_boundary,
            "time_origin": {"value": self.t0, "unit": self.time_unit,
                            "meaning": "time at which the fitted colony had the radius of one "
                            "cell, R0 = sqrt(b/pi) l0 with b = l0/2"},
            "radius_at_first_time": {"value": self.R1, "unit": self.radius_unit},
            "sigma": {"value": self.sigma, "unit": self.radius_unit,
                      "meaning": "maximum-likelihood noise, sqrt(RSS/n)"},
            "tau": {"value_minutes": self.tau_minutes, "given_minutes": self.tau_given_minutes,
                    "given_as": "doubling time" if self.doubling_time else "e-folding time",
                    "fitted": self.tau_prior_sd is not None,
                    "prior_sd_minutes": self.tau_prior_sd,
                    "meaning": "e-folding time of a free cell's length, dl/dt = l/tau (the "
                    "model's time unit)"},
            "units": {"time": self.time_unit, "radius": self.radius_unit,
                      "cell_length_um": self.cell_length_um,
                      "lam": "dimensionless, lam' = tau lam / (xi l0^2)"},
            "n_points": self.n,
            "min_radius": {"value": self.min_radius, "unit": "cell lengths",
                           "rows_not_fitted": self.n_dropped,
                           "meaning": "rows of a smaller radius are not fitted: the few-cell "
                           "stage the continuum's disc does not describe"},
            "noise": {"model": self.noise, "rho": self.rho,
                      "meaning": "continuous-time AR(1) residuals, rho the lag-1 correlation "
                      "at the median time step (0: independent)"},
            "tau_tolerance": {"value": self.tolerance,
                              "meaning": "model discrepancy: the interval is the hull of the "
                              "intervals at tau e^(-x), tau, tau e^(+x)"},
            "residual_lag1_autocorrelation": self.lag1,
            "warnings": self.warnings,
            "columns": {"time": self.columns[0], "radius": self.columns[1]},
            "data": self.source,
            "command": command,
        }


def _grid(y: NDArray, s: NDArray) -> NDArray:
    """Logarithmic lam grid (2 per decade) bracketing what the data can tell apart.

    From 1e-3 / R_max^2 (lam R^2 << 1: R(t) within 1e-3 of lam = 0's) to 20 / v^2, v the mean
    speed in cell lengths per growth time (dR/dt < sqrt(2/lam) for every R, so the estimate
    lies below 2 / v^2 up to noise), at most LAM_MAX. :func:`_interval` searches beyond it.
    """
    v = max((y[-1] - y[0]) / max(s[-1] - s[0], 1e-300), 1e-6)
    lo = 1e-3 / y.max() ** 2
    hi = min(max(20.0 / v ** 2, 100 * lo), LAM_MAX)
    k = max(int(math.ceil(2 * math.log10(hi / lo))), 6)
    return np.logspace(math.log10(lo), math.log10(hi), k + 1)


class _Profile:
    """Q_p(lam) with warm starts from the nearest lam already solved."""

    def __init__(self, problem: _Problem, x0: NDArray):
        self.pb = problem
        self.done: dict[float, tuple[float, NDArray]] = {}
        self.x0 = x0

    def __call__(self, lam: float) -> float:
        lam = float(lam)
        if lam in self.done:
            return self.done[lam][0]
        if self.done:
            near = min(self.done, key=lambda m: abs(math.log1p(m * 1e12) - math.log1p(lam * 1e12)))
            start = self.done[near][1]
            if self.pb.ar1:  # psi saturated at rho -> RHO_MAX (a poor lam) is no start
                start = np.concatenate((start[:-1], np.clip(start[-1:], -PSI_START, PSI_START)))
        else:
            start = self.x0
        q, x = self.pb.profile(lam, start)
        if self.pb.ar1:  # the likelihood can have two optima in rho: also from the first rho
            other = np.concatenate((x[:-1], self.x0[-1:]))
            q2, x2 = self.pb.profile(lam, other)
            if q2 < q:
                q, x = q2, x2
        self.done[lam] = (q, x)
        return q

    def x(self, lam: float) -> NDArray:
        self(lam)
        return self.done[float(lam)][1]


def _mle(prof: _Profile, grid: NDArray) -> tuple[float, float]:
    """(lam_hat, Q_min): the grid's best point, refined by bounded Brent in ln lam (or lam)."""
    lams = np.concatenate(([0.0], grid))
    qs = np.array([prof(m) for m in lams])
    k = int(np.argmin(qs))
    if k <= 1:
        res = optimize.minimize_scalar(prof, bounds=(0.0, lams[2]), method="bounded",
                                       options={"xatol": 1e-5 * lams[2]})
        cands = [(qs[0], 0.0), (float(res.fun), float(res.x))]
    else:
        hi = lams[min(k + 1, lams.size - 1)]
        res = optimize.minimize_scalar(lambda u: prof(math.exp(u)),
                                       bounds=(math.log(lams[k - 1]), math.log(hi)),
                                       method="bounded", options={"xatol": 1e-5})
        cands = [(qs[k], lams[k]), (float(res.fun), math.exp(res.x))]
    q, lam = min(cands)
    return lam, q


def _root(dev, a: float, b: float, outer: float) -> float:
    """Brent's root of ``dev`` in [a, b], or ``outer`` when it does not change sign there.

    ``outer`` is the bracket's end outside the interval (conservative): the profile at an end,
    re-solved from another start, can land on another optimum than on the grid.
    """
    try:
        return optimize.brentq(dev, a, b, xtol=1e-6)
    except ValueError:
        return outer


def _interval(prof: _Profile, lam_hat: float, q_min: float, grid: NDArray, c: float
              ) -> tuple[float, float]:
    """Ends of {lam >= 0: Q_p(lam) - q_min <= c}, bracketed on the grid, refined by brentq."""

    def dev(u: float) -> float:  # in u = ln lam
        return prof(math.exp(u)) - q_min - c

    # upper end
    above = [m for m in grid if m > lam_hat]
    hi = math.inf
    prev = lam_hat
    m = above[0] if above else max(lam_hat, grid[-1]) * 10
    while m <= LAM_MAX:
        if prof(m) - q_min > c:
            a = math.log(prev) if prev > 0 else math.log(m) - 30
            hi = math.exp(_root(dev, a, math.log(m), outer=math.log(m)))
            break
        prev = m
        later = [g for g in above if g > m]
        m = later[0] if later else m * 10
    # lower end
    if prof(0.0) - q_min <= c:
        return 0.0, hi
    below = [m for m in grid[::-1] if m < lam_hat]
    prev = lam_hat
    for m in below:
        if prof(m) - q_min > c:
            return math.exp(_root(dev, math.log(m), math.log(prev), outer=math.log(m))), hi
        prev = m
    # D(0) > c but every grid point below lam_hat is inside: the crossing is below grid[0]
    m = prev
    while m > 1e-300:
        m2 = m / 1e3
        if prof(m2) - q_min > c:
            return math.exp(_root(dev, math.log(m2), math.log(m), outer=math.log(m2))), hi
        m = m2
    return 0.0, hi


def fit_colony(  # noqa: PLR0913 (the fit's options, all keywords with defaults)
    t: ArrayLike,
    R: ArrayLike,
    *,
    tau_minutes: float,
    cell_length_um: float,
    time_unit: str = "min",
    radius_unit: str = "um",
    doubling_time: bool = False,
    tau_prior_sd: float | None = None,
    interval: str = "profile",
    n_boot: int = 200,
    seed: int = 0,
    level: float = 0.95,
    check: bool = True,
    min_radius: float | None = None,
    tolerance: float | None = None,
    noise: str = "ar1",
) -> ColonyFit:
    """Fit the radial solution's R(t) to measured radii: lam with its interval.

    Parameters
    ----------
    t, R : array_like
        Times (``time_unit``) and colony radii (``radius_unit``), in increasing time.
    tau_minutes : float
        Growth time in minutes: the e-folding time of dl/dt = l/tau (the model's time unit);
        a doubling time with ``doubling_time`` (tau = T / ln 2).
    cell_length_um : float
        Birth length l0 in micrometres (the model's length unit; b = l0/2).
    time_unit, radius_unit : str
        Keys of :data:`TIME_UNITS` and :data:`RADIUS_UNITS`.
    doubling_time : bool
        ``tau_minutes`` is a doubling time.
    tau_prior_sd : float, optional
        Fit tau as well, with a Gaussian prior of mean tau and this standard deviation
        (minutes; on the same reading of ``tau_minutes``).
    interval : {"profile", "bootstrap"}
        Profile likelihood (default) or residual-bootstrap percentile interval.
    n_boot, seed : int
        Bootstrap replicates and their random seed.
    level : float
        Confidence level of the interval.
    check : bool
        Refuse implausible data first (:func:`check_series`, the unit checks).
    min_radius : float, optional
        Rows with a radius below this many cell lengths are not fitted (default
        :data:`MIN_RADIUS`; 0 keeps every row): the few-cell stage the radial solution does
        not describe.
    tolerance : float, optional
        Model discrepancy: the interval is the hull of the intervals with tau e^(-tolerance),
        tau and tau e^(+tolerance) (default :data:`MODEL_TOLERANCE`; 0: tau exactly).
    noise : {"ar1", "independent"}
        Residual model of the profile interval: continuous-time AR(1) with its lag-1
        correlation estimated (default), or independent noise.

    Returns
    -------
    ColonyFit
        The estimate, its interval and what :func:`write_fit` needs.
    """
    min_radius = MIN_RADIUS if min_radius is None else min_radius
    tolerance = MODEL_TOLERANCE if tolerance is None else tolerance
    t = np.asarray(t, dtype=float).ravel()
    R = np.asarray(R, dtype=float).ravel()
    _check_options(tau_minutes, cell_length_um, time_unit, radius_unit, tau_prior_sd,
                   interval, n_boot, level)
    _check_model_options(min_radius, tolerance, noise)
    if t.shape != R.shape:
        raise ValueError(f"t and R differ in length ({t.size} and {R.size})")
    if check:
        check_series(t, R, radius_unit)
    ln2 = math.log(2.0)
    tau = tau_minutes / ln2 if doubling_time else tau_minutes
    sd = None if tau_prior_sd is None else (tau_prior_sd / ln2 if doubling_time else tau_prior_sd)
    y = R * RADIUS_UNITS[radius_unit] / cell_length_um
    if check:
        _check_units((t - t[0]) * TIME_UNITS[time_unit] / tau, y, cell_length_um, radius_unit,
                     time_unit)
    keep = _kept_rows(y, min_radius, cell_length_um, radius_unit)
    n_all = t.size
    t, R, y = t[keep], R[keep], y[keep]
    dt_min = (t - t[0]) * TIME_UNITS[time_unit]
    factors = (1.0, math.exp(-tolerance), math.exp(tolerance)) if tolerance > 0 else (1.0,)
    runs = []
    for k, factor in enumerate(factors):
        run = _fit_at(dt_min, y, tau * factor, sd, noise, interval, level, n_boot, seed,
                      time_unit, radius_unit)
        if k == 0:
            _check_identified(run.lam, time_unit)
        runs.append(run)
    main = runs[0]
    pb, prof, lam_hat = main.pb, main.prof, main.lam
    lo, hi = min(r.lo for r in runs), max(r.hi for r in runs)
    _check_identified(lam_hat, time_unit, lo, hi)
    method = main.method
    if tolerance > 0:
        method += (f"; hull of the intervals at tau e^(-{tolerance:g}), tau, tau e^{tolerance:g} "
                   f"(model discrepancy: the colony's time scale known to +-{tolerance:g})")
    x_hat = prof.x(lam_hat)
    theta = x_hat[1] if pb.free_tau else 0.0
    tau_hat = tau * math.exp(theta)
    R1 = math.exp(x_hat[0])
    fitted = pb.curve(lam_hat, x_hat[0], theta)
    r = fitted - y
    to_unit = cell_length_um / RADIUS_UNITS[radius_unit]
    # time origin: F(R1) - F(R0) growth times before the first data time
    t_back = float(radial.time_to_radius(R1, lam_hat, radial.R0)) * tau_hat
    t0 = t[0] - t_back / TIME_UNITS[time_unit]
    return ColonyFit(
        lam=float(lam_hat), lo=float(lo), hi=float(hi), level=level, method=method,
        at_boundary=lo == 0.0, t0=float(t0), R1=R1 * to_unit,
        sigma=math.sqrt(float(r @ r) / pb.n) * to_unit, tau_minutes=tau_hat,
        tau_given_minutes=float(tau_minutes), tau_prior_sd=tau_prior_sd,
        doubling_time=doubling_time, cell_length_um=float(cell_length_um), time_unit=time_unit,
        radius_unit=radius_unit, t=t, R=R, fitted=fitted * to_unit, threshold=main.c,
        q_min=main.q_min, noise=noise, rho=main.rho, tolerance=float(tolerance),
        lo_at_tau=float(main.lo), hi_at_tau=float(main.hi),
        min_radius=float(min_radius), n_dropped=int(n_all - t.size), _prof=prof)


@dataclass
class _Run:
    """One fit at one tau (:func:`_fit_at`): the estimate, its interval and the profile."""

    pb: _Problem
    prof: _Profile
    lam: float
    q_min: float
    lo: float
    hi: float
    c: float
    rho: float
    method: str


def _fit_at(  # noqa: PLR0913 (fit_colony's options, passed on)
        dt_min: NDArray, y: NDArray, tau: float, sd: float | None, noise: str,
            interval: str, level: float, n_boot: int, seed: int, time_unit: str,
            radius_unit: str) -> _Run:
    """The maximum-likelihood lam and its interval at the growth time ``tau`` (model units y).

    With ``noise="ar1"``: the residuals are continuous-time AR(1) with their lag-1
    correlation rho an unknown profiled like R_1 (:meth:`_Problem.use_ar1`), started from the
    residuals of the fit with independent noise (their lag-1 autocorrelation with Kendall's
    small-sample correction + (1 + 3 r)/n); the threshold c then has n - p - 1 degrees of
    freedom.
    """
    pb = _Problem(dt_min, y, tau, sd)
    grid = _grid(y, dt_min / tau)
    x0 = np.array([math.log(max(y[0], 1e-3)), 0.0])
    prof = _Profile(pb, x0)
    with _fit_failure(time_unit, radius_unit):
        lam_hat, q_min = _mle(prof, grid)
    rho = 0.0
    if noise == "ar1":
        x = prof.x(lam_hat)
        r = pb.curve(lam_hat, x[0], x[1] if pb.free_tau else 0.0) - y
        rr = float(r @ r)
        lag1 = float(r[1:] @ r[:-1]) / rr if rr > 0 else 0.0
        start = min(max(lag1 + (1.0 + 3.0 * lag1) / pb.n, 0.05), 0.95) * RHO_MAX
        pb = _Problem(dt_min, y, tau, sd)
        pb.use_ar1()
        x0 = np.array([*x, math.log(start / (RHO_MAX - start))])
        prof = _Profile(pb, x0)
        with _fit_failure(time_unit, radius_unit):
            lam_hat, q_min = _mle(prof, grid)
        rho = RHO_MAX / (1.0 + math.exp(-prof.x(lam_hat)[-1]))
    dof = pb.n - pb.p - int(pb.ar1)
    if dof < 1:
        raise ValueError(f"too few points: {pb.n} rows fitted, a fit needs at least "
                         f"{pb.p + 2}")
    c = pb.n * math.log1p(float(stats.f.ppf(level, 1, dof)) / dof)
    noise_text = (f"AR(1) residuals, lag-1 correlation {rho:.3g} (profiled)" if pb.ar1 else
                  "independent residuals")
    with _fit_failure(time_unit, radius_unit):
        if interval == "profile":
            lo, hi = _interval(prof, lam_hat, q_min, grid, c)
            method = (f"profile likelihood: lam >= 0 with n ln(RSS_p(lam)/RSS_min) "
                      f"{'+ tau prior ' if pb.free_tau else ''}<= n ln(1 + F_{{1,n-p}}"
                      f"({level:g})/(n-p)) = {c:.4g}, n = {pb.n}, p = {pb.p}"
                      f"{' + 1 (rho)' if pb.ar1 else ''}, {noise_text}")
        else:
            lo, hi = _bootstrap(pb, prof, lam_hat, level, n_boot, seed)
            method = (f"residual bootstrap, {n_boot} replicates (seed {seed}), percentile "
                      f"interval at {level:g}")
    return _Run(pb, prof, float(lam_hat), float(q_min), float(lo), float(hi), c, rho, method)


def _kept_rows(y: NDArray, min_radius: float, cell_length_um: float,
               radius_unit: str) -> NDArray:
    """Rows with a radius of at least ``min_radius`` cell lengths; refused if too few remain."""
    keep = y >= min_radius
    if keep.sum() < MIN_POINTS:
        edge = min_radius * cell_length_um / RADIUS_UNITS[radius_unit]
        raise ValueError(
            f"too small a colony to fit: {int(keep.sum())} of {y.size} rows have a radius of at "
            f"least {min_radius:g} cell lengths ({edge:g} {radius_unit}), a fit needs "
            f"{MIN_POINTS}; below it a colony is a line or a few hundred cells, which the "
            "continuum's disc does not describe (record the colony longer, or check "
            "--cell-length-um and --radius-unit)")
    return keep


def _check_model_options(min_radius: float, tolerance: float, noise: str) -> None:
    """Refuse a negative smallest radius or tolerance, or an unknown noise model."""
    if not (math.isfinite(min_radius) and min_radius >= 0):
        raise ValueError(f"min_radius must be a number >= 0 (cell lengths), got {min_radius}")
    if not (math.isfinite(tolerance) and 0 <= tolerance <= 1):
        raise ValueError(f"tolerance must lie in [0, 1], got {tolerance}")
    if noise not in ("ar1", "independent"):
        raise ValueError(f"noise must be ar1 or independent, got {noise!r}")


@contextmanager
def _fit_failure(time_unit: str, radius_unit: str) -> Iterator[None]:
    """Turn a numerical failure of the fit into one line naming the units (ValueError).

    Data in the wrong time or radius unit (minutes read as hours) can drive the radial
    solution out of floating-point range; the failure then says which units were used and
    which flags to check. numpy's overflow warnings are silenced meanwhile (the message is the
    one line the user gets).
    """
    try:
        with np.errstate(all="ignore"):
            yield
    except (ValueError, ArithmeticError) as err:
        detail = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ValueError(
            f"the fit failed with times in {time_unit} and radii in {radius_unit} ({detail}): "
            f"are the times in another unit (--time-unit s|min|h, now {time_unit})? check "
            f"--radius-unit ({radius_unit}) and --tau-minutes too") from None


def _check_identified(lam_hat: float, time_unit: str, lo: float | None = None,
                      hi: float | None = None) -> None:
    """Refuse an estimate that is no number: the data do not identify lam.

    Two cases: the best lam is at the largest lam searched (:data:`LAM_MAX`: a colony that
    does not grow measurably, every large lam fits alike), or the interval is [0, inf] (every
    lam >= 0 fits: no slowing detected and none excluded).
    """
    if lam_hat >= 0.5 * LAM_MAX:
        raise ValueError(
            f"the data do not identify lam: the best fit runs to the largest lam searched "
            f"({LAM_MAX:.0e}), a colony that does not grow measurably (no growth, or no "
            f"slowing to measure); check the radius column and --time-unit ({time_unit})")
    if lo is not None and hi is not None and lo == 0.0 and math.isinf(hi):
        raise ValueError(
            "the data do not identify lam: every lam >= 0 fits them (the interval would be "
            "[0, inf]: no slowing detected and no lam excluded); a fit needs a series long "
            f"enough to show growth slowing; check --time-unit ({time_unit}) and --tau-minutes")


def _bootstrap(pb: _Problem, prof: _Profile, lam_hat: float, level: float, n_boot: int,
               seed: int) -> tuple[float, float]:
    """Percentile interval of lam over residual-bootstrap refits."""
    x = prof.x(lam_hat)
    theta = x[1] if pb.free_tau else 0.0
    fit = pb.curve(lam_hat, x[0], theta)
    res = pb.y - fit
    res = (res - res.mean()) * math.sqrt(pb.n / (pb.n - pb.p))
    rng = np.random.default_rng(seed)
    grid = _grid(pb.y, pb.dt / pb.T)
    lams = np.empty(n_boot)
    for k in range(n_boot):
        yb = fit + rng.choice(res, size=pb.n, replace=True)
        pbk = _Problem(pb.dt, yb, pb.T, pb.sd)
        lams[k] = _mle(_Profile(pbk, x.copy()), grid)[0]
    a = (1.0 - level) / 2.0
    lo, hi = np.quantile(lams, [a, 1.0 - a])
    return float(lo), float(hi)


def _check_option(flag: str, value: float) -> None:
    """Refuse a numeric option that is not a finite number in its :data:`OPTION_RANGES` range.

    One line naming the flag, the range with its unit and what the range means.
    """
    lo, hi, unit, meaning = OPTION_RANGES[flag]
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and lo <= value <= hi):
        shown = f"{value:g}" if ok else repr(value)
        raise ValueError(f"{flag} must be a positive number in [{lo:g}, {hi:g}] {unit} "
                         f"({meaning}), got {shown}")


def _check_options(tau_minutes, cell_length_um, time_unit, radius_unit, tau_prior_sd, interval,
                   n_boot, level) -> None:
    """Refuse options out of range before any work (one line each, the first found).

    tau, the cell length and the tau prior's spread in :data:`OPTION_RANGES`; known units and
    interval; 20 <= ``n_boot`` <= :data:`MAX_BOOTSTRAP`; 0 < ``level`` < 1.
    """
    _check_option("--tau-minutes", tau_minutes)
    _check_option("--cell-length-um", cell_length_um)
    if tau_prior_sd is not None:
        _check_option("--tau-prior-sd", tau_prior_sd)
    if time_unit not in TIME_UNITS:
        raise ValueError(f"unknown time unit {time_unit!r}; known: {', '.join(TIME_UNITS)}")
    if radius_unit not in RADIUS_UNITS:
        raise ValueError(f"unknown radius unit {radius_unit!r}; known: "
                         f"{', '.join(RADIUS_UNITS)}")
    if interval not in ("profile", "bootstrap"):
        raise ValueError(f"interval must be profile or bootstrap, got {interval!r}")
    if not (isinstance(n_boot, int) and n_boot >= 20):
        raise ValueError(f"--bootstrap must be an integer >= 20, got {n_boot}")
    if n_boot > MAX_BOOTSTRAP:
        raise ValueError(f"--bootstrap {n_boot} is above the cap of {MAX_BOOTSTRAP:,} replicates "
                         f"(each is a full refit: {MAX_BOOTSTRAP:,} already take minutes, "
                         "1,000-2,000 give a stable 95 % interval)")
    if not 0 < level < 1:
        raise ValueError(f"level must lie in (0, 1), got {level}")


def fit_file(
    path: str | os.PathLike,
    *,
    time_column: str | None = None,
    radius_column: str | None = None,
    out: str | os.PathLike | None = None,
    command: str | None = None,
    **kwargs,
) -> ColonyFit:
    """Fit of a CSV file: the same result as ``colony fit``.

    :func:`read_series` then :func:`fit_colony` (``kwargs``); with ``out``, also
    :func:`write_fit` (``fit.json``, ``fit.png``, ``command`` recorded).
    """
    t, R, columns = read_series(path, time_column, radius_column)
    result = fit_colony(t, R, **kwargs)
    result.columns = columns
    result.source = str(path)
    if out is not None:
        write_fit(result, out, command)
    return result


# --------------------------------------------------------------------------- from a speed


@dataclass
class SpeedEstimate:
    """The stress sensitivity lam from one late radial speed (:func:`lam_from_speed`)."""

    lam: float
    speed_model: float
    tau_minutes: float
    doubling_time: bool
    lam_other_reading: float
    radius_model: float | None
    method: str

    def summary(self) -> str:
        """One line: lam and the assumption about tau that gives it."""
        other = "a doubling time" if not self.doubling_time else "an e-folding time"
        return (f"lam = {self.lam:.3g} from dR/dt = {self.speed_model:.4g} cell lengths per "
                f"growth time ({self.method}; tau = {self.tau_minutes:.4g} min, the e-folding "
                f"time of dl/dt = l/tau); read as {other}, "
                + (f"lam = {self.lam_other_reading:.3g}" if math.isfinite(self.lam_other_reading)
                   else "no lam >= 0 would give it"))

    def record(self, command: str | None = None) -> dict:
        """The JSON record (``fit.json`` of ``colony fit --speed``)."""
        return {"lam": self.lam, "interval": None, "method": self.method,
                "speed_model_units": self.speed_model, "tau_minutes": self.tau_minutes,
                "tau_given_as": "doubling time" if self.doubling_time else "e-folding time",
                "lam_if_tau_read_the_other_way": (self.lam_other_reading if math.isfinite(
                    self.lam_other_reading) else None),
                "radius_model_units": self.radius_model, "command": command}


def lam_from_speed(
    speed_um_per_s: float,
    *,
    tau_minutes: float,
    cell_length_um: float,
    doubling_time: bool = False,
    radius_um: float | None = None,
) -> SpeedEstimate:
    """The stress sensitivity from a late radial speed: the radial solution's linear growth.

    In model units v = (dR/dt) tau / l0. The radial solution's speed is
    dR/dt = R / (1 + sqrt(1 + lam R^2 / 2)) -> sqrt(2/lam) as lam R^2 -> infinity, so
    lam = 2 / v^2 (the paper's estimate). With the radius R at which the speed was measured
    the relation is inverted exactly: lam = 2 ((R/v - 1)^2 - 1) / R^2 (needs R > 2 v, the
    stress-free speed being R/2).

    The paper's numbers (tau = 54 min, l0 = 1 um, dR/dt = 1.3e-2 um/s) give v = 42.1 and
    lam = 1.13e-3 when tau = 54 min is the e-folding time of dl/dt = l/tau (the model's
    time unit); read as a doubling time, tau = 54 / ln 2 = 77.9 min, v = 60.8, lam = 5.4e-4.
    """
    for flag, v in (("--speed", speed_um_per_s), ("--tau-minutes", tau_minutes),
                    ("--cell-length-um", cell_length_um)):
        _check_option(flag, v)
    ln2 = math.log(2.0)

    def lam_of(tau_min: float) -> tuple[float, float, float | None]:
        v = speed_um_per_s * tau_min * 60.0 / cell_length_um
        if radius_um is None:
            return 2.0 / v ** 2, v, None
        Rm = radius_um / cell_length_um
        if Rm <= 2.0 * v:
            raise ValueError(
                f"the speed {v:.4g} cell lengths per growth time at radius {Rm:.4g} is at least "
                f"the stress-free speed R/2 = {Rm / 2:.4g}: no lam >= 0 gives it")
        return 2.0 * ((Rm / v - 1.0) ** 2 - 1.0) / Rm ** 2, v, Rm

    if radius_um is not None and not (math.isfinite(radius_um) and radius_um > 0):
        raise ValueError(f"--speed-radius must be a positive number, got {radius_um}")
    tau = tau_minutes / ln2 if doubling_time else tau_minutes
    other = tau_minutes if doubling_time else tau_minutes / ln2
    lam, v, Rm = lam_of(tau)
    try:
        lam_other = lam_of(other)[0]
    except ValueError:  # the other reading is faster than stress-free growth allows
        lam_other = math.nan
    method = ("late-time limit dR/dt = sqrt(2/lam) l0/tau" if radius_um is None else
              "exact radial speed dR/dt = R / (1 + sqrt(1 + lam R^2/2)) at the given radius")
    return SpeedEstimate(lam=lam, speed_model=v, tau_minutes=tau, doubling_time=doubling_time,
                         lam_other_reading=lam_other, radius_model=Rm, method=method)


# --------------------------------------------------------------------------- outputs


def _out_folder(out: str | os.PathLike) -> Path:
    folder = check_output(out)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def write_fit(result: ColonyFit | SpeedEstimate, out: str | os.PathLike,
              command: str | None = None) -> list[Path]:
    """Write ``fit.json`` (and ``fit.png`` for a fit) into ``out``, each atomically."""
    folder = _out_folder(out)
    text = json.dumps(result.record(command), indent=2, allow_nan=False) + "\n"

    paths = [replace_file(folder, "fit.json", lambda fh: fh.write(text.encode("utf-8")))]
    if isinstance(result, ColonyFit):
        paths.append(replace_file(folder, "fit.png", lambda fh: plot_fit(result, fh)))
    return paths


def plot_fit(result: ColonyFit, path: str | os.PathLike | BinaryIO) -> None:
    """Draw the fit as PNG: R(t), the residuals, and the profile deviance of lam.

    Left: the data, the radial solution at lam_hat and the band of the interval
    (:meth:`ColonyFit.band`); middle: data minus fit with the band about it; right: D(lam)
    (:meth:`ColonyFit.profile_curve`) against the threshold c, the interval marked.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4), layout="constrained")
    FigureCanvasAgg(fig)
    ax, rx, bx = fig.subplots(1, 3)
    tt, best, low, high = result.band()
    pct = f"{100 * result.level:g} %"
    ax.fill_between(tt, low, high, color="C0", alpha=0.3, lw=0, label=f"lam in the {pct} interval")
    ax.plot(tt, best, color="C0", label=f"radial solution, lam = {result.lam:.3g}")
    ax.plot(result.t, result.R, "o", ms=3, color="k", label="data")
    ax.set_xlabel(f"t ({result.time_unit})")
    ax.set_ylabel(f"R ({result.radius_unit})")
    ax.legend(loc="upper left", fontsize=8)
    hi = "inf" if math.isinf(result.hi) else f"{result.hi:.3g}"
    ax.set_title(f"lam = {result.lam:.3g}, {pct} [{result.lo:.3g}, {hi}], n = {result.n}",
                 fontsize=10)
    rx.fill_between(tt, low - best, high - best, color="C0", alpha=0.3, lw=0)
    rx.axhline(0.0, color="C0")
    rx.plot(result.t, result.R - result.fitted, "o", ms=3, color="k")
    rx.set_xlabel(f"t ({result.time_unit})")
    rx.set_ylabel(f"data - fit ({result.radius_unit})")
    rx.set_title(f"sigma = {result.sigma:.3g} {result.radius_unit}, residuals' lag-1 "
                 f"correlation {result.lag1:.2f}"
                 + (f" (AR(1) fit {result.rho:.2f})" if result.rho > 0 else ""), fontsize=10)
    lams, dev, log = result.profile_curve()
    bx.plot(lams, dev, ".-", color="C0", ms=3, label="profile deviance D(lam)")
    if log:
        bx.set_xscale("log")
    bx.axhline(result.threshold, color="C3", ls="--", label=f"threshold c = {result.threshold:.3g}")
    hull = result.tolerance > 0
    for i, end in enumerate((result.lo, result.hi)):
        if math.isfinite(end) and end > 0:
            bx.axvline(end, color="C3", lw=0.8, label=None if i else (
                f"interval: hull over tau e^(+-{result.tolerance:g})" if hull else "interval"))
    if hull:  # the crossings of the curve drawn: the interval at tau alone
        for i, end in enumerate((result.lo_at_tau, result.hi_at_tau)):
            if math.isfinite(end) and end > 0:
                bx.axvline(end, color="C1", lw=0.8, ls="--",
                           label=None if i else "interval at tau")
    if result.at_boundary:
        d0 = result._prof(0.0) - result.q_min
        bx.axhline(d0, color="C2", ls=":", label=f"D(0) = {d0:.3g}")
    bx.set_ylim(-0.05 * 4 * result.threshold, 4 * result.threshold)
    bx.set_xlabel("lam")
    bx.set_ylabel("Q_p(lam) - min Q_p")
    bx.set_title(result.method.split(":")[0] + (" at tau" if hull else ""), fontsize=10)
    bx.legend(fontsize=8)
    fig.savefig(path, format="png", dpi=100)


# --------------------------------------------------------------------------- the CLI


def _command(args) -> str:
    """The ``colony fit`` command of parsed arguments, every option spelled out."""
    words = ["colony", "fit"]
    if args.data is not None:
        words.append(str(args.data))
    opts = [("--tau-minutes", args.tau_minutes), ("--cell-length-um", args.cell_length_um)]
    if args.data is not None:
        opts += [("--time-column", args.time_column), ("--radius-column", args.radius_column),
                 ("--time-unit", args.time_unit), ("--radius-unit", args.radius_unit),
                 ("--tau-prior-sd", args.tau_prior_sd), ("--interval", args.interval)]
        if args.interval == "bootstrap":
            opts += [("--bootstrap", args.bootstrap), ("--seed", args.seed)]
    else:
        opts += [("--speed", args.speed), ("--speed-radius", args.speed_radius),
                 ("--radius-unit", args.radius_unit if args.speed_radius is not None else None)]
    opts.append(("--out", args.out))
    for flag, value in opts:
        if value is not None:
            words += [flag, f"{value:g}" if isinstance(value, float) else str(value)]
    if args.doubling_time:
        words.append("--doubling-time")
    return shlex.join(words)


def main_fit(args) -> int:
    """``colony fit``: a fit of DATA.csv or an estimate from --speed; prints and writes.

    ``args`` are those of the ``fit`` sub-parser of :func:`cases.cli.parser`.
    """
    if (args.data is None) == (args.speed is None):
        raise ValueError("give DATA.csv or --speed V (um/s), not both and not neither")
    if args.out is None and args.data is not None:
        args.out = f"fit-{Path(args.data).stem}"
    if args.out is not None:
        check_output(args.out)  # before any work (write_fit checks again)
    if args.data is None:
        if args.speed_radius is not None:
            radius = args.speed_radius * RADIUS_UNITS[args.radius_unit]
        else:
            radius = None
        est = lam_from_speed(args.speed, tau_minutes=args.tau_minutes,
                             cell_length_um=args.cell_length_um,
                             doubling_time=args.doubling_time, radius_um=radius)
        print(est.summary())
        if args.out is not None:
            for path in write_fit(est, args.out, _command(args)):
                print(f"written {path}")
        return 0
    if args.speed_radius is not None:
        raise ValueError("--speed-radius goes with --speed")
    _check_options(args.tau_minutes, args.cell_length_um, args.time_unit, args.radius_unit,
                   args.tau_prior_sd, args.interval, args.bootstrap, 0.95)  # before any work
    result = fit_file(args.data, time_column=args.time_column,
                      radius_column=args.radius_column, tau_minutes=args.tau_minutes,
                      cell_length_um=args.cell_length_um, time_unit=args.time_unit,
                      radius_unit=args.radius_unit, doubling_time=args.doubling_time,
                      tau_prior_sd=args.tau_prior_sd, interval=args.interval,
                      n_boot=args.bootstrap, seed=args.seed)
    args.time_column, args.radius_column = result.columns  # recorded as used
    print(result.summary())
    for warning in result.warnings:
        print(f"colony: warning: {warning}", file=sys.stderr)
    for path in write_fit(result, args.out, _command(args)):
        print(f"written {path}")
    return 0
