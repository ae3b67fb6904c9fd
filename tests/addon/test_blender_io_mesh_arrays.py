"""Blender I/O (``blender_io.mesh_arrays``): the bind data's triples round-trip exactly, and a
missing or retyped attribute reads as missing, never as other numbers."""

import numpy as np

from scene_helpers import add_sphere


def test_triples_round_trip_bitwise_with_the_last_one_padded(gc):
    mesh = add_sphere().data
    rng = np.random.default_rng(28)
    values = rng.normal(size=(len(mesh.vertices), 7)).astype(np.float32)  # 3 attributes, 2 pad columns
    names = [".probe_0", ".probe_1", ".probe_2"]
    gc.mesh_arrays.write_triples(mesh, names, values)
    np.testing.assert_array_equal(gc.mesh_arrays.read_triples(mesh, names, 7), values)
    np.testing.assert_array_equal(gc.mesh_arrays.read_triples(mesh, names, 9)[:, 7:], 0.0)
    short = rng.normal(size=(10, 3)).astype(np.float32)  # fewer rows: zeros beyond them
    gc.mesh_arrays.write_triples(mesh, [".probe_rows"], short)
    stored = gc.mesh_arrays.read_triples(mesh, [".probe_rows"], 3)
    np.testing.assert_array_equal(stored[:10], short)
    assert not stored[10:].any()


def test_a_missing_or_retyped_attribute_reads_as_missing(gc):
    mesh = add_sphere().data
    gc.mesh_arrays.write_triples(mesh, [".probe_0"], np.ones((len(mesh.vertices), 3), np.float32))
    assert gc.mesh_arrays.read_triples(mesh, [".probe_0", ".probe_1"], 6) is None
    mesh.attributes.new(".probe_1", 'FLOAT', 'POINT')
    assert gc.mesh_arrays.read_triples(mesh, [".probe_0", ".probe_1"], 6) is None
