"""Evaluation: the cage object, the public coordinate functions, row evaluation and workers."""
