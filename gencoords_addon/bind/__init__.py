"""Bind: the settings and the scene read (``scene``), the job around the core's planner
(``job``), writing a binding (``commit``), its attributes on the mesh (``attributes``), the
bindings in the file (``bindings``) and Make Cage (``cage_maker``)."""
