"""Where the power family's coordinates stay positive: a table over gamma and polytopes.

For regular and irregular convex polytopes in 2D, 3D and 4D, the smallest coordinate
of gencoords.reports.coordinate_report's interior sample (dense near the boundary) for each gamma,
and the range of gamma where none is negative. Figures for docs/POWER.md:

    .venv/bin/python scripts/pictures/power_positivity.py [--samples 3000] [--step 0.25]
        [--picture docs/power.png]
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir))  # the repository
import gencoords  # noqa: E402
from gencoords.cages.shapes import (cross_polytope, icosphere, irregular_octahedron, octahedron,  # noqa: E402
                                    regular_polygon)
from gencoords.surfaces.named import POWER  # noqa: E402
from scripts.common.png import write_png  # noqa: E402
from tests.fixtures.polytopes import random_convex_polytope  # noqa: E402


def polytopes():
    """(name, vertices, faces) of the regular and irregular test polytopes."""
    rng = np.random.default_rng(7)
    yield ("2D regular hexagon", *regular_polygon(6))
    yield ("2D irregular 9-gon", *random_convex_polytope(rng, 2, 9))
    yield ("3D regular octahedron", *octahedron())
    yield ("3D regular icosahedron", *icosphere(0))
    yield ("3D irregular octahedron (paper fig. 10)", *irregular_octahedron())
    yield ("3D irregular 14 vertices", *random_convex_polytope(rng, 3, 14))
    yield ("4D regular 16-cell", *cross_polytope(4))
    yield ("4D irregular 10 vertices", *random_convex_polytope(rng, 4, 10))


def positive_ranges(gammas, smallest):
    """The runs of consecutive gammas whose smallest coordinate is >= 0, as text."""
    positive = smallest >= -gencoords.base.tolerances.NEGATIVE
    runs, start = [], None
    for index, flag in enumerate(list(positive) + [False]):
        if flag and start is None:
            start = index
        elif not flag and start is not None:
            low = "..." if start == 0 else f"{gammas[start]:g}"
            high = "..." if index == len(gammas) else f"{gammas[index - 1]:g}"
            runs.append(f"{low}" if low == high else f"[{low}, {high}]")
            start = None
    return ", ".join(runs) or "none"


def field_picture(path, gammas=(-1.0, -0.5, 0.0, 0.5, 1.0, 2.0), pixels=220):
    """The coordinate of one vertex (the marked dot) across a regular hexagon and an
    irregular polygon, one panel per gamma, in the add-on's colours (viridis; pink to
    red below zero): the style of the paper's figures 9 to 11."""
    irregular = np.array([[0.0, 0.0], [2.2, -0.6], [4.4, 0.4], [4.6, 1.5], [2.0, 2.6], [0.3, 2.0]])
    edges = np.stack([np.arange(6), (np.arange(6) + 1) % 6], axis=1)
    rows = []
    for vertices, faces in (regular_polygon(6), (irregular, edges)):
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        pad = 0.04 * (high - low).max()
        axis = np.linspace(0.0, 1.0, pixels)
        grid = np.stack(np.meshgrid(low[0] - pad + axis * (high[0] - low[0] + 2 * pad),
                                    high[1] + pad - axis * (high[1] - low[1] + 2 * pad)), axis=-1)
        points = grid.reshape(-1, 2)
        inside = gencoords.point_locations(points, vertices, faces) == gencoords.INSIDE
        marked = np.linalg.norm(points - vertices[0], axis=1) < 0.03 * (high - low).max()
        panels = []
        for gamma in gammas:
            image = np.ones((len(points), 3))
            values = gencoords.coordinates(points[inside], vertices, faces, kind=POWER, gamma=gamma)[:, 0]
            image[inside] = gencoords.reports.field_colors(values)[:, :3]
            image[marked] = 0.0
            panels.append(image.reshape(pixels, pixels, 3))
            panels.append(np.ones((pixels, 6, 3)))
        rows.append(np.concatenate(panels[:-1], axis=1))
        rows.append(np.ones((6, rows[-1].shape[1], 3)))
    write_png(path, np.concatenate(rows[:-1], axis=0))
    print(f"\ncoordinate of the marked vertex for gamma = {', '.join(f'{g:g}' for g in gammas)} "
          f"(left to right) -> {path}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=3000)
    parser.add_argument("--step", type=float, default=0.25)
    parser.add_argument("--low", type=float, default=-3.0)
    parser.add_argument("--high", type=float, default=3.0)
    parser.add_argument("--picture", help="also write the field picture (PNG) here")
    args = parser.parse_args()
    gammas = np.round(np.arange(args.low, args.high + args.step / 2, args.step), 6)
    shown = [g for g in gammas if float(g).is_integer() or g in (-0.5, 0.5)]
    print(f"$ {' '.join([os.path.basename(sys.executable)] + sys.argv)}")
    print(f"smallest coordinate over {args.samples} interior points (half within 1e-3 of the "
          f"boundary), gamma from {args.low:g} to {args.high:g} in steps of {args.step:g}\n")
    print("| polytope | positive for gamma in | " + " | ".join(f"gamma {g:g}" for g in shown) + " |")
    print("|---|---|" + "---|" * len(shown))
    for name, vertices, faces in polytopes():
        smallest = np.array([gencoords.reports.coordinate_report(vertices, faces, POWER, gamma=float(g),
                                                    samples=args.samples).smallest for g in gammas])
        cells = [f"{smallest[list(gammas).index(g)]:.2g}" for g in shown]
        print(f"| {name} | {positive_ranges(gammas, smallest)} | " + " | ".join(cells) + " |")
    if args.picture:
        field_picture(args.picture)


if __name__ == "__main__":
    main()
