"""What the modal operators (Bind, Make Cage, Bake to Bones) share: their steps run in
slices a timer event, and what they answer to that event."""

import time

from ...core.planning import bind_steps

# What a modal operator answers to its timer's event while it keeps running: passed on,
# not consumed. Blender redraws the 3D View after every event a modal operator consumes
# (a bare modal operator: 5 timer events, 5 redraws; passed on: none), and a redraw of a
# 43k-vertex character took 0.15 to 0.45 s in a software-rendered window: a Bind from the
# panel took 1.7 to 2.4 times a script's (scripts/release/gui_bind_timing.py).
TIMER_HANDLED = {'PASS_THROUGH'}


class SlicedSteps:
    """A modal operator's steps run a slice a timer event, each slice as long as
    ``bind_steps.slice_seconds`` says after what the window took since the last."""

    def __init__(self, steps):
        self.steps, self.returned, self.fraction = steps, time.perf_counter(), 0.0

    def advance(self, seconds=None):
        """The next slice (``seconds`` long, default from what the window took since the
        last): its last fraction; StopIteration (with the result) at the end."""
        if seconds is None:
            seconds = bind_steps.slice_seconds(time.perf_counter() - self.returned)
        try:
            self.fraction = bind_steps.advance(self.steps, seconds, self.fraction, bind_steps.TAIL_SECONDS)
            return self.fraction
        finally:
            self.returned = time.perf_counter()

    def first(self):
        """The first slice, run by invoke before the window redraws (the longest a slice
        may be): a short job ends in it, without a progress bar or a redraw between its
        steps (in a software-rendered window that redraw took 0.35 to 0.4 s of a 43k
        character's 1.3 s Bind)."""
        return self.advance(bind_steps.MAX_SLICE_SECONDS)

    def close(self):
        self.steps.close()
