"""The add-on's errors, one family: each message says what is wrong, and what to do, in
Blender's terms. The operators report them as errors (scripts: ``bpy.ops`` raises
RuntimeError with the message); anything else is an internal error."""


class GenCoordsError(Exception):
    """Something the artist can fix; the message says what and how."""


class BindError(GenCoordsError):
    """Binding is impossible."""


class BakeError(GenCoordsError):
    """Bake to Bones is impossible for this binding."""


class CageError(GenCoordsError):
    """Make Cage cannot make a cage around this mesh."""
