"""The scripting door: a pipeline script installs the built zip itself and reads what
Bind found through the public, read-only ``binding_result`` (README, "Scripting")."""

import pytest

from fresh_process import report_of, run_blender_script


@pytest.fixture(scope="module")
def pipeline(package):
    return report_of(run_blender_script("blender_pipeline_script.py", package))


def test_the_script_installs_the_zip_and_binds(pipeline):
    assert pipeline["installed"] == ['FINISHED']
    assert pipeline["enabled_after_read_homefile"]
    assert pipeline["unbound"] == [True, True]
    assert pipeline["bind"] == [['FINISHED'], ['FINISHED']]


def test_results_say_what_bind_chose_and_measured(pipeline):
    exact, compact = pipeline["results"]
    assert (exact["modifier"], exact["cage"]) == ("GenCoords", "Near")
    assert compact["cage"] == "Far" and compact["modifier"] != exact["modifier"]
    for result in (exact, compact):
        assert result["is_current"] and result["format"] >= 1
        assert (result["cage_vertex_count"], result["mesh_vertex_count"]) == (42, 24 * 11 + 2)
        assert 0.0 < result["min_coordinate"] < 1.0 / 42  # inside: all positive, not all equal
        assert result["negative_points"] == result["points_outside"] == 0
        assert 0.0 < result["max_affine_error"] < 1e-6  # of the float32 weights as stored
        assert result["report"] and result["bind_seconds"] > 0
        assert {"kind", "storage", "min_coordinate", "key"} <= set(result["metadata_keys"])
    # Automatic chose exact for this small mesh; the setting 'AUTO' is never reported.
    assert (exact["kind"], exact["gamma"], exact["outside"]) == ('MEAN_VALUE', None, 'RAISE')
    assert (exact["storage"], exact["slot_count"]) == ('EXACT', 42)
    # exact storage deviates by its float32 rounding alone
    assert 0.0 <= exact["deviation_smooth"] < 1e-6 and 0.0 <= exact["deviation_drag"] < 1e-6
    assert (compact["kind"], compact["outside"]) == ('WACHSPRESS', 'PROJECT')
    assert (compact["storage"], compact["slot_count"]) == ('COMPACT', 12)
    # 12 of 42 slots cannot reproduce a dragged vertex: a real, reported deviation.
    assert 0.0 < compact["deviation_smooth"] < compact["deviation_drag"] < 1.0
    assert compact["nbytes"] == 2 * exact["nbytes"] * 12 // 42


def test_results_are_the_figures_written_and_shown(pipeline):
    exact, compact = pipeline["results"]
    # Exact storage writes the coordinates as float32: their minimum is Bind's.
    assert pipeline["stored_slot_count"] == 42
    assert abs(pipeline["stored_min_coordinate"] - exact["min_coordinate"]) < 1e-7
    panel = "\n".join(pipeline["panel"])
    assert f"Smallest coordinate: {exact['min_coordinate']:.4g}" in panel
    assert f"Smallest coordinate: {compact['min_coordinate']:.4g}" in panel
    assert f"Deviation: {compact['deviation_smooth']:.1e} (smooth)" in panel


def test_results_are_read_only_records(pipeline):
    assert pipeline["first_is_default"] and pipeline["by_cage"] and pipeline["cage_not_bound"]
    assert pipeline["immutable"] == ["FrozenInstanceError", "TypeError"]
    assert pipeline["unbind"] == ['FINISHED'] and pipeline["after_unbind"]
    assert pipeline["earlier_result_kept"] == 'EXACT'  # a record: unbinding changes nothing in it


def test_read_factory_settings_unregisters_the_extension(pipeline):
    """What the README warns pipeline scripts about: use read_homefile(use_empty=True)."""
    assert not pipeline["enabled_after_read_factory_settings"]
