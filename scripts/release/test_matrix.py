"""Run the whole test suite on several Blender versions (pip ``bpy``), side by side.

Each version is tested by ``make test BLENDER=<version>``, which sets up its own virtual
environment (the Python and numpy that bpy wheel needs), builds and validates the zip
with that version's extension tools and installs it into that Blender. The set-ups run
one after another (each installs the core editable into the same source tree); each
version's tests start as soon as its set-up is done, ``--jobs`` at a time (default: the
number of CPUs). The tests that need no Blender (``-m "not blender"``: the core, the
layout) run once per Python and numpy pair (``make environment``): a later version with
the same pair runs only the Blender tests (``PYTEST_ADDOPTS=-m blender``), which the
table says. Prints a table of pass/fail counts and wall times and exits non-zero when any
version fails.

Usage: python scripts/release/test_matrix.py [--jobs N] VERSION [VERSION ...]
"""

import argparse
import os
import re
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
COUNTS = re.compile(r"(\d+) (passed|failed|error|errors|skipped|xfailed)")
CLOSING = re.compile(r"\d+ (passed|failed|errors?)\b.* in [\d.]+s")  # pytest's closing line
PRINTING = threading.Lock()  # one whole line at a time from the runs side by side


def set_up(version):
    """(exit code, seconds) of ``make setup`` for one version."""
    start = time.monotonic()
    code = subprocess.run(["make", "--no-print-directory", "setup", f"BLENDER={version}"],
                          cwd=REPO, check=False).returncode
    return code, time.monotonic() - start


def environment(version):
    """``Python X.Y.Z numpy A.B.C`` of a set-up version's environment: str."""
    return subprocess.run(["make", "--no-print-directory", "-s", "environment", f"BLENDER={version}"], cwd=REPO,
                          check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]


def test(version, blender_only=False):
    """(exit code, {outcome: count}, seconds) of ``make test`` for one version; with
    ``blender_only`` the tests that need Blender alone."""
    start = time.monotonic()
    variables = dict(os.environ)
    if blender_only:
        variables["PYTEST_ADDOPTS"] = " ".join(filter(None, [variables.get("PYTEST_ADDOPTS"), "-m blender"]))
    process = subprocess.Popen(["make", "--no-print-directory", "test", f"BLENDER={version}"], cwd=REPO, env=variables,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    last = ""  # pytest's closing line (make's own error line may follow it)
    for line in process.stdout:  # streamed, so a long run shows progress
        with PRINTING:
            sys.stdout.write(f"[{version}] {line}")
            sys.stdout.flush()
        if CLOSING.search(line):
            last = line
    code = process.wait()
    counts = {kind.rstrip("s") if kind == "errors" else kind: int(number)
              for number, kind in COUNTS.findall(last)}
    return code, counts, time.monotonic() - start


def run_matrix(versions, jobs):
    """{version: (exit code, counts, seconds set-up, seconds tests)}, and {version: the
    earlier version whose run had its tests that need no Blender}."""
    results, tests, environments, shared = {}, {}, {}, {}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for version in versions:
            code, seconds = set_up(version)
            results[version] = (code, {}, seconds, 0.0)
            if code == 0:
                first = environments.setdefault(environment(version), version)
                if first != version:
                    shared[version] = first
                tests[version] = pool.submit(test, version, version in shared)
        for version, future in tests.items():
            code, counts, seconds = future.result()
            results[version] = (code, counts, results[version][2], seconds)
    return results, shared


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="versions tested at once (default: the number of CPUs)")
    parser.add_argument("versions", nargs="+")
    arguments = parser.parse_args()
    start = time.monotonic()
    results, shared = run_matrix(arguments.versions, max(1, arguments.jobs))
    print("\nBlender   result  passed  failed  errors  skipped  set-up s  tests s")
    for version, (code, counts, seconds_set_up, seconds_tests) in results.items():
        note = f"  (Blender tests; the others ran with {shared[version]}'s Python and numpy)" if version in shared else ""
        print(f"{version:<9} {'ok' if code == 0 else 'FAIL':<7} {counts.get('passed', 0):>6} "
              f"{counts.get('failed', 0):>7} {counts.get('error', 0):>7} "
              f"{counts.get('skipped', 0):>8} {seconds_set_up:>9.0f} {seconds_tests:>8.0f}{note}")
    passed = sum(counts.get("passed", 0) for _, counts, *_ in results.values())
    # A version that failed without counting a failure (its set-up, a crash) counts as one.
    failed = sum(max(counts.get("failed", 0) + counts.get("error", 0), int(code != 0))
                 for code, counts, *_ in results.values())
    print(f"matrix: {passed} passed, {failed} failed, {time.monotonic() - start:.0f} s in all "
          f"({arguments.jobs} at a time)")
    sys.exit(0 if all(code == 0 for code, *_ in results.values()) else 1)


if __name__ == "__main__":
    main()
