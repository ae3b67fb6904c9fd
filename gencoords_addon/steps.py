"""Work done in steps: generators that yield the fraction done (0 to 1) and return their
result, so a modal operator shows progress and takes Esc between steps (closing the
generator cancels) while scripts run them to the end. The core's (``scaled``,
``run_to_end``: ``core.planning.bind_steps``), and :func:`at_once`. A leaf."""

from ..core.planning.bind_steps import run_to_end, scaled

__all__ = ["at_once", "run_to_end", "scaled"]


def at_once(value):
    """Steps that yield nothing and return ``value``, computed before: work done in one step
    where a caller takes steps."""
    return value
    yield  # makes this a generator
