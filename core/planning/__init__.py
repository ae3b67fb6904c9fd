"""Planning a Bind: what it computes and stores, and its steps, without Blender."""
