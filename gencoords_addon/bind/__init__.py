"""Bind: the planning's glue, the bindings in the file, the bind data's attributes."""
