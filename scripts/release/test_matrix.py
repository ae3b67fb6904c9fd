"""Run the whole test suite on several Blender versions (pip ``bpy``), one after another.

Each version is tested by ``make test BLENDER=<version>``, which sets up its own virtual
environment (the Python and numpy that bpy wheel needs), builds and validates the zip
with that version's extension tools and installs it into that Blender. Prints a table of
pass/fail counts and wall times (set-up included) and exits non-zero when any version
fails.

Usage: python scripts/release/test_matrix.py VERSION [VERSION ...]
"""

import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
COUNTS = re.compile(r"(\d+) (passed|failed|error|errors|skipped|xfailed)")
CLOSING = re.compile(r"\d+ (passed|failed|errors?)\b.* in [\d.]+s")  # pytest's closing line


def run(version):
    """(exit code, {outcome: count}, seconds set-up, seconds tests) of one version."""
    start = time.monotonic()
    setup = subprocess.run(["make", "--no-print-directory", "setup", f"BLENDER={version}"],
                           cwd=REPO, check=False)
    set_up = time.monotonic() - start
    if setup.returncode != 0:
        return setup.returncode, {}, set_up, 0.0
    start = time.monotonic()
    process = subprocess.Popen(["make", "--no-print-directory", "test", f"BLENDER={version}"],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    last = ""  # pytest's closing line (make's own error line may follow it)
    for line in process.stdout:  # streamed, so a long run shows progress
        sys.stdout.write(f"[{version}] {line}")
        sys.stdout.flush()
        if CLOSING.search(line):
            last = line
    code = process.wait()
    counts = {kind.rstrip("s") if kind == "errors" else kind: int(number)
              for number, kind in COUNTS.findall(last)}
    return code, counts, set_up, time.monotonic() - start


def main():
    versions = sys.argv[1:]
    if not versions:
        sys.exit(__doc__)
    results = {version: run(version) for version in versions}
    print("\nBlender   result  passed  failed  errors  skipped  set-up s  tests s")
    for version, (code, counts, set_up, tests) in results.items():
        print(f"{version:<9} {'ok' if code == 0 else 'FAIL':<7} {counts.get('passed', 0):>6} "
              f"{counts.get('failed', 0):>7} {counts.get('error', 0):>7} "
              f"{counts.get('skipped', 0):>8} {set_up:>9.0f} {tests:>8.0f}")
    passed = sum(counts.get("passed", 0) for _, counts, *_ in results.values())
    # A version that failed without counting a failure (its set-up, a crash) counts as one.
    failed = sum(max(counts.get("failed", 0) + counts.get("error", 0), int(code != 0))
                 for code, counts, *_ in results.values())
    print(f"matrix: {passed} passed, {failed} failed")
    sys.exit(0 if all(code == 0 for code, *_ in results.values()) else 1)


if __name__ == "__main__":
    main()
