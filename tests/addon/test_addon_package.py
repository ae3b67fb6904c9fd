"""The built zip: Blender's builder and validator accept it; it ships add-on and core only."""

import ast
import importlib
import re
import tomllib
import zipfile
from pathlib import Path

import bpy

REPO = Path(__file__).resolve().parents[2]


def version_tuple(text):
    return tuple(int(part) for part in text.split("."))


def test_zip_holds_only_the_addon_and_core(package):
    names = zipfile.ZipFile(package).namelist()
    assert "__init__.py" in names and "blender_manifest.toml" in names
    assert any(name.startswith("gencoords_addon/") for name in names)
    assert "core/__init__.py" in names
    allowed_tops = {"__init__.py", "blender_manifest.toml", "LICENSE", "gencoords_addon", "core"}
    assert {name.split("/")[0] for name in names} <= allowed_tops
    assert not [name for name in names if "__pycache__" in name or name.endswith(".pyc")]
    manifest = tomllib.loads(zipfile.ZipFile(package).read("blender_manifest.toml").decode())
    assert package.name == f"{manifest['id']}-{manifest['version']}.zip"


def test_manifest_claims_what_the_matrix_tests():
    """blender_version_min is the oldest Blender `make test-blender-matrix` runs (so the
    manifest promises nothing untested) and this Blender lies in the manifest's range."""
    manifest = tomllib.loads((REPO / "blender_manifest.toml").read_text(encoding="utf-8"))
    matrix = re.search(r"^MATRIX\s*:=(.*)$", (REPO / "Makefile").read_text(), re.M).group(1)
    tested = sorted(version_tuple(version) for version in matrix.split())
    minimum = version_tuple(manifest["blender_version_min"])
    assert tested[0] == minimum
    assert minimum <= bpy.app.version
    if "blender_version_max" in manifest:  # exclusive
        assert tested[-1] < version_tuple(manifest["blender_version_max"])
        assert bpy.app.version < version_tuple(manifest["blender_version_max"])


def test_installed_extension_is_enabled_with_its_api(gc):
    assert "bl_ext.user_default.gencoords" in bpy.context.preferences.addons
    for operator in ("gencoords_bind", "gencoords_unbind", "gencoords_show_field",
                     "gencoords_clear_field"):
        assert hasattr(bpy.ops.object, operator)
    properties = bpy.types.Object.bl_rna.properties["gencoords"].fixed_type.properties
    for name in ("cage", "kind", "gamma", "outside", "storage", "compact_size", "auto_rebind",
                 "field_vertex", "resolution", "sparse_size"):
        assert properties[name].description, name
        assert not properties[name].is_animatable, name  # read at bind time only
    assert properties["kind"].default == 'MEAN_VALUE'
    assert {item.identifier for item in properties["kind"].enum_items} == {
        'WACHSPRESS', 'MEAN_VALUE', 'DISCRETE_HARMONIC', 'VORONOI', 'POWER', 'GREEN', 'HARMONIC', 'MEAN_VALUE_QUADS'}
    assert properties["kind"].enum_items['MEAN_VALUE_QUADS'].name == "Quad Mean Value"
    assert properties["kind"].enum_items['HARMONIC'].name == "Harmonic"
    assert properties["kind"].enum_items['HARMONIC'].description.startswith("Local, positive: ")
    assert {item.identifier for item in properties["storage"].enum_items} == {'AUTO', 'EXACT', 'COMPACT', 'SPARSE'}
    assert properties["kind"].enum_items['GREEN'].name == "Green"


class RecordingLayout:
    """Stands in for bpy.types.UILayout (unavailable headless), recording what is drawn."""

    def __init__(self, drawn):
        self.drawn = drawn
        self.enabled = True

    def _nested(self, *args, **kwargs):
        return RecordingLayout(self.drawn)

    column = row = box = _nested

    def panel(self, idname, default_closed=False):
        """A layout panel, open: its header and body."""
        return RecordingLayout(self.drawn), RecordingLayout(self.drawn)

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, name
        self.drawn.append(("prop", name))

    def operator(self, idname, **kwargs):
        category, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, category), name), idname
        self.drawn.append(("operator", idname))
        if "text" in kwargs:  # the button's own words
            self.drawn.append(("text", kwargs["text"]))

    def label(self, text, icon='NONE'):
        self.drawn.append(("label", text))


def test_panel_draws_settings_status_and_operators(gc):
    from scene_helpers import add_icosphere_cage, add_sphere, bind

    panel = importlib.import_module("bl_ext.user_default.gencoords.gencoords_addon.ui.panel")
    assert hasattr(bpy.types, "OBJECT_PT_gencoords") and hasattr(bpy.types, "VIEW3D_PT_gencoords")
    obj = add_sphere()
    bind(obj, add_icosphere_cage())
    drawn = []
    panel.draw_settings(RecordingLayout(drawn), obj)
    for item in (("prop", "cage"), ("prop", "kind"), ("prop", "outside"), ("prop", "storage"),
                 ("prop", "field_vertex"), ("operator", "object.gencoords_bind"),
                 ("operator", "object.gencoords_unbind"),
                 ("operator", "object.gencoords_show_field"),
                 ("label", "Bound to 'Cage' (modifier 'GenCoords')"),
                 ("label", "Coordinates: Mean Value")):
        assert item in drawn


def test_status_lines_wrap_to_the_panel_width_without_losing_words(gc):
    panel = importlib.import_module("bl_ext.user_default.gencoords.gencoords_addon.ui.panel")
    sentence = ("Mesh edited since Bind: 812 vertices added; it is not deformed until you "
                "Bind again (or turn on Auto Rebind)")
    lines = panel.wrapped(sentence, 30)
    assert len(lines) > 1 and all(len(line) <= 30 for line in lines)
    assert " ".join(lines) == sentence
    assert panel.wrapped(sentence, None) == [sentence]


ADDON = REPO / "gencoords_addon"


MAX_MODULE_LINES = 400
MAX_MODULES_PER_FOLDER = 12


def addon_trees():
    """Every add-on module's dotted name under the add-on (``bind.job``) and syntax tree."""
    return {".".join(path.relative_to(ADDON).with_suffix("").parts): ast.parse(path.read_text(), str(path))
            for path in sorted(ADDON.rglob("*.py"))}


def test_no_add_on_module_is_over_400_lines():
    long = {str(path.relative_to(REPO)): count for path in sorted(ADDON.rglob("*.py"))
            if (count := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long


def test_the_add_on_is_grouped_in_folders_of_at_most_12_modules():
    folders = [ADDON, *(path for path in ADDON.rglob("*") if path.is_dir() and path.name != "__pycache__")]
    counts = {str(folder.relative_to(REPO)): len([p for p in folder.glob("*.py") if p.name != "__init__.py"])
              for folder in folders}
    assert all(count <= MAX_MODULES_PER_FOLDER for count in counts.values()), counts
    assert {"ui", "bind", "graph", "blender_io"} <= {Path(folder).name for folder in counts}


def test_add_on_tests_mirror_its_folders():
    """A test file per folder of the add-on, named for it (``test_bind_*.py`` for ``bind/``)."""
    tests = [path.name for path in (REPO / "tests" / "addon").glob("test_*.py")]
    for folder in (path for path in ADDON.iterdir() if path.is_dir() and path.name != "__pycache__"):
        assert any(name.startswith(f"test_{folder.name}_") for name in tests), folder.name


def test_kind_ids_are_spelled_only_in_the_enum_module(addon):
    spellings = {kind.name for kind in addon.core.KIND_TABLE} | {"green"}
    spellings |= {name.upper() for name in spellings}
    found = [f"{name}.py:{node.lineno} {node.value!r}" for name, tree in addon_trees().items()
             if name != "enums" for node in ast.walk(tree)
             if isinstance(node, ast.Constant) and node.value in spellings]
    assert not found


def test_mesh_arrays_are_read_and_written_in_one_module():
    """``foreach_get``/``foreach_set`` on mesh data only in ``blender_io.mesh_arrays`` (keyframes
    are not mesh data)."""
    found = [f"{name}.py:{node.lineno}" for name, tree in addon_trees().items()
             if name != "blender_io.mesh_arrays" for node in ast.walk(tree)
             if isinstance(node, ast.Attribute) and node.attr in ("foreach_get", "foreach_set")
             and not (isinstance(node.value, ast.Attribute) and node.value.attr == "keyframe_points")]
    assert not found
