"""The seeded operator fuzz: random bad cages and meshes, random operator sequences, the
invariants checked after every step (``cases``, ``steps``, ``checks``).

    python scripts/fuzz/run.py --cases 200            # seeds 0..199 (make fuzz CASES=200)
    python scripts/fuzz/run.py --first-seed 1000 --cases 50 --jobs 2
    python scripts/fuzz/run.py --replay 123           # one case, with everything it printed

Each case plays in its own fresh Python with pip bpy (``blender_case.py``), the built
extension installed into a throw-away user folder, under a timeout, so a crash or a hang
belongs to one seed. Every failing case is printed with its steps and the command that
replays it; the exit status is 1 when one failed.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from scripts.common import session  # noqa: E402
from scripts.fuzz import cases  # noqa: E402

CASE_SCRIPT = Path(__file__).resolve().parent / "blender_case.py"
TIMEOUT = 120  # seconds a case may take, start-up included


def replay_command(seed):
    return f"python scripts/fuzz/run.py --replay {seed}   (or: make fuzz SEED={seed})"


def play(seeds, timeout=TIMEOUT, verbose=False, zip_path=None):
    """Play ``seeds`` in one fresh process with the extension ``zip_path`` (default: the
    built one); returns a result dict per seed (a crash or a hang is the result of the seed
    that was playing; the seeds after it are played again in another process)."""
    zip_path = zip_path or session.extension_zip(rebuild_if_stale=False)
    results, pending = [], list(seeds)
    while pending:
        folder = tempfile.mkdtemp(prefix="gencoords-fuzz-")
        try:
            reported, playing, status = _run_process(zip_path, pending, folder, timeout * len(pending),
                                                     verbose)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        results += reported
        done = {r["seed"] for r in reported}
        if playing is not None and playing not in done:
            results.append({"seed": playing, "status": "fail", "invariant": "no crash or hang",
                            "message": status, "step": None, "outcomes": []})
            done.add(playing)
        remaining = [s for s in pending if s not in done]
        if len(remaining) == len(pending):  # nothing played: the process could not start
            results += [{"seed": s, "status": "error", "invariant": "fuzz start", "message": status,
                         "step": None, "outcomes": []} for s in remaining]
            break
        pending = remaining
    return results


def _run_process(zip_path, seeds, folder, timeout, verbose):
    environment = dict(os.environ, BLENDER_USER_RESOURCES=str(Path(folder) / "user"))
    command = [sys.executable, str(CASE_SCRIPT), str(zip_path), folder, *map(str, seeds)] + \
        (["--verbose"] if verbose else [])
    reported, playing, lines = [], None, []
    with subprocess.Popen(command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, cwd=REPO) as process:
        deadline = time.monotonic() + timeout
        try:
            output, _ = process.communicate(timeout=max(1.0, deadline - time.monotonic()))
            status = f"exited with {process.returncode}"
        except subprocess.TimeoutExpired:
            process.kill()
            output, _ = process.communicate()
            status = f"ran past {timeout} s"
    for line in output.splitlines():
        if line.startswith("START "):
            playing = int(line.split()[1])
        elif line.startswith("RESULT "):
            reported.append(json.loads(line[len("RESULT "):]))
        elif verbose or not line.startswith(("START", "RESULT")):
            lines.append(line)
    if verbose:
        print("\n".join(lines), flush=True)
    return reported, playing, f"{status}; last output:\n" + "\n".join(lines[-30:])


def play_all(seeds, jobs=1, per_process=1, timeout=TIMEOUT, zip_path=None, progress=None):
    """Every seed's result, ``per_process`` seeds a process, ``jobs`` processes at once, with
    the extension ``zip_path`` (default: built now if stale, before the processes read it);
    ``progress(result)`` is called as each case ends."""
    zip_path = zip_path or session.extension_zip()
    batches = [seeds[i:i + per_process] for i in range(0, len(seeds), per_process)]
    results = []
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for future in as_completed([pool.submit(play, b, timeout, zip_path=zip_path) for b in batches]):
            for result in future.result():
                results.append(result)
                if progress is not None:
                    progress(result)
    return sorted(results, key=lambda r: seeds.index(r["seed"]))


def failure_text(result):
    """A failing case as text: what broke at which step, the case's steps, the replay command."""
    seed = result["seed"]
    lines = [f"FAIL seed {seed}: step {result.get('step')}: {result.get('invariant')}",
             *("    " + line for line in str(result.get("message", "")).splitlines()[:40]),
             "  case:", *("  " + line for line in cases.describe(cases.case_of(seed))),
             "  outcomes: " + "; ".join(f"{n}: {o}" for n, o in enumerate(result.get("outcomes", []))),
             "  replay: " + replay_command(seed)]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=20, help="how many seeds (default 20)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--seeds", help="comma-separated seeds instead of a range")
    parser.add_argument("--replay", type=int, help="play one seed, printing everything")
    parser.add_argument("--jobs", type=int, default=1, help="processes at once (default 1)")
    parser.add_argument("--per-process", type=int, default=1, help="cases a process plays (default 1)")
    parser.add_argument("--timeout", type=float, default=TIMEOUT, help="seconds a case may take")
    arguments = parser.parse_args(argv)
    if arguments.replay is not None:
        print("\n".join(cases.describe(cases.case_of(arguments.replay))), flush=True)
        session.extension_zip()
        (result,) = play([arguments.replay], arguments.timeout, verbose=True)
        print(failure_text(result) if result["status"] != "pass" else
              f"seed {arguments.replay}: pass; outcomes: {'; '.join(result['outcomes'])}")
        return 0 if result["status"] == "pass" else 1
    seeds = ([int(s) for s in arguments.seeds.split(",")] if arguments.seeds else
             list(range(arguments.first_seed, arguments.first_seed + arguments.cases)))
    started = time.perf_counter()
    results = play_all(seeds, arguments.jobs, arguments.per_process, arguments.timeout,
                       progress=lambda r: print(f"seed {r['seed']}: {r['status']} "
                                                f"({r.get('invariant') or str(len(r['outcomes'])) + ' steps'})", flush=True))
    failed = [r for r in results if r["status"] != "pass"]
    for result in sorted(failed, key=lambda r: r["seed"]):
        print(failure_text(result), end="\n\n")
    print(f"fuzz: {len(results) - len(failed)} of {len(results)} cases passed in "
          f"{time.perf_counter() - started:.0f} s; failing seeds: {sorted(r['seed'] for r in failed)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
