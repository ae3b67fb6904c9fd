"""The fuzz's steps, each done as a user or a pipeline script does it (operators inside
``bpy.context.temp_override``, bmesh edits of the data, the object's transform), each with
the invariants that belong to it. ``run(state, step)`` returns what happened: "done",
"refused: <message>" or "skipped: <why>"; a broken invariant raises ``checks.Violation``.
"""

from pathlib import Path

import bmesh
import bpy
import numpy as np

from scripts.common import session
from scripts.common.blender_objects import arrays, make_active
from . import checks, scene

# Modifiers that commute with a translation on every mesh. Blender's Smooth and Displace
# do not on loose vertices (Smooth halves their motion, Displace follows their
# position's direction): meshes with others are left out of the translation check.
TRANSLATION_SAFE = {'NODES', 'ARMATURE', 'SUBSURF', 'TRIANGULATE'}


class Refused(Exception):
    """The operator refused (its message), and changed nothing."""


class Skipped(Exception):
    """The step does not apply (an object of its role is gone)."""


class CaseState:
    """One case's file: its objects by role, the mesh data seen before their first Bind
    (``pristine``: name -> ``checks.mesh_digest``) and a folder for saved files."""

    def __init__(self, roles, folder):
        self.roles = dict(roles)
        self.pristine = {}
        self.reshaped = set()  # objects whose topology a step changed: their baked rigs no longer fit
        self.made_for = {}  # made cage -> (mesh name, signature of both when it was made)
        self.folder = Path(folder)

    def get(self, role, kind='MESH'):
        obj = bpy.data.objects.get(self.roles.get(role, ""))
        if obj is None or obj.type != kind or not obj.users_collection:
            raise Skipped(f"no {role}")
        return obj


def _override(obj):
    return bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj],
                                     selected_editable_objects=[obj])


def operate(obj, operator, **arguments):
    """Call ``operator`` on ``obj`` as a pipeline script does; a refusal (RuntimeError or
    CANCELLED) must leave the file as it was, and raises ``Refused``."""
    before = checks.file_state()
    try:
        with _override(obj):
            result = operator(**arguments)
    except RuntimeError as error:
        message = str(error).strip()
    else:
        if 'FINISHED' in result:
            return
        message = f"returned {sorted(result)}"
    checks.check_output(message)
    checks.check_unchanged(before, checks.file_state(), "a refusal changes nothing")
    raise Refused(message.splitlines()[0] if message else "refused")


def bindings_of(obj):
    """(modifier, node group) of each binding of ``obj``."""
    return [(m, m.node_group) for m in obj.modifiers
            if m.type == 'NODES' and m.node_group is not None and checks.METADATA in m.node_group]


def cage_of_modifier(modifier):
    """The object input of a binding's modifier (read through the add-on's compat: 5.2 moved
    modifier inputs to a new API)."""
    compat = session.addon_module("blender_io.compat")
    for item in modifier.node_group.interface.items_tree:
        if getattr(item, "socket_type", "") == 'NodeSocketObject' and item.in_out == 'INPUT':
            return compat.get_modifier_input(modifier, item.name)
    return None


def _live(obj, modifier, group):
    """The cage of a binding that deforms: its cage is there, finite, with the vertex count
    bound, the mesh has its own (else the deformer passes the mesh through, by design)."""
    cage, info = cage_of_modifier(modifier), group[checks.METADATA]
    if cage is None or len(obj.data.vertices) != info.get("mesh_vertex_count"):
        return None
    evaluated = cage.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    if len(evaluated.vertices) != info.get("cage_vertex_count"):
        return None
    return cage if np.isfinite(arrays.read_positions(evaluated)).all() else None


def drivers_of(obj):
    """The objects ``obj`` follows directly: its live bindings' cages, its baked rigs' cages."""
    return [cage for cage in [_live(obj, m, g) for m, g in bindings_of(obj)] + checks.rig_cages(obj) if cage is not None]


def follows_exactly(obj, reshaped=()):
    """Whether ``obj`` moves exactly as its drivers do: not when a rig it is baked to
    follows a cage whose topology a step changed since (``reshaped``, names), or when
    its own topology changed since. Such a rig still follows that cage (its bones' vertex
    groups travel with a subdivision, and an emptied group leaves the bone on the cage's
    origin), but no longer as the binding did; a vertex added to the mesh has no weight
    and stays (as in any Blender skin)."""
    cages = checks.rig_cages(obj)
    return not any(cage.name in reshaped for cage in cages) and not (cages and obj.name in reshaped)


def followers(cage):
    """Names of the mesh objects that follow ``cage``, directly or through other cages."""
    meshes = [o for o in bpy.context.view_layer.objects if o.type == 'MESH']
    drivers = {o.name: {d.name for d in drivers_of(o)} for o in meshes}
    follows = {cage.name}
    for _ in meshes:  # to a fixed point: chains of cages
        follows |= {name for name, found in drivers.items() if found & follows}
    return sorted(follows - {cage.name})


def single_followers(cage, reshaped=()):
    """Mesh objects that follow ``cage`` along exactly one path, exactly (they move as it moves)."""
    meshes = [o for o in bpy.context.view_layer.objects if o.type == 'MESH']
    drivers = {o.name: [d.name for d in drivers_of(o)] for o in meshes}
    follows = {cage.name, *followers(cage)}
    return [name for name, found in drivers.items() if name != cage.name
            and sum(d in follows for d in found) == 1 and translates(bpy.data.objects[name])
            and all(follows_exactly(bpy.data.objects[d], reshaped) for d in [name, *found]
                    if bpy.data.objects[d].type == 'MESH')]


def translates(obj):
    """Whether the mesh object can show a translation of its cage: its modifiers commute
    with translations and its transform is not flat (a zero scale, set after Bind, keeps
    the mesh on a plane whatever the cage does)."""
    columns = np.linalg.norm(np.array(obj.matrix_world, dtype=np.float64)[:3, :3], axis=0)
    # An armature commutes with translations only when its bones just translate: Bake to
    # Bones' rigs that follow the cage; a Fitted rig's keyframed bones turn.
    armatures_translate = all(checks.rig_cages_of(m) for m in obj.modifiers if m.type == 'ARMATURE')
    return ({m.type for m in obj.modifiers} <= TRANSLATION_SAFE and armatures_translate
            and columns.min() > 1e-6 * columns.max())


def _data_shared_with(obj):
    return [o for o in bpy.data.objects if o.data == obj.data]


def bind(state, step):
    target = state.get(step["target"])
    cage = state.get(step["cage"])
    settings = target.gencoords
    try:
        settings.cage = cage
    except (TypeError, ValueError) as error:  # the setting's own check
        raise Refused(f"Cage setting: {error}") from None
    settings.kind, settings.outside = step["kind"], step["outside"]
    settings.storage, settings.compact_size = step["storage"], step["compact_size"]
    if "sparse_size" in step:
        settings.sparse_size = step["sparse_size"]
    if "gamma" in step:
        settings.gamma = step["gamma"]
    if "resolution" in step:
        settings.resolution = step["resolution"]
    return _bind_operator(state, target)


def rebind(state, step):
    return _bind_operator(state, state.get(step["target"]))


def signature(mesh, cage):
    """What a made cage was made around: the mesh's data and evaluated shape, the cage's data,
    both transforms."""
    positions = checks.world_positions()
    return repr([checks.mesh_digest(mesh.data), checks.mesh_digest(cage.data),
                 checks._digest(positions.get(mesh.name, np.zeros(0))),
                 checks._digest(positions.get(cage.name, np.zeros(0)))])


def _bind_operator(state, target):
    try:
        return _bind_checked(state, target)
    except Refused as refusal:
        cage = target.gencoords.cage
        made = state.made_for.get(cage.name if cage else None)
        if made and made[0] == target.name and "mesh vertices lie outside" in str(refusal) \
                and made[1] == signature(target, cage):
            raise checks.Violation("a made cage binds", str(refusal)) from None
        raise


def _bind_checked(state, target):
    unbound = not any(bindings_of(o) for o in _data_shared_with(target))
    # Bind replaces a binding to the same cage (or one whose cage is gone): the mesh then
    # drops that binding's deformation, by design. Any other mesh must stay put.
    replaced = any(cage_of_modifier(m) in (None, target.gencoords.cage) for m, _ in bindings_of(target))
    digest = checks.mesh_digest(target.data, checks.FIELD_NAMES)
    before = checks.world_positions()
    operate(target, bpy.ops.object.gencoords_bind)
    if unbound:
        state.pristine[target.data.name] = digest
    after = checks.world_positions()
    # Meshes whose cage is the target (or follows it) follow it as it drops that deformation.
    moving = {target.name} | set(followers(target)) if replaced else set()
    still = [name for name in before if name not in moving]
    checks.check_moved(still, before, after, np.zeros(3), 0.0, "rest is unchanged (Bind)")
    return "done"


def unbind(state, step):
    target = state.get(step["target"])
    operate(target, bpy.ops.object.gencoords_unbind)
    pristine = state.pristine.get(target.data.name)
    if pristine is not None and not any(bindings_of(o) for o in _data_shared_with(target)):
        now = checks.mesh_digest(target.data, checks.FIELD_NAMES)
        checks.check_unchanged(pristine, now, "Unbind restores bitwise")
        del state.pristine[target.data.name]
    return "done"


def _forget_pristine(state, obj):
    state.pristine.pop(obj.data.name, None)


def translate_cage(state, step):
    cage = state.get(step["cage"])
    direction = np.array(step["direction"]) / (np.linalg.norm(step["direction"]) or 1.0)
    before = checks.world_positions()
    matrix = np.array(cage.matrix_world, dtype=np.float64)
    if step["how"] == "object":
        shift = direction * step["amount"] * checks.size_of(before[cage.name])
        location = cage.location.copy()
        cage.location = location + type(location)(shift)
        bpy.context.view_layer.update()
        shift = np.array(cage.matrix_world, dtype=np.float64)[:3, 3] - matrix[:3, 3]
        undo = lambda: setattr(cage, "location", location)  # noqa: E731
    else:
        positions = arrays.read_positions(cage.data).copy()
        local_shift = direction * step["amount"] * checks.size_of(positions.astype(np.float64))
        moved = positions + local_shift.astype(np.float32)
        arrays.write_positions(cage.data, moved)
        exact = (moved.astype(np.float64) - positions)
        shift = matrix[:3, :3] @ exact[np.isfinite(exact).all(axis=1)].mean(axis=0) if len(exact) else np.zeros(3)
        undo = lambda: arrays.write_positions(cage.data, positions)  # noqa: E731
    return _check_translation(state, cage, before, shift, undo if step["back"] else None)


def _check_translation(state, cage, before, shift, undo):
    after = checks.world_positions()
    followers = single_followers(cage, state.reshaped)
    size = checks.size_of(before[cage.name])
    if np.isfinite(before[cage.name]).all():
        checks.check_moved(followers, before, after, shift, size, "a translated cage translates the mesh",
                           cage=before[cage.name])
    if undo is not None:
        undo()
        bpy.context.view_layer.update()
        checks.check_moved(list(before), before, checks.world_positions(), np.zeros(3), size,
                           "rest is unchanged (cage moved back)")
    return f"done, followers {followers}"


def edit_cage(state, step):
    cage = state.get(step["cage"])
    positions = arrays.read_positions(cage.data).astype(np.float64)
    rng = np.random.default_rng(step["seed"])
    positions += rng.normal(size=positions.shape) * step["amount"] * checks.size_of(positions)
    if step["nan"] and len(positions):
        positions[0] = np.nan
    arrays.write_positions(cage.data, positions)
    return "done"


def cage_topology(state, step):
    cage = state.get(step["cage"])
    state.reshaped.add(cage.name)
    _change_topology(cage, step["change"])
    return "done"


def _change_topology(obj, change):
    def apply(bm):
        if not bm.verts:
            return
        if change in ("delete_vertex",):
            bmesh.ops.delete(bm, geom=[bm.verts[0]], context='VERTS')
        elif change == "add_vertex":
            bm.verts.new(bm.verts[0].co * 0.5)
        elif change == "subdivide":
            bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True)
        else:
            bmesh.ops.triangulate(bm, faces=bm.faces[:])
    scene.edit(obj, apply)


def mesh_topology(state, step):
    target = state.get(step["target"])
    state.reshaped.add(target.name)
    _forget_pristine(state, target)
    _change_topology(target, step["change"])
    return "done"


def delete(state, step):
    obj = state.get(step["target"])
    operate(obj, bpy.ops.object.delete)
    return "done"


def apply(state, step):
    obj = state.get(step["target"])
    if not obj.modifiers:
        raise Skipped("no modifier")
    if obj.data.shape_keys is not None:
        # Blender's own refusal ("cannot be applied to a mesh with shape keys"), in which
        # 4.2 rewrites the mesh's UV map (seeds 19 and 31): none of the add-on's to check.
        raise Skipped("Blender refuses Apply on a mesh with shape keys")
    modifier = obj.modifiers[0 if step["which"] == "first" else -1]
    # Blender applies a modifier to the mesh data as it is, without those above it ("Applied
    # modifier was not first, result may not be as expected"): only the first keeps the
    # evaluated mesh (seed 7209: a Smooth modifier above a baked rig with partial weights).
    first = all(not other.show_viewport for other in obj.modifiers[:list(obj.modifiers).index(modifier)])
    before = checks.world_positions()
    operate(obj, bpy.ops.object.modifier_apply, modifier=modifier.name)
    _forget_pristine(state, obj)
    if not first:
        return "done (not first)"
    checks.check_moved([obj.name], before, checks.world_positions(), np.zeros(3),
                       checks.size_of(before[obj.name]), "Apply keeps the evaluated mesh")
    return "done"


def _new_objects(action):
    names = set(bpy.data.objects.keys())
    action()
    return [o for o in bpy.data.objects if o.name not in names]


def duplicate(state, step):
    target = state.get(step["target"])
    before = checks.world_positions()
    added = _new_objects(lambda: operate(target, bpy.ops.object.duplicate, linked=step["linked"]))
    copies = [o for o in added if o.type == 'MESH']
    if not copies:
        return "done, nothing added"
    state.roles["copy"] = copies[0].name
    after = checks.world_positions()
    after[target.name] = after[copies[0].name]  # the copy lies where the original does
    checks.check_moved([target.name], before, after, np.zeros(3), checks.size_of(before[target.name]),
                       "a duplicate deforms as its original")
    return f"done, {copies[0].name}"


def save_reload(state, step):
    path = state.folder / "case.blend"
    before, positions = checks.file_state(saved_only=True), checks.world_positions()
    bpy.ops.wm.save_as_mainfile(filepath=str(path), check_existing=False)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    checks.check_unchanged(before, checks.file_state(saved_only=True), "reload is unchanged")
    after = checks.world_positions()
    for name in positions:
        checks.check_moved([name], positions, after, np.zeros(3), 0.0, "reload is unchanged (evaluated)")
    return "done"


def bake(state, step):
    target = state.get(step["target"])
    before = checks.world_positions()
    options = {"max_influences": step["max_influences"], "keyframes": step["keyframes"]}
    fitted = step.get("mode") == "FITTED"
    if fitted:
        options.update(mode='FITTED', bones=step["bones"], use_scene_range=False,
                       frame_start=step.get("frame_start", 1), frame_end=step["frame_end"])
    operate(target, bpy.ops.object.gencoords_bake_bones, **options)
    _forget_pristine(state, target)
    if step["max_influences"] == 0 and not fitted:  # every weight kept: as the binding did
        after = checks.world_positions()
        scale = max((checks.size_of(p) for p in before.values()), default=0.0)
        checks.check_moved([target.name], before, after, np.zeros(3), scale,
                           "Bake to Bones keeps the mesh where it was")
    return "done"


def show_field(state, step):
    target = state.get(step["target"])
    target.gencoords.field_vertex = step["vertex"]
    operate(target, bpy.ops.object.gencoords_show_field)
    return "done"


def clear_field(state, step):
    operate(state.get(step["target"]), bpy.ops.object.gencoords_clear_field)
    return "done"


def _make_odd(state, obj, oddity):
    """Make the mesh data of ``obj`` odd (``cases.MESH_ODDITIES``): every vertex at the
    first's position, shrunk a billionfold about its centre, or flattened along Z."""
    state.reshaped.add(obj.name)  # its rigs and followers no longer move as bound
    _forget_pristine(state, obj)
    positions = arrays.read_positions(obj.data).astype(np.float64)
    if not len(positions):
        return
    centre = positions.mean(axis=0)
    if oddity == "one_point":
        positions[:] = positions[0]
    elif oddity == "tiny":
        positions = centre + (positions - centre) * 1e-9
    else:
        positions[:, 2] = centre[2]
    arrays.write_positions(obj.data, positions.astype(np.float32))


def make_cage(state, step):
    target = state.get(step["target"])
    if step.get("oddity") and target.type == 'MESH':
        _make_odd(state, target, step["oddity"])
    options = {"target_vertices": step["vertices"], "margin": step["margin"]}
    if step.get("shape") == "TIGHT":
        options.update(shape='TIGHT', offset=step["offset"])
    added = _new_objects(lambda: operate(target, bpy.ops.object.gencoords_make_cage, **options))
    made = [o for o in added if o.type == 'MESH']
    if made:
        state.roles["made"] = made[0].name
        state.made_for[made[0].name] = (target.name, signature(target, made[0]))
    return f"done, {made[0].name if made else 'nothing'}"


def frame(state, step):
    """Keyframe the cage's location at frames 1 and 11 (moved), play to 11 and back."""
    cage = state.get(step["cage"])
    scene_ = bpy.context.scene
    scene_.frame_set(1)
    before = checks.world_positions()
    start = np.array(cage.matrix_world.translation, dtype=np.float64)
    location = cage.location.copy()
    cage.keyframe_insert("location", frame=1)
    direction = np.array(step["direction"]) / (np.linalg.norm(step["direction"]) or 1.0)
    cage.location = location + type(location)(direction * step["amount"] * checks.size_of(before[cage.name]))
    cage.keyframe_insert("location", frame=11)
    scene_.frame_set(11)
    shift = np.array(cage.matrix_world.translation, dtype=np.float64) - start
    try:
        return _check_translation(state, cage, before, shift, lambda: scene_.frame_set(1))
    finally:
        cage.animation_data_clear()
        cage.location = location
        bpy.context.view_layer.update()


def object_scale(state, step):
    scene.scale_oddly(state.get(step["target"]), step["scale"])
    bpy.context.view_layer.update()
    return "done"


def edit_mode(state, step):
    """Tab into Edit Mode, change the mesh there with Blender's operators, tab out (Auto
    Rebind, when set, binds again then)."""
    obj = state.get(step["target"])
    obj.gencoords.auto_rebind = step["auto_rebind"]
    _forget_pristine(state, obj)
    make_active(obj)
    with _override(obj):
        bpy.ops.object.mode_set(mode='EDIT')
        try:
            bpy.ops.mesh.select_all(action='SELECT' if step["change"] == "subdivide" else 'DESELECT')
            if step["change"] == "subdivide":
                bpy.ops.mesh.subdivide()
            elif step["change"] == "delete":
                edited = bmesh.from_edit_mesh(obj.data)
                for vertex in list(edited.verts)[:3]:
                    vertex.select = True
                bpy.ops.mesh.delete(type='VERT')
        finally:
            bpy.ops.object.mode_set(mode='OBJECT')
    bpy.context.view_layer.update()
    return "done"


def rename(state, step):
    obj = state.get(step["target"])
    obj.name = f"{step['target'].title()} renamed"
    state.roles[step["target"]] = obj.name
    bpy.context.view_layer.update()
    return f"done, {obj.name}"


def parent_cage(state, step):
    """Parent the cage to the mesh, keeping where it is (Ctrl+P, Object)."""
    cage, mesh = state.get(step["cage"]), state.get(step["target"])
    make_active(mesh)
    cage.select_set(True)
    with bpy.context.temp_override(active_object=mesh, object=mesh, selected_objects=[cage, mesh],
                                   selected_editable_objects=[cage, mesh]):
        bpy.ops.object.parent_set(type='OBJECT', keep_transform=True)
    bpy.context.view_layer.update()
    return f"done, parent {cage.parent.name if cage.parent else None}"


def move_mesh(state, step):
    """Move a mesh bound to one cage: unless the cage moves with it (a child), the mesh
    stays with its cage, as with Mesh Deform."""
    obj = state.get(step["target"])
    before = checks.world_positions()
    start = np.array(obj.matrix_world, dtype=np.float64)[:3, 3]
    direction = np.array(step["direction"]) / (np.linalg.norm(step["direction"]) or 1.0)
    obj.location = obj.location + type(obj.location)(direction * step["amount"] * checks.size_of(before[obj.name]))
    bpy.context.view_layer.update()
    drivers = drivers_of(obj)
    if len(drivers) != 1 or len(bindings_of(obj)) != 1 or not translates(obj) or \
            'ARMATURE' in {m.type for m in obj.modifiers}:
        return "done, not checked"
    cage = drivers[0]
    moved_along = cage.parent == obj
    shift = np.array(obj.matrix_world, dtype=np.float64)[:3, 3] - start if moved_along else np.zeros(3)
    checks.check_moved([obj.name], before, checks.world_positions(), shift,
                       checks.size_of(before.get(cage.name, np.zeros((0, 3)))), "the mesh stays with its cage")
    return f"done, {'moved with' if moved_along else 'stayed with'} {cage.name}"


STEPS = {name: globals()[name] for name in (
    "bind", "rebind", "unbind", "translate_cage", "edit_cage", "cage_topology", "mesh_topology",
    "delete", "apply", "duplicate", "save_reload", "bake", "show_field", "clear_field", "make_cage",
    "frame", "object_scale", "edit_mode", "rename", "parent_cage", "move_mesh")}


def run(state, step):
    try:
        return STEPS[step["op"]](state, step)
    except Refused as refusal:
        return f"refused: {refusal}"
    except Skipped as skipped:
        return f"skipped: {skipped}"


