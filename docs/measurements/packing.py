"""How densely the initial fills pack: the table of docs/tutorial.md ("Shapes").

Each shape of :data:`TABLE_SHAPES`, filled with particles in both orientations
(:func:`cases.shapes.initial_particles`, seed 0): N, the length packing b sum l / A (1 at the
model's density), the area fraction and the seconds the fill took.

    python docs/measurements/packing.py

Lived in ``cases.shapes`` (``python -m cases.shapes``) until issue 43 moved it here.
"""

from __future__ import annotations

import time

from cases.shapes import initial_particles
from continuum.mesh import polygon_area
from continuum.shapes import outline
from particles.packings import FILL_ORIENTATIONS, packing_fractions

#: Shapes of the packing table (docs/tutorial.md, "Shapes").
TABLE_SHAPES = ("circle:8", "circle:20", "ellipse:8,4", "rectangle:12,3,0.5", "star:3,0.3,8",
                "star:5,0.2,8")


def packing_table(specs=TABLE_SHAPES, seed: int = 0) -> list[dict]:
    """N, the length packing b sum l / A and the area fraction of the fill of each shape.

    For both orientations of particles.packings.fill_outline, with the seconds it took (the
    first call includes Numba's compilation when its cache is cold).
    """
    rows = []
    for spec in specs:
        area = polygon_area(outline(spec))
        for orientation in FILL_ORIENTATIONS:
            start = time.perf_counter()
            state = initial_particles(spec, seed, orientation)
            seconds = time.perf_counter() - start
            phi_l, phi_a = packing_fractions(state.length, area)
            rows.append({"shape": spec, "orientation": orientation, "area": round(area, 2),
                         "N": state.n, "length packing": round(phi_l, 3),
                         "area fraction": round(phi_a, 3),
                         "mean length": round(float(state.length.mean()), 3),
                         "seconds": round(seconds, 2)})
    return rows


def main() -> list[dict]:
    """Print the table (module docstring) as markdown; returns its rows."""
    table = packing_table()
    keys = list(table[0])
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for row in table:
        print("| " + " | ".join(str(row[k]) for k in keys) + " |")
    return table


if __name__ == "__main__":
    main()
