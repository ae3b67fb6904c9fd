"""The operator fuzz's cases (scripts/fuzz/cases.py): a seed alone gives the case, and the
seeds cover every step, defect and modifier the fuzz claims to try."""

import json

import pytest

from scripts.fuzz import cases, run


def test_a_seed_gives_the_same_case_every_time():
    assert json.dumps(cases.case_of(123), sort_keys=True) == json.dumps(cases.case_of(123), sort_keys=True)
    assert cases.case_of(123) != cases.case_of(124)


def test_two_hundred_seeds_try_every_step_defect_shape_and_modifier():
    drawn = [cases.case_of(seed) for seed in range(200)]
    ops = {step["op"] for case in drawn for step in case["steps"]}
    assert ops == set(cases.STEP_WEIGHTS)
    assert {case["story"] for case in drawn} == {None, "copies", "bake", "two bakes", "deleted cage", "small", "flat mesh"}
    scenes = [case["scene"] for case in drawn]
    assert {s["cage"]["defect"] for s in scenes} == set(cases.CAGE_DEFECTS) | {None}
    assert {s["cage"]["shape"] for s in scenes} == set(cases.CAGE_SHAPES)
    assert {s["cage"]["modifier"] for s in scenes} == set(cases.CAGE_MODIFIERS) | {None}
    assert {s["mesh"]["shape"] for s in scenes} == set(cases.MESH_SHAPES)
    binds = [step for case in drawn for step in case["steps"] if step["op"] == "bind"]
    assert {step["kind"] for step in binds} == set(cases.KINDS) and "HARMONIC" in cases.KINDS
    # Harmonic binds on coarse grids (a case plays in seconds), each of them drawn, and now
    # and then on a finer one (HARMONIC_FINE: the most a case's time limit allows).
    assert ({step["resolution"] for step in binds if step["kind"] == "HARMONIC"}
            == set(cases.HARMONIC_RESOLUTIONS) | {cases.HARMONIC_FINE})
    assert max(cases.HARMONIC_RESOLUTIONS) <= 16 and cases.HARMONIC_FINE <= 32
    scales = [s["placement"]["scale"] for s in scenes]
    assert min(scales) < 1e-4 and max(scales) > 1e4


def test_the_steps_are_printed_one_a_line_with_their_arguments():
    case = cases.case_of(7)
    lines = cases.describe(case)
    assert len(lines) == 2 + len(case["steps"])
    assert lines[2].startswith(f"  0: {case['steps'][0]['op']}(")


FAKE_CASE_SCRIPT = '''
import json, os, sys, time
for seed in map(int, sys.argv[3:]):
    print("START", seed, flush=True)
    if seed == 2:
        os.abort()  # a crash
    if seed == 3:
        time.sleep(60)  # a hang
    print("RESULT " + json.dumps({"seed": seed, "status": "pass", "outcomes": []}), flush=True)
'''


@pytest.mark.slow
def test_a_crash_or_a_hang_is_the_seed_that_was_playing_and_the_rest_play_on(tmp_path, monkeypatch):
    script = tmp_path / "fake_case.py"
    script.write_text(FAKE_CASE_SCRIPT)
    monkeypatch.setattr(run, "CASE_SCRIPT", script)
    results = run.play([1, 2, 3, 4], timeout=2.0, zip_path=tmp_path / "unused.zip")
    by_seed = {r["seed"]: r for r in results}
    assert sorted(by_seed) == [1, 2, 3, 4]
    assert by_seed[1]["status"] == by_seed[4]["status"] == "pass"
    assert by_seed[2]["invariant"] == by_seed[3]["invariant"] == "no crash or hang"
    assert "exited with" in by_seed[2]["message"] and "ran past" in by_seed[3]["message"]
    assert "replay: python scripts/fuzz/run.py --replay 2" in run.failure_text(by_seed[2])
