"""Blender I/O: mesh arrays in and out (``mesh_arrays``), the evaluated meshes a Bind reads
(``mesh_io``) and what differs between Blender versions (``compat``)."""
