"""Files and fresh processes: save and reopen, render farm workers, missing extension."""

import json
import tempfile

import bpy
import numpy as np
import pytest

from conftest import run_blender_script
from scene_helpers import add_icosphere_cage, add_sphere, bind, positions


def report_of(output):
    (line,) = [line for line in output.splitlines() if line.startswith("REPORT ")]
    return json.loads(line[len("REPORT "):])


@pytest.fixture(scope="module")
def bound_file(addon, tmp_path_factory):
    folder = tmp_path_factory.mktemp("bound_file")
    blend, saved = folder / "bound.blend", folder / "saved_positions.npy"
    run_blender_script("blender_make_bound_file.py", blend, saved)
    return blend, saved


def test_reopened_file_is_still_bound_and_live(bound_file):
    report = report_of(run_blender_script("blender_open_file.py", *bound_file))
    assert report["enabled"]
    assert report["kept_saved_shape"]
    assert report["bind_data_texts"] == [".GenCoords bind data: Mesh"]
    assert "Bound to 'Cage' (Mean Value)" in report["status"]
    assert report["rest_error_at_frame_1"] < 1e-5  # the animation still drives the mesh
    assert report["follows_exactly"]


def test_render_animation_shows_the_deformed_mesh(bound_file, tmp_path):
    blend, _ = bound_file
    output = run_blender_script("blender_render_file.py", blend, tmp_path)
    assert "Traceback" not in output
    report = report_of(output)
    assert report["lock_interface"]
    widths = {int(frame): width for frame, width in report["widths"].items()}
    assert widths[1] == pytest.approx(2.0, abs=1e-3)
    assert widths[2] == pytest.approx(3.2, abs=1e-2)  # the cage stretches x by 1.6
    covered = {int(frame): count for frame, count in report["covered_pixels"].items()}
    assert covered[2] > covered[1] * 1.2  # the wider mesh covers more of the image


def test_file_opens_without_the_extension(bound_file):
    with tempfile.TemporaryDirectory() as bare_user_folder:
        output = run_blender_script("blender_open_file.py", *bound_file,
                                    user_resources=bare_user_folder)
    assert "Traceback" not in output
    report = report_of(output)
    assert not report["enabled"]
    assert report["kept_saved_shape"] and report["unchanged_after_edits"]
    # Only saving dropped the deleted object's bind data: nothing ran on opening.
    assert report["bind_data_texts"] == [".GenCoords bind data: Mesh"]
    assert np.isfinite(np.load(bound_file[1])).all()


def test_opening_a_file_drops_bind_data_of_deleted_objects(gc, tmp_path):
    """Files saved by versions that kept such data, written here without save handlers."""
    cage = add_icosphere_cage()
    obj, deleted = add_sphere(), add_sphere(radius=0.5, name="Deleted")
    rest = positions(obj.data).copy()
    bind(obj, cage)
    bind(deleted, cage)
    orphan = deleted.gencoords.bind_data
    bpy.data.objects.remove(deleted)
    path = str(tmp_path / "orphan.blend")
    bpy.data.libraries.write(path, {bpy.context.scene, orphan})
    bpy.ops.wm.open_mainfile(filepath=path)
    assert [text.name for text in bpy.data.texts] == [".GenCoords bind data: Mesh"]
    obj = bpy.data.objects["Mesh"]
    np.testing.assert_array_equal(gc.storage.load(obj).rest_positions, rest)
