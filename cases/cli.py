"""The ``colony`` command: run either engine or one of the paper's cases.

::

    colony continuum|particles --lam LAM (--radius R | --time T) [--FIELD VALUE ...]
                               [--out DIR] [--config FILE.toml] [--set KEY=VALUE ...]
    colony continuum --from-particles RUN_DIR [--alpha A] [--bandwidth H] (--radius R | ...
    colony case NAME [--scale smoke|medium|paper] [--engines both|continuum] [--out DIR]
                [--runs DIR] [--scheduler ADDRESS] [--workers N]
    colony case NAME --from-data [--data-set medium|paper] [--out DIR]

SHAPE (continuum.shapes): circle[:R], ellipse:A,B, rectangle:W,H[,ROUND], star:K,EPS[,R],
polygon:FILE.csv, and for particles line:N; the particles fill the outline (cases.shapes).

Every run is configured by one dataclass (``continuum.Config`` / ``particles.Config``), built from
the engine's defaults, then an optional TOML file, then ``--set`` overrides, then the flags (one
``--field-name`` per field, but those of ``NO_FLAG``); the run writes it back as ``config.json``.

Output folders are never left half-written: a run writes into ``DIR.partial/`` and renames it to
``DIR`` only when everything (engine output, ``profile.csv``, the PNG) is written. A stopped
particle run keeps its checkpoint in ``DIR.partial/`` and resumes from it when the same command
is given again (``--change-step-policy``: also with another ``--dt`` or ``--step-control``).
``--max-hours H`` pauses a run before H hours of wall: a checkpoint, ``run.json`` status
``paused``, exit status 75 (``rundir.PAUSED_STATUS``); the same command resumes it. Bad
input ends with a one-line message on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import inspect
import logging
import math
import os
import re
import sys
import time
import tomllib
from pathlib import Path

from cases.rundir import (
    CHECKPOINTS,
    PAUSED_STATUS,
    RECORD,
    RunFolderError,
    RunPaused,
    check_output,
    describe,
    is_no_space,
    no_space_message,
    partial_of,
    stop_signals_exit,
)
from cases.runs import ENGINES
from cases.sweep import check_scheduler, check_workers, legs, select_lams

#: ``colony case NAME``: the module of each case (``compute``, ``plot``; docs/DESIGN.md).
CASES = {
    "fig2": "cases.figures.fig2",
    "fig3": "cases.figures.fig3",
    "fig4": "cases.figures.fig4",
    "crosscheck": "cases.figures.crosscheck",
    "stability": "cases.studies.stability",
    "convergence": "cases.studies.convergence",
    "ensemble": "cases.studies.ensemble",
    "shapes": "cases.studies.shapes",
    "orientation": "cases.studies.orientation",
    "strains": "cases.studies.strains",
    "nutrients": "cases.studies.nutrients",
}
#: The figure cases: their runs are one per (engine, lam), so ``--lams`` may select some.
FIGURE_CASES = ("fig2", "fig3", "fig4", "crosscheck")
#: Committed data sets of every case: cases/data/NAME (medium), cases/data/NAME_paper.
DATA_SETS = ("medium", "paper")
#: The committed data of the cases, in a git checkout (the wheel carries none: issue 43).
DATA = Path(__file__).resolve().parent / "data"


class UsageError(ValueError):
    """Bad command-line input (reported in one line, exit status 2)."""


SHOWN = 60
"""Most characters of a value quoted in an error line (longer ones are cut, ``...``)."""


def _shown(value, toml: bool = True) -> str:
    """A value as an error line quotes it, cut at SHOWN characters.

    TOML-like (true, "yes", 1e+300) for a configuration value, else as Python writes it
    (``toml=False``: the command line's text, '1.5').
    """
    import json

    text = json.dumps(value) if toml and isinstance(value, (bool, str)) else repr(value)
    return text if len(text) <= SHOWN else text[:SHOWN - 3] + "..."


# --------------------------------------------------------------------------- configuration


def _threads(text: str) -> int | str:
    """Threads (``--threads``, ``--set threads=``): "auto" or an integer (validate: its range)."""
    if text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto or an integer, got {text!r}") from None


def strain_list(text: str) -> list[list[float]]:
    """``LAM[:GROWTH],LAM[:GROWTH],...`` (strain 0 first, growth default 1) as [[lam, growth], ...].

    The form of ``--strains`` and ``--set strains=``; the engine's Config checks the values.
    """
    out = []
    for item in text.split(","):
        lam, _, growth = item.strip().partition(":")
        try:
            out.append([float(lam), float(growth) if growth.strip() else 1.0])
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected LAM[:GROWTH],LAM[:GROWTH],... (e.g. 1e-2,0 or 1e-2:1,0:0.5), "
                f"got {_shown(text, toml=False)}") from None
    return out


FIELD_PARSERS = {"threads": _threads, "strains": strain_list}
"""Fields whose type is not that of their default: their flag's and ``--set`` value's parser."""


def _coerce(value: str, key: str, mismatch):
    """A ``--set`` string as the type the field ``key`` takes; else UsageError saying which.

    The first of a number, an integer, a boolean (1, true, yes, on or 0, false, no, off, in
    any case) or the string itself that the field takes: ``mismatch(key, value)`` is None (the
    engine's ``Config.type_mismatch``).
    """
    candidates = []
    for parse in (float, int):
        try:
            candidates.append(parse(value))
        except ValueError:
            pass
    word = value.strip().lower()
    if word in ("1", "true", "yes", "on", "0", "false", "no", "off"):
        candidates.append(word in ("1", "true", "yes", "on"))
    for candidate in (*candidates, value):
        if mismatch(key, candidate) is None:
            return candidate
    number = [c for c in candidates if isinstance(c, float)]  # "a finite number" for inf
    expected = mismatch(key, (number or [value])[0])
    raise UsageError(f"expected {expected}, got {_shown(value, toml=False)}")


def _lam_of_strains(strains) -> dict:
    """``{"lam": strain 0's lam}`` when strains are given, else ``{}``.

    With strains, lam is not used by the model (each strain's own is), so it is optional; the
    Config checks the strains.
    """
    try:
        first = strains[0]
        return {"lam": float(first["lam"] if isinstance(first, dict) else first[0])}
    except (TypeError, LookupError, ValueError):
        return {}


def build_config(cls, toml_file: str | None, sets: list[str], flags: dict):
    """Engine defaults <- TOML file <- ``--set KEY=VALUE`` <- flags; then ``validate()``.

    Every value is checked against its field's type (``cls.type_mismatch``, when the class has
    one) where it was given, so that the one-line message names its source:
    ``--config FILE: key lam: expected a number, got true``, ``--set seed: expected an
    integer, got '1.5'`` or ``--seed: ...``.
    """
    names = {f.name for f in dataclasses.fields(cls)}
    mismatch = getattr(cls, "type_mismatch", lambda key, value: None)
    values: dict = {}
    source: dict = {}

    def name(text) -> str:  # a key or file name on one line: quoted when it holds a line break
        text = str(text) if str(text).isprintable() else repr(str(text))
        return text if len(text) <= 5 * SHOWN else text[:5 * SHOWN - 3] + "..."

    if toml_file:
        path = Path(toml_file)
        try:
            with path.open("rb") as fh:
                table = tomllib.load(fh)
        except OSError as err:
            raise UsageError(f"config file not found or not readable: {name(path)} "
                             f"({err.strerror})") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:  # not TOML, not UTF-8
            raise UsageError(f"--config {name(path)}: {err}") from None
        unknown = sorted(set(table) - names)
        if unknown:
            raise UsageError(f"--config {name(path)}: unknown setting(s) "
                             f"{', '.join(map(name, unknown))}; known: {', '.join(sorted(names))}")
        values.update(table)
        source.update({key: f"--config {name(path)}: key {key}" for key in table})
    for item in sets:
        key, sep, raw = item.partition("=")
        key = key.strip().replace("-", "_")
        if not sep:
            raise UsageError(f"--set expects KEY=VALUE, got {_shown(item, toml=False)}")
        if key not in names:
            raise UsageError(f"unknown setting {_shown(key, toml=False)}; known: "
                             f"{', '.join(sorted(names))}")
        try:
            values[key] = (FIELD_PARSERS[key](raw) if key in FIELD_PARSERS
                           else _coerce(raw, key, mismatch))
        except (UsageError, argparse.ArgumentTypeError) as err:
            raise UsageError(f"--set {key}: {err}") from None
        source[key] = f"--set {key}"
    given = {k: v for k, v in flags.items() if v is not None}
    checks = [(source[key], key, value) for key, value in values.items()]
    checks += [("--" + key.replace("_", "-"), key, value) for key, value in given.items()]
    for where, key, value in checks:
        what = mismatch(key, value)
        if what is not None:
            raise UsageError(f"{where}: expected {what}, got {_shown(value)}")
    if "lam" in given and "lam" in values and float(values["lam"]) != given["lam"]:
        raise UsageError(f"lam given twice: --lam {given['lam']:g} and lam = "
                         f"{values['lam']} in --config/--set; give it once")
    if "lam" in names and "lam" not in given and "lam" not in values:
        values.update(_lam_of_strains(given.get("strains", values.get("strains"))))
    if "lam" in names and "lam" not in given and "lam" not in values:
        raise UsageError("lam is required: give --lam or lam in --config/--set (or --strains)")
    values.update(given)
    config = cls(**values)
    config.validate()
    return config


# --------------------------------------------------------------------------- engine flags

#: Config fields with no flag (``--config FILE`` or ``--set KEY=VALUE`` give them).
NO_FLAG = {"continuum": ("initial_radius", "interior_coarsening", "grading", "courant", "q_min",
                         "stretch", "n_length_cells", "bump_width", "initial_sizes",
                         "psi_transport", "write_fields", "step_limit", "checkpoint_seconds"),
           "particles": ("tol", "fill_lengths", "checkpoint_seconds", "max_particles",
                         "solver_tol", "solver_tol_factor", "contact_margin", "max_passes",
                         "max_iterations", "nutrient_grid")}
#: How the help words a default of None or () (what the engine does without a value).
DEFAULT_WORDS = {"monod_k": "inf", "max_hours": "no limit", "strains": "one strain of --lam",
                 "shape": "none, one cell", "init": "one cell of length 1 at the origin",
                 "dish_radius": "supply at the colony's edge"}
#: Help of the engine flags by Config field, or (engine, field): ``{default}`` is the field's
#: default (DEFAULT_WORDS for None), ``{choices}`` its values (CHOICES), ``{config}`` the Config.
#: A field not here has the first sentence of its entry in the Config's docstring.
FLAG_HELP = {
    "lam": "stress sensitivity lambda, per unit stress (required; or lam in --config / --set)",
    "radius": "stop when the colony radius reaches R, in birth lengths",
    "time": "stop at time T, in growth times (e-folding times of a cell's length; t = 0 at start)",
    "nutrient_length": "nutrient limitation: the penetration length ell in cell lengths (growth "
                       "exp(-lam sigma) f(c), Laplace c = g / ell^2, c = 1 at the edge; "
                       "default: {default})",
    "dish_radius": "with --nutrient-length: the nutrient supplied through the agar of a dish, "
                   "c = 1 on the circle of radius R about the origin (where the colony starts), "
                   "in cell lengths; the run stops when the colony reaches it (default: "
                   "{default})",
    "max_hours": f"pause before H hours of wall: a checkpoint, exit status {PAUSED_STATUS}; the "
                 "same command resumes (batch jobs: docs/clusters.md; default: {default})",
    "strains": "strains of the colony, strain 0 first: stress sensitivity and growth factor "
               "(default 1), e.g. 1e-2,0 (default: {default})",
    "layout": "initial layout of the strains: core:R1[,R2...], sector:THETA[,DIRECTION] "
              "(radians; strain 1 in the wedge), mixture:F0,F1[,...] or polygon:FILE.csv[,...] "
              "(strain i + 1 inside file i; default: {default})",
    ("continuum", "shape"): "initial shape, sizes in birth lengths: {default} (default, radius "
                            "sqrt(b/pi) = {config.initial_radius:.2f}: one cell's area), circle:R, "
                            "ellipse:A,B, rectangle:W,H[,ROUND], star:K,EPS[,R] or "
                            "polygon:FILE.csv",
    "element": "pressure element: {choices} (default {default})",
    "init": "initial particles, CSV with columns x,y,theta,length (default: {default})",
    ("particles", "shape"): "initial shape filled with rods, sizes in birth lengths: circle:R, "
                            "ellipse:A,B, rectangle:W,H[,ROUND], star:K,EPS[,R], "
                            "polygon:FILE.csv or line:N (default: {default})",
    "solver": "contact solver: {choices} (default {default}; bbpgd-cuda needs an NVIDIA GPU and "
              "pip install '.[gpu]')",
    "threads": "threads of the contact solver: a number or {default} (the default: one thread "
               "below 2e4 particles, every core above; give 1 when runs share the cores); the "
               "same result for any number",
}
METAVARS = {"nutrient_length": "ELL", "monod_k": "K", "dish_radius": "R", "output_every": "T",
            "max_hours": "H", "strains": "LAM[:A],LAM[:A],..."}
#: The table of a field's values, in its Config's module (argparse checks a step control).
CHOICES = {"element": "ELEMENTS", "solver": "SOLVERS", "step_control": "STEP_CONTROLS"}


def _first_sentences(cls) -> dict:
    """Each field's docstring entry to its first full stop: lower case, no markup or code names."""
    entries = re.findall(r"^(\w+(?:, \w+)*) : .*\n((?:    .*\n)+)",
                         inspect.cleandoc(cls.__doc__) + "\n", re.MULTILINE)
    first = {name: " ".join(re.sub(r'``|"', "", text).split()).split(". ")[0].rstrip(".")
             for names, text in entries for name in names.split(", ")}
    return {name: re.sub(r"^[A-Z](?=[a-z])|\s\((?:[\w.]+\.\w+(?:; |, )?)+\)",
                         lambda m: m[0].lower() if m[0][0].isupper() else "", text)
            for name, text in first.items()}


def _config_flags(p: argparse.ArgumentParser, engine: str) -> None:
    """A flag of each Config field of ``engine`` with one (NO_FLAG); ``--radius | --time``."""
    cls, docs = ENGINES[engine].config, _first_sentences(ENGINES[engine].config)
    module = vars(sys.modules[cls.__module__])  # where CHOICES are
    group = p.add_argument_group(f"configuration ({engine}.Config; also --config, --set)")
    goal = group.add_mutually_exclusive_group(required=True)
    for field in (f for f in dataclasses.fields(cls) if f.name not in NO_FLAG[engine]):
        default = field.default
        default = format(default, "g") if isinstance(default, float) else default
        default = DEFAULT_WORDS.get(field.name, "none") if default in (None, ()) else default
        values = module.get(CHOICES.get(field.name), ())
        template = FLAG_HELP.get((engine, field.name), FLAG_HELP.get(field.name))
        text = docs.get(field.name, "").replace("%", "%%") + f" (default {default})"  # as is
        if template is not None:
            text = template.format(default=default, choices=", ".join(values), config=cls)
        choices = None
        if field.name == "step_control":
            choices = sorted(values, key=lambda v: v != field.default)  # the default first
        kind = {"float": float, "int": int}.get(field.type.split(" | ")[0])  # None: a string
        where = goal if field.name in ("radius", "time") else group
        where.add_argument("--" + field.name.replace("_", "-"), help=text, choices=choices,
                           type=FIELD_PARSERS.get(field.name, kind),
                           metavar=METAVARS.get(field.name))


def _engine_parser(sub, engine: str, help: str) -> argparse.ArgumentParser:
    """The sub-command of an engine: its Config's flags, then those of the run folder."""
    p = sub.add_parser(engine, help=help)
    _config_flags(p, engine)
    run = p.add_argument_group("run folder and output")
    run.add_argument("--out", default=f"runs/{engine}", help="output folder (default %(default)s)")
    run.add_argument("--overwrite", action="store_true",
                     help="replace an existing output folder (default: refuse)")
    run.add_argument("--other-engine", action="store_true",
                     help="resume a stopped run whose checkpoint another version of the engine "
                     "wrote (default: refuse; grow every leg with the same version)")
    run.add_argument("--config", help="TOML file of configuration values (default: none)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override one configuration value (repeatable)")
    _verbosity(run)
    return run


def _continuum(sub) -> None:
    run = _engine_parser(sub, "continuum", "2D moving-boundary continuum colony")
    run.add_argument("--from-particles", metavar="RUN_DIR",
                     help="start from the final state of a particle run (cases.handoff): its "
                     "alpha-shape outline and kernel-smoothed size distribution; lam defaults "
                     "to the particle run's")
    run.add_argument("--alpha", type=float,
                     help="with --from-particles: alpha of the outline (default 1 = 2 rod widths)")
    run.add_argument("--bandwidth", type=float,
                     help="with --from-particles: Gaussian kernel bandwidth of Psi0 (default 2)")


def _particles(sub) -> None:
    run = _engine_parser(sub, "particles", "growing, dividing sphero-cylinders")
    run.add_argument("--change-step-policy", action="store_true",
                     help="resume a checkpoint written with another --dt or --step-control")


# --------------------------------------------------------------------------- parser


def _verbosity(p) -> None:
    p.add_argument("--quiet", action="store_true", help="no progress output, warnings only")
    p.add_argument("--verbose", action="store_true", help="log every stage (INFO, DEBUG)")


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, ``colony: error: ...``, exit status 2.

    argparse prints its usage block first; the line names the sub-command's ``--help``
    instead. Sub-parsers are of the same class.
    """

    def error(self, message: str):
        """Exit with one line: the message and where the help is."""
        name = self.prog.split()[0]
        self.exit(2, f"{name}: error: {message} (see {self.prog} --help)\n")


def parser() -> argparse.ArgumentParser:
    """The ``colony`` argument parser."""
    top = OneLineParser(prog="colony", description=__doc__.split("\n")[0])
    sub = top.add_subparsers(dest="command", required=True)
    _continuum(sub)
    _particles(sub)

    i = sub.add_parser("info", help="print a run folder's provenance (run.json)")
    i.add_argument("dir", help="run folder (or its stopped DIR.partial)")

    pp = sub.add_parser("plot", help="redraw a run's pictures and R(t) from its saved outputs")
    pp.add_argument("dir", help="run folder")
    pp.add_argument("--out", default=None, help="folder of the pictures (default DIR)")

    pm = sub.add_parser("movie", help="MP4 of a run's saved frames (trajectory.gsd or VTU)")
    pm.add_argument("dir", help="run folder")
    pm.add_argument("--out", default=None, help="movie file (default DIR/movie.mp4)")
    pm.add_argument("--fps", type=float, default=12.0, help="frames per second (default 12)")
    pm.add_argument("--max-frames", type=int, default=None,
                    help="at most this many frames, evenly spaced (default all)")
    _verbosity(pm)

    k = sub.add_parser("case", help="a paper figure (fig2, fig3, fig4), the cross-check, or a "
                       "study (" + ", ".join(n for n in CASES if n not in FIGURE_CASES) + ")")
    k.add_argument("name", choices=list(CASES))
    k.add_argument("--scale", choices=("smoke", "medium", "paper"), default="smoke",
                   help="smoke (default): small colonies in about a minute, for a check; "
                   "medium: radius 40, both engines, about an hour on 2 cores; paper: radius "
                   "150 as in the paper, hours per particle colony")
    k.add_argument("--out", default=None, help="output folder (default runs/case-NAME-SCALE)")
    k.add_argument("--from-data", action="store_true",
                   help="redraw from the data committed in cases/data (no computation)")
    k.add_argument("--data", metavar="FOLDER",
                   help="with --from-data: the folder of the committed data (default: cases/data "
                   "of this checkout; an installed package carries none)")
    k.add_argument("--data-set", choices=DATA_SETS, default="medium",
                   help="committed data to redraw: medium (radius 40, both engines, default) or "
                   "paper (radius 150; particles for the lam computed so far)")
    k.add_argument("--engines", choices=("both", "continuum", "finished"), default="both",
                   help="compute both engines (default), the continuum only, or the continuum "
                   "plus the particle runs already finished under --runs (none started)")
    k.add_argument("--lams", type=_lam_list, default=None, metavar="L[,L...]",
                   help=f"only these lam of the figure ({', '.join(FIGURE_CASES)}) or of "
                   "ensemble (default all), e.g. a new paper colony or ensemble lam, to merge "
                   "into the committed data with python -m cases.figures.merge")
    k.add_argument("--runs", help="folder of the engine runs, shared between cases "
                   "(default OUT/runs); finished runs in it are reused")
    k.add_argument("--print-runs", action="store_true",
                   help="print, for a figure case, each engine run's folder under --runs and the "
                   "colony command that grows it there by hand (then --engines finished takes "
                   "it); run nothing")
    k.add_argument("--scheduler",
                   help="address of an existing dask scheduler, e.g. tcp://host:8786 (default: "
                   "a local cluster of --workers); the workers must see --out on a shared "
                   "file system")
    k.add_argument("--workers", type=int, default=2,
                   help="local dask workers when no --scheduler is given (default 2)")
    k.add_argument("--max-hours", type=float, metavar="H",
                   help="each engine run in legs of at most H hours of wall (a little under the "
                   "workers' walltime); a paused run is submitted again (default: no limit)")
    _verbosity(k)

    f = sub.add_parser("fit", help="stress sensitivity lam from a colony's measured R(t) "
                       "(cases.fit), or from a late radial speed")
    f.add_argument("data", nargs="?", default=None, help="CSV with a header: times and radii")
    f.add_argument("--tau-minutes", type=float, required=True,
                   help="growth time tau in minutes: the e-folding time of a cell's length "
                   "(dl/dt = l/tau, the model's time unit); see --doubling-time")
    f.add_argument("--doubling-time", action="store_true",
                   help="--tau-minutes is a doubling time (tau = T / ln 2)")
    f.add_argument("--cell-length-um", type=float, required=True,
                   help="birth length l0 in um (the model's length unit)")
    f.add_argument("--time-column", help="time column (default: t or time)")
    f.add_argument("--radius-column", help="radius column (default: radius or r)")
    f.add_argument("--time-unit", choices=("s", "min", "h"), default="min",
                   help="unit of the times (default min)")
    f.add_argument("--radius-unit", choices=("um", "mm"), default="um",
                   help="unit of the radii (default um)")
    f.add_argument("--tau-prior-sd", type=float, metavar="MINUTES",
                   help="fit tau too, with a Gaussian prior of this standard deviation")
    f.add_argument("--interval", choices=("profile", "bootstrap"), default="profile",
                   help="95 %% interval of lam: profile likelihood (default) or bootstrap")
    f.add_argument("--bootstrap", type=int, default=200, metavar="N",
                   help="bootstrap replicates (default 200)")
    f.add_argument("--seed", type=int, default=0, help="bootstrap seed (default 0)")
    f.add_argument("--speed", type=float, metavar="V_UM_PER_S",
                   help="instead of DATA.csv: lam from a late radial speed in um/s")
    f.add_argument("--speed-radius", type=float, metavar="R",
                   help="with --speed: the radius (--radius-unit) where it was measured, to "
                   "invert the exact radial speed instead of its late-time limit")
    f.add_argument("--out", help="folder of fit.json and fit.png (default fit-STEM for "
                   "DATA.csv; with --speed only printed unless given)")
    return top


def _lam_list(text: str) -> list[float]:
    """``--lams``: comma-separated lam >= 0."""
    try:
        lams = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"not a comma-separated list of numbers: {text!r}") from None
    if not all(math.isfinite(v) and v >= 0 for v in lams):
        raise argparse.ArgumentTypeError(f"every lam must be finite and >= 0, got {text!r}")
    return lams


def _positive_hours(hours: float | None) -> float | None:
    """``--max-hours`` of ``colony case``: positive and finite (the engines check their own)."""
    if hours is not None and not (math.isfinite(hours) and hours > 0):
        raise UsageError(f"--max-hours must be positive and finite, got {hours}")
    return hours


def _handoff_options(args, flags: dict) -> tuple | None:
    """(run folder, alpha, bandwidth) of --from-particles, checked; None without it.

    The particle run's folder and last frame are checked here, before any work; its lam is
    the default of ``flags["lam"]`` (unless --lam, --config or --set lam= gives one).
    """
    from cases import handoff

    extra = [name for name in ("alpha", "bandwidth") if getattr(args, name) is not None]
    if args.from_particles is None:
        if extra:
            raise UsageError(f"--{extra[0]} needs --from-particles")
        return None
    if args.shape is not None:
        raise UsageError("give either --shape or --from-particles, not both")
    for name in extra:
        if not (math.isfinite(getattr(args, name)) and getattr(args, name) > 0):
            raise UsageError(f"--{name} must be a positive number, got {getattr(args, name)}")
    try:
        handoff.final_particles(args.from_particles)
    except ValueError as err:
        raise UsageError(f"--from-particles: {err}") from None
    flags["initial_sizes"] = "histogram"  # Psi0 is the particles' size histogram
    lam_elsewhere = args.config or any(s.strip().startswith("lam=") for s in args.set)
    if flags["lam"] is None and not lam_elsewhere:
        flags["lam"] = handoff.particle_lam(args.from_particles)
    return (args.from_particles,
            handoff.ALPHA if args.alpha is None else args.alpha,
            handoff.BANDWIDTH if args.bandwidth is None else args.bandwidth)


def _handoff_start(config, run_dir: str, alpha: float, bandwidth: float) -> tuple:
    """(state, record) of the particle run's final state (cases.handoff.continuum_start).

    The radius goal must lie beyond the outline's radius sqrt(A / pi).
    """
    from cases.handoff import continuum_start

    state, record = continuum_start(run_dir, config, alpha, bandwidth)
    if config.radius is not None and config.radius <= record["outline_radius"]:
        raise UsageError(f"--radius {config.radius:g} is not beyond the particle colony's "
                         f"radius sqrt(A/pi) = {record['outline_radius']:.4g}")
    return state, record


def _run_engine(args, progress: bool) -> None:
    """``colony continuum`` / ``colony particles``: the Config of the flags, then the run."""
    names = [f.name for f in dataclasses.fields(ENGINES[args.command].config)]
    flags = {name: getattr(args, name) for name in names if hasattr(args, name)}
    for name, value in flags.items():  # the nutrient's: the Config says (monod_k takes inf)
        if isinstance(value, float) and not math.isfinite(value) and name not in (
                "nutrient_length", "monod_k"):
            raise UsageError(f"--{name.replace('_', '-')} must be finite, got {value}")
    handoff = _handoff_options(args, flags) if args.command == "continuum" else None
    config = build_config(ENGINES[args.command].config, args.config, args.set, flags)
    if len(config.strains) >= 2 and config.layout is None:  # no other way to place them
        raise UsageError(f"{len(config.strains)} strains need --layout to place them at the "
                         "start: core:R1, sector:THETA, mixture:F0,F1 or polygon:FILE.csv")
    resume = ({"change_step_policy": args.change_step_policy} if args.command == "particles"
              else {"start": handoff and _handoff_start(config, *handoff)})
    ENGINES[args.command].run(config, Path(args.out), overwrite=args.overwrite,
                              progress=progress, other_engine=args.other_engine,
                              started=args.started, **resume)
    print(f"{args.command.replace('particles', 'particle')} run written to {args.out}")


def _dispatch(args) -> int:
    progress = not args.__dict__.get("quiet", False)
    if args.command in ENGINES:
        _run_engine(args, progress)
    elif args.command == "info":
        print(describe(Path(args.dir)))
    elif args.command == "plot":
        from cases.viewer import plot_run

        for path in plot_run(Path(args.dir), args.out):
            print(path)
    elif args.command == "movie":
        from cases.viewer import movie_run

        print(movie_run(Path(args.dir), args.out or Path(args.dir) / "movie.mp4", fps=args.fps,
                        max_frames=args.max_frames, progress=progress))
    elif args.command == "fit":
        from cases.fit import main_fit

        main_fit(args)
    else:
        module = importlib.import_module(CASES[args.name])
        out = check_output(args.out or f"runs/case-{args.name}-{args.scale}")
        if args.runs is not None:
            args.runs = str(check_output(args.runs, flag="--runs"))
        if not (args.from_data or args.print_runs):  # the runs go to Dask: check it first
            if args.scheduler is None:
                check_workers(args.workers)
            else:
                check_scheduler(args.scheduler)
        created = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
        try:
            with legs(_positive_hours(args.max_hours)):
                data = _case_data(module, args, out)
        except BaseException:
            if created and not any(out.iterdir()):  # bad input: leave nothing behind
                out.rmdir()
            raise
        if data is None:  # --print-runs
            if created and not any(out.iterdir()):
                out.rmdir()
            return 0
        module.plot(data, out)
        print(f"case {args.name} written to {out}")
    return 0


def _case_data(module, args, out: Path) -> Path:
    """The data folder a case draws from: committed (--from-data) or computed into ``out``."""
    if args.from_data:
        suffix = "" if args.data_set == "medium" else f"_{args.data_set}"
        root = Path(args.data) if args.data else DATA
        data = root / f"{args.name}{suffix}"
        if not data.is_dir():
            where = ("" if args.data or DATA.is_dir() else
                     "; the committed data live in a git checkout's cases/data, not in the "
                     "installed package: give --data CHECKOUT/cases/data")
            raise UsageError(f"no committed data for case {args.name} in {data}{where}")
        return data
    if args.workers < 1:
        raise UsageError(f"--workers must be >= 1, got {args.workers}")
    if args.print_runs:
        if args.name not in FIGURE_CASES:
            raise UsageError(f"--print-runs applies to the figure cases "
                             f"({', '.join(FIGURE_CASES)}), not to {args.name}")
        print(run_commands(module, args.scale, Path(args.runs or out / "runs"), args.lams),
              end="")
        return None
    engines = ("continuum",) if args.engines == "continuum" else ("continuum", "particles")
    finished_only = ("particles",) if args.engines == "finished" else ()
    lams = {}
    if args.lams is not None:
        if args.name not in (*FIGURE_CASES, "ensemble"):
            raise UsageError(f"--lams applies to the figure cases ({', '.join(FIGURE_CASES)}) "
                             f"and ensemble, not to {args.name}")
        if args.name in FIGURE_CASES:  # the ensemble checks its lam itself
            select_lams(module.runs_needed(args.scale, engines)[1], args.lams, args.name)
        lams = {"lams": args.lams}
    return module.compute(scale=args.scale, out=out, scheduler=args.scheduler,
                          n_workers=args.workers, runs=args.runs, engines=engines,
                          finished_only=finished_only, **lams)


def run_commands(module, scale: str, runs: Path, lams=None) -> str:
    """Each engine run of a figure case at ``scale``: its folder and the command that grows it.

    A run grown by that command into that folder is the sweep's own (``cases.sweep.is_done``
    checks its configuration), so ``--engines finished`` draws from it.
    """
    from cases.sweep import _engine_params, run_name, scale_config

    lines = []
    for engine, lam in select_lams(module.runs_needed(scale)[1], lams):
        params = _engine_params(engine, lam, scale_config(scale))
        sets = " ".join(f"--set {k}={v:g}" if isinstance(v, float) else f"--set {k}={v}"
                        for k, v in params.items() if k not in ("engine", "lam", "radius"))
        lines.append(f"colony {engine} --lam {lam:g} --radius {params['radius']:g} {sets} "
                     f"--out {runs / run_name(params)}")
    return "".join(line + "\n" for line in lines)


def _stage_of(args) -> Path | None:
    """The stage folder of a run command (None for other commands or unusable --out)."""
    out = getattr(args, "out", None)
    if args.command not in ENGINES or not out:
        return None
    path = Path(os.path.abspath(out))
    return partial_of(path) if path.name else None


#: Options whose value is a list that may start with a minus sign (``--strains -1,0``), which
#: argparse would take for an option: given to it as ``--strains=-1,0`` (:func:`_joined`).
LIST_OPTIONS = ("--strains", "--lams")


def _joined(argv: list[str]) -> list[str]:
    """``argv`` with each LIST_OPTIONS option and a value starting with "-" joined by "="."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] in LIST_OPTIONS and i + 1 < len(argv) and argv[i + 1][:1] == "-" \
                and argv[i + 1][1:2] in ".0123456789":
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``colony`` console script; returns the exit status."""
    started = time.monotonic()  # what --max-hours counts from: the imports of a run are work
    args = parser().parse_args(_joined(sys.argv[1:] if argv is None else list(argv)))
    args.started = started
    configure_logging(getattr(args, "quiet", False), getattr(args, "verbose", False))
    with stop_signals_exit():
        return _report(args)


def _report(args) -> int:
    """Run the command; every failure becomes one line on stderr and an exit status."""
    partial = _stage_of(args)

    def holds(name: str) -> bool:  # False also for a stage whose name cannot exist
        try:
            return partial is not None and (partial / name).exists()
        except OSError:
            return False

    def kept() -> str:
        if not any(holds(name) for name in CHECKPOINTS):
            return ""
        return f"; the last checkpoint is kept in {partial}, give the same command to resume"

    try:
        return _dispatch(args)
    except KeyboardInterrupt:
        print(f"colony: interrupted (SIGINT){kept()}", file=sys.stderr)
        return 130
    except RunPaused as paused:
        print(f"colony: {paused}", file=sys.stderr)
        return PAUSED_STATUS
    except SystemExit as err:  # SIGTERM: the engine stopped after a whole step
        if isinstance(err.code, int) and err.code > 128:
            print(f"colony: terminated (signal {err.code - 128}){kept()}", file=sys.stderr)
            return err.code
        raise
    except (ValueError, RuntimeError, OSError) as err:
        message = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        if partial is not None and is_no_space(err, partial if holds(".") else None):
            message = no_space_message(partial.parent)
        if holds(RECORD) and not isinstance(err, RunFolderError):
            message += f" (output so far kept in {partial})"
        print(f"colony: error: {message}", file=sys.stderr)
        return 2


def configure_logging(quiet: bool, verbose: bool) -> None:
    """Route the library modules' ``logging`` records to stderr as ``colony: message``.

    The level is WARNING with --quiet, INFO by default, DEBUG with --verbose.
    """
    level = logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO
    logging.basicConfig(level=level, format="colony: %(message)s", stream=sys.stderr)
    for noisy in ("numba", "matplotlib", "PIL", "distributed", "fsspec", "gsd", "asyncio"):
        logging.getLogger(noisy).setLevel(max(level, logging.WARNING))


if __name__ == "__main__":
    sys.exit(main())
