"""Bake: a binding turned into what exporters and game engines know (an armature and
vertex groups, ``bones``)."""
