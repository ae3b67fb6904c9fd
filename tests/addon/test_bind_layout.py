"""The bind data's schema (``bind_layout.BindData``): what is stored is what is read back,
and data of other versions read as such, never misread."""

import pytest

from scene_helpers import add_icosphere_cage, add_sphere, bind


def test_a_binds_metadata_reads_back_as_the_record_it_was_written_from(gc):
    obj = add_sphere()
    assert bind(obj, add_icosphere_cage()) == {'FINISHED'}
    found = gc.binding.binding(obj)
    stored = found.group[gc.bind_layout.METADATA].to_dict()
    data = gc.bind_layout.BindData.from_properties(stored)
    assert data == found.data and data.to_properties() == stored
    assert data.is_current and data.storage in gc.bind_layout.STORAGES
    assert data.gamma is None and "gamma" not in stored  # ID properties hold no None
    assert data.rows == data.cage_vertex_count == data.slot_count  # exact, not Green
    assert data.slot_names == gc.bind_layout.slot_attribute_names(data.key, data.slot_count)
    assert data.basis_names is None and data.triangle_name is None


def test_other_versions_data_are_read_as_far_as_they_go_and_kept(gc):
    BindData = gc.bind_layout.BindData
    earlier = BindData.from_properties({"format": gc.bind_layout.FORMAT, "storage": 'COMPACT'})
    assert earlier.is_current and earlier.deviation_drag_vertex is None  # a later figure
    later = {"format": gc.bind_layout.FORMAT + 1, "kind": "mean_value", "new_figure": [1, 2]}
    data = BindData.from_properties(later)
    assert not data.is_current and data.kind == "mean_value"
    assert data.to_properties() == later  # a key this version does not know survives
    with pytest.raises(AttributeError):
        data.kind = "wachspress"  # frozen


def test_format_2_binds_read_as_the_current_format(gc):
    """Format 3 added sparse storage and harmonic coordinates: earlier binds are a part of
    it, so files bound before still open, deform and show their figures."""
    layout = gc.bind_layout
    earlier = {"format": 2, "kind": "mean_value", "storage": 'EXACT', "slot_count": 42, "key": "abc123"}
    data = layout.BindData.from_properties(earlier)
    assert layout.FORMAT == 3 and data.is_current and data.storage == 'EXACT'
    assert data.node_count is None and data.attribute_names == layout.slot_attribute_names("abc123", 42)
    assert not layout.BindData.from_properties(dict(earlier, format=1)).is_current


def test_a_sparse_binds_attributes_are_all_named_by_its_record(gc):
    obj = add_sphere()
    assert bind(obj, add_icosphere_cage(subdivisions=2), storage='SPARSE') == {'FINISHED'}
    data = gc.binding.binding(obj).data
    prefix = gc.bind_layout.attribute_prefix(data.key)
    assert data.storage == 'SPARSE' and data.slot_count == 16
    assert sorted(data.attribute_names) == sorted(a.name for a in obj.data.attributes if a.name.startswith(prefix))
