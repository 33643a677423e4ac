"""Records: the small data of a big run kept in the repository, a table of them, comparisons.

A paper-scale particle colony takes hours and is grown by one command, resumed over several
sessions when needed; to join a case's runs it is grown straight into the case's runs folder
under the sweep's name (``colony case NAME --scale paper --print-runs``), where the sweep takes
it as finished when its ``run.json`` says so and its configuration is the sweep's
(``cases.sweep.is_done``). What the repository keeps of it:

1. :func:`record`: its small data copied to ``DATA/lam=LAM/``: the history, every step (about
   190 kB packed at radius 150; records before 2026-12-05 kept every k-th step, which aliases
   the division waves: :func:`thinning_bias`), the final profile, the profile pooled over the
   last frames as the figures draw it (``profile_pooled.csv``,
   ``cases.analysis.final_particle_profile``), the configuration, the ``/usr/bin/time -v``
   reports of its segments, and ``work.csv``: the solver work of every step-policy segment,
   over all steps and over those with N >= 6e4 (``cases.analysis.history_segments``; the sums
   a thinned history cannot give).
2. :func:`table`: the recorded one-command runs (those with ``work.csv``) as a Markdown table:
   size, time, steps, wall and CPU time, memory, overlap, solver work (:func:`summary`).
3. :func:`compare`: two records of one lam (e.g. a colony and the one it replaces, the earlier
   taken from git) side by side: size and time at radius 150, the first times at radii 50,
   100 and 150, the central stress and the mean differences of the final profiles.
4. :func:`thinning_table`: what thinning a full history would do to the whole colony's
   stress averaged over the last division period (:func:`thinning_bias`; why a record keeps
   every step).
5. :func:`make_whole`: an older record's thinned history replaced by every step of the same
   colony (:func:`same_colony`), where one exists.

Command line::

    python docs/measurements/records.py RUN [--data cases/data/particles_paper] [--time-log LOG]
        [--log PROGRESS_LOG]
    python docs/measurements/records.py --table [--data cases/data/particles_paper]
    python docs/measurements/records.py --compare OLD NEW [OLD NEW ...]
    python docs/measurements/records.py --thinning RUN [RUN ...]
    python docs/measurements/records.py --make-whole RECORD HISTORY

Nothing is written when a check fails (a one-line error, exit status 2).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.rundir import read_record, replace_file
from cases.studies import ensemble as E

__all__ = ["compare", "compare_table", "make_whole", "record", "same_colony", "summary",
           "table", "thinning_bias", "thinning_table", "time_reports"]

SMALL_FILES = ("profile.csv", "config.json")
"""Files copied as they are by :func:`record` (besides the history)."""

WORK_MIN_PARTICLES = (0, 60_000)
"""``work.csv`` holds the segments' solver work over all steps and over N >= 6e4."""


def time_reports(text: str, lines: int = 23) -> str:
    """The first ``lines`` lines of every ``/usr/bin/time -v`` report in ``text``.

    These are the command, CPU and wall time and memory, one report after the other.
    """
    blocks = text.split("\tCommand being timed")[1:]
    return "".join("\tCommand being timed" + "\n".join(b.splitlines()[:lines]) + "\n"
                   for b in blocks)


def same_colony(record: dict[str, np.ndarray], whole: dict[str, np.ndarray]) -> bool:
    """Whether every row of ``record`` is ``whole``'s row of the same step (8 digits)."""
    at = np.searchsorted(whole["step"], record["step"])
    if at[-1] >= whole["step"].size or np.any(whole["step"][at] != record["step"]):
        return False
    return all(np.allclose(whole[k][at], record[k], rtol=1e-7, atol=0)
               for k in ("t", "radius", "n_particles", "mean_stress", "max_stress"))


def make_whole(dest: str | Path, history: str | Path) -> Path:
    """Give the record ``dest`` (``DATA/lam=LAM``) of a thinned history its whole history.

    ``history``: every step of the same colony, from a run grown on (colony_260's) or grown
    again by an engine that reproduces it; taken up to the record's last step, after
    :func:`same_colony` checks every recorded row. Raises ValueError when it is another colony.
    """
    dest = Path(dest)
    record = A.read_csv(dest / "history.csv")
    whole = A.read_csv(history)
    if not same_colony(record, whole):
        raise ValueError(f"{history} is not the history of {dest}'s colony")
    last = int(np.searchsorted(whole["step"], record["step"][-1]))

    def write(fh):  # the CSV of write_csv, replacing the record's at once (replace_file)
        with tempfile.TemporaryDirectory() as tmp:
            path = A.write_csv(Path(tmp) / "history.csv",
                               {k: v[:last + 1] for k, v in whole.items()})
            fh.write(path.read_bytes())

    replace_file(dest, "history.csv", write)
    return dest


def thinning_bias(history: dict[str, np.ndarray], lam: float) -> dict[str, float]:
    """What thinning does to the final cycle-mean stress ratio r = mean stress / continuum's.

    ``full``: r - 1 of the whole history (``cases.studies.ensemble.mean_stress_ratio``),
    ``thinned``: of ``thin_rows(history)`` (every k-th row from the first: the records before
    2026-12-05) less ``full``, ``lowest`` and ``highest``: that difference over
    the k phases (rows o, o + k, ... and the last, o < k), ``stride``: k.
    """
    n = len(history["t"])
    rows = A.thin_rows({"row": np.arange(n)})["row"]  # 0, k, 2k, ... and n - 1
    k = int(rows[1] - rows[0]) if rows.size > 1 else 1

    def final(idx):
        h = {c: np.asarray(v)[idx] for c, v in history.items()}
        return float(E.mean_stress_ratio(h, lam)["cycle"][-1]) - 1.0

    full = final(np.arange(n))
    phases = [final(np.unique(np.minimum(rows + o, n - 1))) - full for o in range(k)]
    return {"stride": k, "full": full, "thinned": phases[0], "lowest": min(phases),
            "highest": max(phases)}


def thinning_table(runs: list[Path]) -> str:
    """:func:`thinning_bias` of the histories of run folders, a Markdown table (points)."""
    lines = ["| run | lam | rows | stride | r - 1, whole history | thinned - whole, points "
             "| over the phases |", "|---|---|---|---|---|---|---|"]
    for run in runs:
        lam = float(json.loads((run / "config.json").read_text())["lam"])
        h = A.read_csv(run / "history.csv")
        b = thinning_bias(h, lam)
        lines.append(f"| {run} | {lam:g} | {len(h['t'])} | {b['stride']} | "
                     f"{100 * b['full']:+.2f} % | {100 * b['thinned']:+.2f} | "
                     f"{100 * b['lowest']:+.2f} to {100 * b['highest']:+.2f} |")
    return "\n".join(lines) + "\n"


def record(run: str | Path, data: str | Path, time_log: str | Path | None = None,
           progress_log: str | Path | None = None) -> Path:
    """Copy the small data of the finished run ``run`` to ``data/lam=LAM/`` (module docstring).

    ``progress_log``: the command's stderr (its progress lines, one a minute), copied as
    ``progress.log`` and timing the stretches of ``work.csv`` (wall_s, ms_per_iteration:
    ``cases.analysis.history_segments``).  Returns that folder.
    """
    run = Path(run)
    lam = float(json.loads((run / "config.json").read_text())["lam"])
    dest = Path(data) / f"lam={lam:g}"
    dest.mkdir(parents=True, exist_ok=True)
    A.write_csv(dest / "history.csv", A.read_csv(run / "history.csv"))  # every step
    wall = A.progress_wall(progress_log) if progress_log is not None else None
    work = [{"min_particles": n, **row} for n in WORK_MIN_PARTICLES
            for row in A.history_segments(run, n, wall=wall)]
    if work:
        A.write_csv(dest / "work.csv",
                    {k: [row[k] for row in work] for k in work[0] if k != "run"})
    for f in SMALL_FILES:
        if (run / f).is_file():
            shutil.copy(run / f, dest / f)
    if (run / "trajectory.gsd").is_file():  # the figures' profile: pooled over the last frames
        A.write_csv(dest / "profile_pooled.csv", A.final_particle_profile(run, growth_window=1.0))
    if time_log is not None:
        (dest / "time.txt").write_text(time_reports(Path(time_log).read_text()))
    if progress_log is not None:
        shutil.copy(progress_log, dest / "progress.log")
    return dest


TIME_FIELDS = {"wall": r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)",
               "user": r"User time \(seconds\): (\S+)",
               "peak_kb": r"Maximum resident set size \(kbytes\): (\d+)"}
"""What :func:`summary` reads from each ``/usr/bin/time -v`` report of ``time.txt``."""


def _seconds(clock: str) -> float:
    """Seconds of a ``time -v`` wall clock, ``h:mm:ss`` or ``m:ss.ss``."""
    out = 0.0
    for part in clock.split(":"):
        out = 60 * out + float(part)
    return out


def summary(dest: str | Path) -> dict:
    """The record ``dest = DATA/lam=LAM/`` of one recorded run, in one row.

    lam, the final particles, t and step (history), halved steps, largest overlap, iterations
    per unit time and failed share over all steps and over N >= 6e4 (``work.csv``; one segment
    each: a run of one command), and the wall and user CPU seconds and peak memory of its
    ``time -v`` reports (summed, summed and largest; ``reports``: how many).

    Raises
    ------
    ValueError
        No ``work.csv``, or one with several segments per size threshold.
    """
    dest = Path(dest)
    if not (dest / "work.csv").is_file():
        raise ValueError(f"{dest}: no work.csv (not recorded with docs/measurements/records.py)")
    work = A.read_csv(dest / "work.csv")
    n_min = list(work["min_particles"])
    if len(set(n_min)) != len(n_min):
        raise ValueError(f"{dest}/work.csv: several step-policy segments (not one command)")
    h = A.read_csv(dest / "history.csv")
    row = {"lam": float(json.loads((dest / "config.json").read_text())["lam"]),
           "particles": int(h["n_particles"][-1]), "t": float(h["t"][-1]),
           "steps": int(h["step"][-1])}
    for k, n in zip(("all", "large"), WORK_MIN_PARTICLES, strict=True):
        i = n_min.index(n) if n in n_min else None
        for col in ("per_time", "failed_share"):
            row[f"{col}_{k}"] = float(work[col][i]) if i is not None else float("nan")
        if k == "all":
            row |= {"halved": int(work["halved"][i]), "max_overlap": float(work["max_overlap"][i])}
    text = (dest / "time.txt").read_text() if (dest / "time.txt").is_file() else ""
    found = {k: re.findall(pattern, text) for k, pattern in TIME_FIELDS.items()}
    row |= {"reports": len(found["wall"]),
            "wall_s": sum(_seconds(v) for v in found["wall"]),
            "user_s": sum(float(v) for v in found["user"]),
            "peak_mb": max((int(v) for v in found["peak_kb"]), default=0) / 1000}
    return row


def _clock(seconds: float) -> str:
    """h:mm:ss of a number of seconds."""
    s = round(seconds)
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def table(data: str | Path) -> str:
    """Markdown table of :func:`summary` for every ``lam=LAM/`` of ``data`` with a work.csv."""
    rows = sorted((summary(d) for d in Path(data).glob("lam=*") if (d / "work.csv").is_file()),
                  key=lambda r: r["lam"])
    lines = ["| lam | particles at R = 150 | t | steps | halved | wall (time -v) | user CPU | "
             "peak memory | max overlap | iterations per unit time: all / N >= 6e4 | "
             "failed share: all / N >= 6e4 |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        wall = _clock(r["wall_s"]) + (f" ({r['reports']} reports)" if r["reports"] > 1 else "")
        lines.append(
            f"| {r['lam']:g} | {r['particles']:,} | {r['t']:.2f} | {r['steps']} | {r['halved']} "
            f"| {wall} | {r['user_s'] / 60:.0f} min | {r['peak_mb']:.0f} MB "
            f"| {r['max_overlap']:.4g} | {r['per_time_all']:.2g} / {r['per_time_large']:.2g} "
            f"| {100 * r['failed_share_all']:.1f} % / {100 * r['failed_share_large']:.1f} % |")
    return "\n".join(lines) + "\n"


COMPARE_RADII = (50.0, 100.0, 150.0)
"""Radii at which :func:`compare` reports the first time the colony reaches them."""


def _filled_annuli(profile: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The annuli of a profile with finite stress and mean length (an empty annulus has nan)."""
    keep = np.isfinite(profile["stress"]) & np.isfinite(profile["mean_length"])
    return {k: v[keep] for k, v in profile.items()}


def compare(old: str | Path, new: str | Path) -> dict:
    """Two records ``DATA/lam=LAM/`` of one lam compared (the earlier ``old``, the later ``new``).

    Returns, for each of old and new, the final particles and t, the first times t(R) at
    :data:`COMPARE_RADII` (``statistics.time_at_radius``) and the central stress p0 of the
    final profile (``profile_central_stress``, fit); and the differences of the final profiles
    on the old one's annuli over the radii both cover (the new profile linearly interpolated;
    empty annuli left out),
    as means over the annuli relative to the old profile's mean::

        d_stress = mean |s_new - s_old| / mean s_old,   d_length likewise for mean_length.

    Raises
    ------
    ValueError
        The two records are of different lam.
    """
    rec = {}
    for key, d in (("old", Path(old)), ("new", Path(new))):
        h = A.read_csv(d / "history.csv")
        prof = A.read_csv(d / "profile.csv")
        rec[key] = {"lam": float(json.loads((d / "config.json").read_text())["lam"]),
                    "particles": int(h["n_particles"][-1]), "t": float(h["t"][-1]),
                    "t_at": A.time_at_radius(h["t"], h["radius"], np.array(COMPARE_RADII)),
                    "p0": A.profile_central_stress(prof, float(h["radius"][-1]))["central_fit"],
                    "profile": prof}
    if rec["old"]["lam"] != rec["new"]["lam"]:
        raise ValueError(f"{old} and {new} hold different lam: {rec['old']['lam']:g}, "
                         f"{rec['new']['lam']:g}")
    po, pn = (_filled_annuli(rec[key].pop("profile")) for key in ("old", "new"))
    inside = (po["r"] >= pn["r"][0]) & (po["r"] <= pn["r"][-1])
    diff = {}
    for name in ("stress", "mean_length"):
        moved = np.interp(po["r"][inside], pn["r"], pn[name]) - po[name][inside]
        diff[f"d_{name}"] = float(np.mean(np.abs(moved)) / np.mean(po[name][inside]))
    return {"lam": rec["old"]["lam"], "old": rec["old"], "new": rec["new"], **diff}


def compare_table(pairs: list[tuple[Path, Path]]) -> str:
    """Markdown table of :func:`compare` for (old, new) record pairs, a row each."""
    head = ("| lam | particles old / new | t old / new | "
            + " | ".join(f"t(R = {r:g}) old / new" for r in COMPARE_RADII)
            + " | central stress p0 old / new | mean profile change: stress, mean length |")
    lines = [head, "|" + "---|" * (5 + len(COMPARE_RADII))]
    for old, new in pairs:
        c = compare(old, new)
        o, n = c["old"], c["new"]
        times = " | ".join(f"{a:.3f} / {b:.3f}" for a, b in zip(o["t_at"], n["t_at"], strict=True))
        lines.append(f"| {c['lam']:g} | {o['particles']:,} / {n['particles']:,} "
                     f"| {o['t']:.3f} / {n['t']:.3f} | {times} | {o['p0']:.4g} / {n['p0']:.4g} "
                     f"| {100 * c['d_stress']:.1f} %, {100 * c['d_mean_length']:.1f} % |")
    return "\n".join(lines) + "\n"


def _history_command(make: list[Path] | None, thinning: list[Path] | None) -> str:
    """What ``--make-whole RECORD HISTORY`` and ``--thinning RUN ...`` do and print.

    ValueError on a missing file or (:func:`make_whole`) another colony's history.
    """
    needed = ([(make[0], "history.csv"), (make[1], "")] if make else []) + [
        (r, f) for r in thinning or () for f in ("history.csv", "config.json")]
    for folder, name in needed:
        if not (folder / name if name else folder).is_file():
            raise ValueError(f"no file {folder / name if name else folder}")
    if make:
        make_whole(*make)
        return f"{make[0]}/history.csv: every step, from {make[1]}\n"
    return thinning_table(thinning)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python docs/measurements/records.py",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("run", type=Path, nargs="?",
                   help="finished run folder (colony particles --out) to record")
    p.add_argument("--table", action="store_true",
                   help="print the table of the recorded one-command runs in --data")
    p.add_argument("--data", type=Path, default=Path("cases/data/particles_paper"),
                   help="small data go to DATA/lam=LAM (default cases/data/particles_paper)")
    p.add_argument("--time-log", type=Path, default=None,
                   help="the run's /usr/bin/time -v -a -o log")
    p.add_argument("--log", type=Path, default=None,
                   help="the run's progress log (its stderr), kept as progress.log")
    p.add_argument("--compare", type=Path, nargs="+", metavar="OLD NEW",
                   help="compare records DATA/lam=LAM in pairs OLD NEW (a table)")
    p.add_argument("--make-whole", type=Path, nargs=2, metavar=("RECORD", "HISTORY"),
                   help="replace the thinned history of RECORD by HISTORY, every step of the "
                        "same colony (checked)")
    p.add_argument("--thinning", type=Path, nargs="+", metavar="RUN",
                   help="what thinning the histories of these run folders does to their "
                        "final cycle-mean stress (a table)")
    args = p.parse_args(argv)
    if args.table:
        print(table(args.data), end="")
        return 0
    try:
        if args.make_whole is not None or args.thinning is not None:
            print(_history_command(args.make_whole, args.thinning), end="")
            return 0
        if args.compare is not None:
            if len(args.compare) % 2:
                p.error("--compare takes pairs of record folders: OLD NEW [OLD NEW ...]")
            missing = [d for d in args.compare
                       for f in ("history.csv", "profile.csv", "config.json")
                       if not (d / f).is_file()]
            if missing:
                raise ValueError(f"{missing[0]} is not a record (history.csv, profile.csv, "
                                 "config.json)")
            pairs = list(zip(args.compare[::2], args.compare[1::2], strict=True))
            print(compare_table(pairs), end="")
            return 0
        if args.run is None:
            p.error("give a RUN folder, --table or --compare")
        record_of_run = read_record(args.run)
        if record_of_run is None or record_of_run.get("status") != "finished":
            raise ValueError(f"{args.run} is not a finished run folder of colony (run.json)")
        for log in (args.time_log, args.log):
            if log is not None and not log.is_file():
                raise ValueError(f"no log file {log}")
    except ValueError as err:
        print(f"records: error: {err}", file=sys.stderr)
        return 2
    dest = record(args.run, args.data, args.time_log, args.log)
    h = A.read_csv(args.run / "history.csv")
    last = ", ".join(f"{k} = {h[k][-1]:.6g}" for k in ("t", "radius", "n_particles") if k in h)
    print(f"recorded {args.run} ({last}) in {dest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
