"""One fuzz process: install the built extension, then play the cases of the seeds given,
each from an empty file, checking the invariants after every step.

    python scripts/fuzz/blender_case.py ZIP FOLDER SEED [SEED ...] [--verbose]

``run.py`` starts it (a throw-away Blender user folder in BLENDER_USER_RESOURCES, a
timeout); it prints one ``RESULT <json>`` line per case: "pass", "fail" (an invariant:
the step, the invariant, what was seen) or "error" (the fuzz's own code failed).
"""

import contextlib
import json
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

import bpy  # noqa: E402

from scripts.fuzz import cases, checks, scene, steps  # noqa: E402


class Captured:
    text = ""


@contextlib.contextmanager
def captured():
    """What Blender and Python print during the block (file descriptors 1 and 2), in
    ``.text`` afterwards: reports, tracebacks printed by handlers."""
    holder = Captured()
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield holder
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            sink.seek(0)
            holder.text = sink.read().decode("utf-8", "replace")


def play(seed, folder, verbose=False):
    """The case of ``seed``: a dict for the RESULT line."""
    case = cases.case_of(seed)
    outcomes, started = [], time.perf_counter()
    result = {"seed": seed, "status": "pass", "outcomes": outcomes}
    number = -1
    try:
        with captured() as output:
            bpy.ops.wm.read_homefile(use_empty=True)
            state = steps.CaseState(scene.build(case["scene"], seed), folder)
        checks.check_output(output.text)
        for number, step in enumerate(case["steps"]):
            try:
                with captured() as output:
                    outcomes.append(steps.run(state, step))
            finally:
                if verbose:
                    outcome = outcomes[number] if len(outcomes) > number else "(raised)"
                    print(f"--- step {number} {step['op']}: {outcome}\n{output.text}", end="", flush=True)
            checks.check_output(output.text)
            checks.check_finite()
            checks.check_panel()
    except checks.Violation as violation:
        result.update(status="fail", step=number, invariant=violation.invariant, message=str(violation))
    except Exception:  # the fuzz's own code
        result.update(status="error", step=number, invariant="fuzz code", message=traceback.format_exc())
    result["seconds"] = round(time.perf_counter() - started, 2)
    return result


def main(arguments):
    verbose = "--verbose" in arguments
    arguments = [a for a in arguments if a != "--verbose"]
    zip_path, folder, seeds = arguments[0], arguments[1], [int(s) for s in arguments[2:]]
    with captured():
        installed = bpy.ops.extensions.package_install_files(
            filepath=zip_path, repo="user_default", enable_on_install=True)
    if 'FINISHED' not in installed or not hasattr(bpy.types.Object, "gencoords"):
        raise SystemExit(f"installing {zip_path} failed: {installed}")
    for seed in seeds:
        print("START", seed, flush=True)
        print("RESULT " + json.dumps(play(seed, folder, verbose)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
