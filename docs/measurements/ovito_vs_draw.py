"""OVITO's rendering of a trajectory frame beside the project's drawing of the same frame.

The picture of README ("Pictures": docs/figures/ovito_vs_draw.png): ``trajectory.gsd`` opened
by OVITO (``cases.viewer.render_ovito``: import_file, colour coding, Tachyon) and drawn by
``cases.figures.draw.draw_particles``, coloured by length on [1, 2]. Needs the ``viz`` extra::

    python docs/measurements/ovito_vs_draw.py RUN/trajectory.gsd docs/figures/ovito_vs_draw.png

Lived in ``cases.viewer`` until issue 43 moved it here.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from cases.figures.draw import draw_particles  # noqa: E402
from cases.viewer import render_ovito  # noqa: E402
from particles.output import count_frames, read_trajectory  # noqa: E402


def ovito_vs_draw(path: str | Path, png: str | Path, ovito_png: str | Path | None = None,
                  frame: int = -1, size: int = 480) -> Path:
    """OVITO's picture of frame ``frame`` of ``path`` beside draw_particles'; returns ``png``.

    ``ovito_png``: where OVITO's own picture goes (default: beside ``png``, suffix _ovito).
    """
    png = Path(png)
    ovito_png = Path(ovito_png) if ovito_png else png.with_name(png.stem + "_ovito.png")
    k = frame % count_frames(path)
    render_ovito(path, ovito_png, frame=k, size=(size, size))
    (fr,) = read_trajectory(path, frames=[k])
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 5.2))
    a.imshow(plt.imread(ovito_png))
    a.set_axis_off()
    a.set_title("OVITO (import_file + colour coding, Tachyon)")
    draw_particles(fr.x, fr.y, fr.theta, fr.length, ax=b)
    b.set_title("cases.figures.draw.draw_particles")
    t = f", t = {fr.t:.3g}" if math.isfinite(fr.t) else ""
    fig.suptitle(f"same frame (step {fr.step}{t}, N = {fr.n}), coloured by length on [1, 2]")
    fig.savefig(png, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return png


def main(argv: list[str] | None = None) -> None:
    """The command line: a trajectory, the picture to write, ``--frame``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trajectory", help="a trajectory.gsd")
    ap.add_argument("png", help="the picture to write")
    ap.add_argument("--frame", type=int, default=-1, help="frame index (default: the last)")
    args = ap.parse_args(argv)
    print(ovito_vs_draw(args.trajectory, args.png, frame=args.frame))


if __name__ == "__main__":
    main()
