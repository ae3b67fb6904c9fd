"""How local Green coordinates are on the character: the deviation (of the cage's size,
``storage.deviations.residual_deviations``) left by keeping only each vertex's K largest, the
kept phi renormalised to sum 1 as sparse storage does, for phi and psi together and for
psi alone (every phi kept). Why Green coordinates have no sparse storage: Automatic needs
1e-3 (``bind_plan.AUTO_DEVIATION``).

    .venv/bin/python scripts/benchmarks/green_locality.py [--every 10]
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))

import gencoords  # noqa: E402
from gencoords.storage.deviations import residual_deviations  # noqa: E402
from tests.fixtures.character import body_mesh, character_cage  # noqa: E402

COUNTS = (16, 32, 64, 128, 192, 256, 320)


def kept(coordinates, count, first=0):
    """``coordinates`` (k, r) with only each row's ``count`` largest of columns ``first:``
    kept (the columns before all kept)."""
    part = coordinates[:, first:]
    largest = np.argsort(-np.abs(part), axis=1)[:, :count]
    result = coordinates.copy()
    result[:, first:] = 0.0
    np.put_along_axis(result[:, first:], largest, np.take_along_axis(part, largest, axis=1), axis=1)
    return result


def deviations(coordinates, vertices, triangles, count, first):
    stored = kept(coordinates, count, first)
    n = len(vertices)
    stored[:, :n] /= stored[:, :n].sum(axis=1, keepdims=True)  # translations stay exact
    smooth, drag = residual_deviations(coordinates - stored, vertices, faces=triangles)
    return smooth, float(drag.max())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=int, default=10, help="use every Nth body vertex")
    args = parser.parse_args()
    vertices, quads = character_cage()
    triangles = gencoords.cages.triangulate_quads(vertices, quads)
    points = body_mesh()[0][::args.every]
    phi, psi = gencoords.green_coordinates(points, vertices, triangles, outside="project")
    coordinates = np.hstack([phi, psi])
    print(f"{len(points)} body vertices, {len(vertices)} cage vertices, {len(triangles)} triangles: "
          f"{coordinates.shape[1]} coordinates each")
    print("| K | phi and psi: smooth / drag | psi alone (all phi kept): smooth / drag |")
    print("|---:|---|---|")
    for count in COUNTS:
        both = deviations(coordinates, vertices, triangles, count, 0)
        psi_only = deviations(coordinates, vertices, triangles, min(count, len(triangles)), len(vertices))
        print(f"| {count} | {both[0]:.1e} / {both[1]:.1e} | {psi_only[0]:.1e} / {psi_only[1]:.1e} |")


if __name__ == "__main__":
    main()
