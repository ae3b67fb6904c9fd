"""The node graph: the deformer's Geometry Nodes group, its helpers and their builder."""
