"""The add-on's errors: each message says what is wrong, and what to do, in Blender's terms."""


class BindError(Exception):
    """Binding is impossible; the message says why in Blender's terms."""
