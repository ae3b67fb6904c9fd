"""Work done in steps: generators that yield the fraction done (0 to 1) and return their
result, so a modal operator shows progress and takes Esc between steps (closing the
generator cancels) while scripts run them to the end. A leaf."""


def scaled(steps, start, span):
    """``steps``' fractions as ``start + span * fraction`` (one part of a longer job);
    returns ``steps``' result. Closing it closes ``steps``."""
    try:
        while True:
            try:
                fraction = next(steps)
            except StopIteration as done:
                return done.value
            yield start + span * fraction
    finally:
        steps.close()


def run_to_end(steps, report=None):
    """``steps``' result, computed to the end; ``report(fraction)`` on the way."""
    while True:
        try:
            fraction = next(steps)
        except StopIteration as done:
            return done.value
        if report is not None:
            report(fraction)


def at_once(value):
    """Steps that yield nothing and return ``value``, computed before: work done in one step
    where a caller takes steps."""
    return value
    yield  # makes this a generator
