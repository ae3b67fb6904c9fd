"""Files and fresh processes: save and reopen, render farm workers, missing extension."""

import tempfile

import numpy as np
import pytest

from fresh_process import report_of, run_blender_script


@pytest.fixture(scope="module", params=["MEAN_VALUE", "GREEN", "HARMONIC"])
def bound_file(addon, tmp_path_factory, request):
    """A saved file with the mesh bound with each deformer type: the paper's kinds all
    evaluate alike, Green coordinates add the cage's face terms, harmonic coordinates are
    stored sparse in two levels (their own node group)."""
    folder = tmp_path_factory.mktemp("bound_file")
    blend, saved = folder / "bound.blend", folder / "saved_positions.npy"
    run_blender_script("blender_make_bound_file.py", blend, saved, request.param)
    return blend, saved


def test_reopened_file_is_still_bound_and_deforms(bound_file, request):
    report = report_of(run_blender_script("blender_open_file.py", *bound_file))
    assert report["enabled"]
    assert report["mesh_data_is_rest"]  # Bind never wrote positions
    assert report["frame_2_as_saved"] and report["frame_1_is_rest"]
    assert "Bound to 'Cage' (modifier 'GenCoords')" in report["status"]
    # The cage scaled by 1.25 (radius 2): every kind follows exactly, harmonic too (its
    # coordinates are reweighted to place every vertex: docs/MATH.md).
    assert report["follows_an_edit"] < 1e-5
    # The deleted object's binding was not saved: one group and its shared helpers.
    assert [g for g in report["node_groups"] if not g.startswith(".")] == ["GenCoords: Mesh in Cage"]
    assert "Deleted" not in report["meshes"]


@pytest.mark.parametrize("installed", [True, False], ids=["extension", "no-extension"])
def test_render_animation_shows_the_deformed_mesh(bound_file, tmp_path, installed):
    """A render-farm worker, with or without the extension: Blender evaluates the modifier."""
    blend, _ = bound_file
    with tempfile.TemporaryDirectory() as bare_user_folder:
        options = {} if installed else {"user_resources": bare_user_folder}
        # After a Cycles animation render with a frame_change_post handler defined in
        # __main__, bpy crashes or hangs at interpreter exit, after the script is done:
        # bpy 4.2.23 dies with SIGSEGV, bpy 4.5.15 never exits (both pip modules on
        # Linux; 5.0 and later exit cleanly). The harness kills it and warns. Upstream:
        # no report found (Blender's tracker cannot be reached from here); gone in 5.0.
        output = run_blender_script("blender_render_file.py", blend, tmp_path,
                                    survive_exit_bug=True, **options)
    assert "Traceback" not in output
    report = report_of(output)
    widths = {int(frame): width for frame, width in report["widths"].items()}
    assert widths[1] == pytest.approx(2.0, abs=1e-3)
    # The cage stretches x by 1.6: mean value stretches the sphere alike (3.2), Green
    # coordinates keep its shape better; either way as the saving Blender evaluated it.
    saved_width = float(np.ptp(np.load(bound_file[1])[1][:, 0]))
    assert widths[2] == pytest.approx(saved_width, abs=1e-2) and widths[2] > 2.5
    covered = {int(frame): count for frame, count in report["covered_pixels"].items()}
    assert covered[2] > covered[1] * 1.2  # the wider mesh covers more of the image


def test_disabling_and_enabling_the_extension_keeps_bound_meshes_working(addon):
    # The deformation is the modifier's: it carries on while the extension is disabled,
    # and after enabling it again the panel's status and Unbind work on the same binding.
    report = report_of(run_blender_script("blender_disable_enable.py"))
    assert report["bind"] == ["FINISHED"] and report["disabled"]
    assert report["follows_while_disabled"] < 1e-5
    assert "Bound to 'Cage' (modifier 'GenCoords')" in report["status_after_enable"]
    assert report["follows_after_enable"] < 1e-5
    assert report["unbind"] == ["FINISHED"] and report["restored"] and report["modifiers"] == []


def test_file_opens_and_deforms_without_the_extension(bound_file, request):
    with tempfile.TemporaryDirectory() as bare_user_folder:
        output = run_blender_script("blender_open_file.py", *bound_file,
                                    user_resources=bare_user_folder)
    assert "Traceback" not in output
    report = report_of(output)
    assert not report["enabled"]
    assert report["mesh_data_is_rest"]
    assert report["frame_2_as_saved"] and report["frame_1_is_rest"]
    # The cage scaled by 1.25 (radius 2): every kind follows exactly, harmonic too (its
    # coordinates are reweighted to place every vertex: docs/MATH.md).
    assert report["follows_an_edit"] < 1e-5
