"""Speed and memory of gencoords.coordinates, beside an independent C++ implementation.

Cost is reported per (point x facet) on a 642-vertex icosphere cage (1280 triangles),
beside CGAL's (C++, double, one thread, the cage prepared once) run in the same process
on the same cage and points when its binary is given (scripts/chroot/cgal_reference.sh builds
it), and peak extra memory for a large batch (numpy reports its allocations to
tracemalloc).

    .venv/bin/python scripts/benchmarks/bench_core.py [--points 4000] [--memory-points 200000]
    .venv/bin/python scripts/benchmarks/bench_core.py --cgal build/cgal_reference
    .venv/bin/python scripts/benchmarks/bench_core.py --workers     # 1, 2, 4, ... all cores
    .venv/bin/python scripts/benchmarks/bench_core.py --million     # 1M points, mean value, float32
"""

import os

# One worker is one core, as CGAL's single thread: no BLAS threads beside it (the
# worker processes set the same for themselves).
for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir))  # the repository
import gencoords  # noqa: E402
from gencoords.evaluation.interpreters import available_cores  # noqa: E402
from gencoords.cages.shapes import icosphere  # noqa: E402
from gencoords.surfaces.named import DISCRETE_HARMONIC, MEAN_VALUE, WACHSPRESS  # noqa: E402

# CGAL 6.2 on an earlier 2-core machine of this project (ns per point x facet), shown
# for orientation when no CGAL binary is given; timings from another machine are not
# comparable, so no ratio is printed for them.
CGAL_EARLIER_NS = {WACHSPRESS: 39.0, DISCRETE_HARMONIC: 78.0, MEAN_VALUE: 231.0}


def interior_points(count, radius, seed=0):
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return directions * radius * rng.uniform(0.0, 1.0, size=(count, 1)) ** (1.0 / 3.0)


def best_time(function, repeats):
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def cgal_coordinates(binary, kind, vertices, faces, points, repeats):
    """CGAL's coordinates and best time, by scripts/chroot/cgal_reference.cpp: ((k, n) float, s)."""
    with tempfile.TemporaryDirectory() as folder:
        cage, queries, result = (os.path.join(folder, name) for name in ("cage.off", "points", "out"))
        with open(cage, "w") as off:
            off.write(f"OFF\n{len(vertices)} {len(faces)} 0\n")
            off.writelines(f"{x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
            off.writelines(f"3 {a} {b} {c}\n" for a, b, c in faces.tolist())
        np.ascontiguousarray(points, dtype=np.float64).tofile(queries)
        seconds = float(subprocess.run([binary, kind, cage, queries, str(len(points)), str(repeats), result],
                                       check=True, capture_output=True, text=True).stdout)
        return np.fromfile(result).reshape(len(points), len(vertices)), seconds


def single_worker_table(vertices, faces, points, repeats, cgal=None):
    pairs = len(points) * len(faces)
    source = "same run" if cgal else "earlier machine, not comparable"
    print(f"| kind | CGAL 6.2, 1 thread, ns ({source}) | ours, 1 worker, ns | CGAL / ours (same run) | "
          "max linear precision error | max difference from CGAL |")
    print("|---|---|---|---|---|---|")
    with gencoords.Cage(vertices, faces) as cage:
        for kind in gencoords.advanced.KINDS:
            cage.coordinates(points[:200], kind=kind, workers=1)  # warm up
            seconds = best_time(lambda: cage.coordinates(points, kind=kind, workers=1), repeats)
            ns = seconds / pairs * 1e9
            ours = cage.coordinates(points, kind=kind, workers=1)
            error = np.abs(ours @ vertices - points).max()
            reference, difference = CGAL_EARLIER_NS.get(kind), "-"
            if cgal and kind in CGAL_EARLIER_NS:
                theirs, cgal_seconds = cgal_coordinates(cgal, kind, vertices, faces, points, repeats)
                reference = round(cgal_seconds / pairs * 1e9, 1)
                difference = f"{np.abs(theirs - ours).max():.1e}"
            ratio = f"{reference / ns:.2f}" if cgal and reference else "-"
            print(f"| {kind} | {reference or '-'} | {ns:.1f} | {ratio} | {error:.1e} | {difference} |")


def independent_rate(kind, count, points, repeats):
    """Points per second of ``count`` independent single-process runs at once, each on its
    share of ``points`` points, added up: what the machine allows (shared caches, memory
    bandwidth), whatever the pool."""
    command = [sys.executable, os.path.abspath(__file__), "--independent", kind,
               "--repeats", str(repeats), "--workers-points", str(points // count)]
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, text=True) for _ in range(count)]
    return sum(float(run.communicate()[0]) for run in runs)


def independent_run(kind, count, repeats):
    """One of independent_rate's runs: prints its points per second."""
    vertices, faces = icosphere(3)
    points = interior_points(count, 0.95, seed=3)
    with gencoords.Cage(vertices, faces) as cage:
        cage.coordinates(points[:200], kind=kind, workers=1)
        print(len(points) / best_time(lambda: cage.coordinates(points, kind=kind, workers=1), repeats))


def workers_table(vertices, faces, points, repeats):
    """Throughput for 1, 2, 4, ... workers (and all cores), each kind, beside as many
    independent processes."""
    cores = available_cores()
    counts = sorted({min(2 ** i, cores) for i in range(cores.bit_length() + 1)})
    print(f"\nworkers: {len(points)} points per call, a kept gencoords.Cage (workers started once, "
          f"then reused); points per second and speed-up over one worker; last column: {cores} "
          "independent one-process runs at the same time (the machine's own ceiling)\n")
    print("| kind | " + " | ".join(f"{count} worker{'s' if count > 1 else ''}" for count in counts)
          + f" | {cores} independent |")
    print("|---|" + "---|" * (len(counts) + 1))
    for kind in gencoords.advanced.KINDS:
        cells, single = [], None
        for count in counts:
            with gencoords.Cage(vertices, faces) as cage:
                cage.coordinates(points[:4 * count], kind=kind, workers=count)  # start
                seconds = best_time(lambda: cage.coordinates(points, kind=kind, workers=count), repeats)
            rate = len(points) / seconds
            single = single or rate
            cells.append(f"{rate:,.0f}/s ({rate / single:.2f}x)")
        ceiling = independent_rate(kind, cores, len(points), repeats)
        cells.append(f"{ceiling:,.0f}/s ({ceiling / single:.2f}x)")
        print(f"| {kind} | " + " | ".join(cells) + " |")


def numerical_surfaces_table(repeats):
    """ns per (point x ridge) of ridge scalars: closed forms beside numerical integration."""
    from gencoords.cages.shapes import cross_polytope
    from tests.fixtures.polytopes import random_convex_polytope

    print("\nridge scalars, ns per point x ridge: closed form beside the numerical integral "
          "(ridge_scalars_from_surface with the unit sphere, default levels)\n")
    print("| cage | ridges | mean value, closed form | numerical, default levels | "
          "numerical, levels 3 |")
    print("|---|---|---|---|---|")
    sphere = lambda x, u: np.ones(u.shape[:2])  # noqa: E731
    cages = [("3D icosphere, 162 vertices", *icosphere(2)), ("4D 16-cell", *cross_polytope(4)),
             ("4D hull of 12 points", *random_convex_polytope(np.random.default_rng(1), 4, 12))]
    for name, vertices, faces in cages:
        points = 0.3 * (vertices.mean(axis=0) + np.random.default_rng(2).uniform(-0.2, 0.2, (40, vertices.shape[1])))
        pairs = len(points) * len(gencoords.advanced.ridges(faces))
        closed = best_time(lambda: gencoords.advanced.ridge_scalars(points, vertices, faces, MEAN_VALUE), repeats)
        numerical = best_time(lambda: gencoords.advanced.ridge_scalars_from_surface(points, vertices, faces, sphere), 1)
        coarse = best_time(lambda: gencoords.advanced.ridge_scalars_from_surface(points, vertices, faces, sphere,
                                                                   levels=3), repeats)
        print(f"| {name} | {len(gencoords.advanced.ridges(faces))} | {closed / pairs * 1e9:.0f} | "
              f"{numerical / pairs * 1e9:,.0f} | {coarse / pairs * 1e9:,.0f} |")


def million(vertices, faces):
    """1M points, mean value, float32 result, all cores: wall time and peak memory."""
    points = interior_points(1_000_000, 0.95, seed=2)
    start = time.perf_counter()
    result = gencoords.coordinates(points, vertices, faces, kind=MEAN_VALUE, dtype=np.float32)
    seconds = time.perf_counter() - start
    parent = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 2**10
    error = np.abs(result[::1000].astype(np.float64) @ vertices - points[::1000]).max()
    print(f"\n1,000,000 points x {len(vertices)}-vertex cage, mean value, float32 out, "
          f"{available_cores()} workers: {seconds:.1f} s; result {result.nbytes / 2**20:.0f} MB "
          f"(shared memory, written by the workers); peak resident memory: this process "
          f"{parent:.0f} MB, largest worker {child:.0f} MB (a process's resident memory counts "
          f"the shared pages it wrote: about {result.nbytes / 2**20 / available_cores():.0f} MB "
          f"per worker); linear precision error {error:.1e}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4000)
    parser.add_argument("--memory-points", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", action="store_true", help="the table of worker counts")
    parser.add_argument("--workers-points", type=int, default=40_000)
    parser.add_argument("--million", action="store_true", help="1M points, mean value, float32")
    parser.add_argument("--surfaces", action="store_true", help="numerical ridge scalars' cost")
    parser.add_argument("--cgal", metavar="BINARY", help="scripts/chroot/cgal_reference.cpp, built")
    parser.add_argument("--independent", metavar="KIND", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.independent:
        return independent_run(args.independent, args.workers_points, args.repeats)

    vertices, faces = icosphere(4 - 1)  # 642 vertices
    points = interior_points(args.points, 0.95)
    print(f"$ {' '.join([os.path.basename(sys.executable)] + sys.argv)}")
    print(f"cage: icosphere, {len(vertices)} vertices, {len(faces)} triangles; {len(points)} interior "
          f"points; {os.cpu_count()} cores, {available_cores()} usable\n")
    single_worker_table(vertices, faces, points, args.repeats, args.cgal)
    if args.workers:
        workers_table(vertices, faces, interior_points(args.workers_points, 0.95, seed=3), args.repeats)
    if args.surfaces:
        numerical_surfaces_table(args.repeats)
    if args.million:
        million(vertices, faces)
        return

    many = interior_points(args.memory_points, 0.95, seed=1)
    tracemalloc.start()
    baseline = tracemalloc.get_traced_memory()[0]
    result = gencoords.coordinates(many, vertices, faces, kind=MEAN_VALUE, workers=1)
    peak = tracemalloc.get_traced_memory()[1] - baseline
    tracemalloc.stop()
    print(f"\npeak memory for {len(many)} points (mean value, one worker): {peak / 2**20:.0f} MB, of "
          f"which the (k, n) result is {result.nbytes / 2**20:.0f} MB: working memory "
          f"{(peak - result.nbytes) / 2**20:.0f} MB (budget 256 MB)")


if __name__ == "__main__":
    main()
