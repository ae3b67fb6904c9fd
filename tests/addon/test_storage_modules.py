"""Each storage's module (``gencoords_addon/storage/``), bound through the operator as a
pipeline script binds: the attributes it writes are the ones its record names, its byte
count is what they hold, and what it reads back are coordinates (summing to 1), the same
whole or a column at a time."""

import numpy as np
import pytest

from scene_helpers import add_icosphere_cage, add_sphere, add_subdivided_sphere, bind

# Blender's attribute types the storages write -> bytes per point.
ITEM_BYTES = {'FLOAT_VECTOR': 12, 'FLOAT': 4, 'INT': 4}


@pytest.mark.parametrize("storage, kind, module", [
    ('EXACT', "MEAN_VALUE", "exact"), ('COMPACT', "MEAN_VALUE", "compact"),
    ('SPARSE', "MEAN_VALUE", "sparse"), ('SPARSE', "HARMONIC", "two_level")])
def test_a_storage_writes_what_its_record_names_counts_its_bytes_and_reads_coordinates(gc, storage, kind, module):
    # Two levels need fewer grid nodes than mesh vertices: a denser mesh.
    obj = add_subdivided_sphere(levels=2) if module == "two_level" else add_sphere()
    cage = add_icosphere_cage(subdivisions=2)
    obj.gencoords.resolution, obj.gencoords.sparse_size = 8, 8
    assert bind(obj, cage, kind=kind, storage=storage, compact_size=12) == {'FINISHED'}
    found = gc.binding.binding(obj)
    data, home = found.data, gc.storage.of(found.data)
    assert home.__name__.rpartition(".")[2] == module and data.storage in gc.bind_layout.STORAGES
    assert bool(data.node_count) == (module == "two_level")
    prefix = gc.bind_layout.attribute_prefix(data.key)
    written = {a.name: a for a in obj.data.attributes if a.name.startswith(prefix)}
    assert sorted(written) == sorted(data.attribute_names)
    measured = sum(len(a.data) * ITEM_BYTES[a.data_type] for a in written.values())
    assert data.nbytes == home.nbytes(data) == measured
    coordinates = found.coordinates(obj.data)
    assert coordinates.shape == (len(obj.data.vertices), data.rows) and np.isfinite(coordinates).all()
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, atol=1e-5)
    for cage_vertex in (0, data.cage_vertex_count - 1):
        np.testing.assert_allclose(found.coordinate_column(obj.data, cage_vertex), coordinates[:, cage_vertex],
                                   atol=1e-6)


def test_a_binding_whose_attributes_are_gone_reads_as_none_in_every_storage(gc):
    obj, cage = add_sphere(), add_icosphere_cage(subdivisions=2)
    for storage in ('EXACT', 'COMPACT', 'SPARSE'):
        assert bind(obj, cage, storage=storage, compact_size=12) == {'FINISHED'}
        found = gc.binding.binding(obj)
        gc.attributes.remove_slots(obj.data, found.key)
        assert found.coordinates(obj.data) is None and found.coordinate_column(obj.data, 0) is None
