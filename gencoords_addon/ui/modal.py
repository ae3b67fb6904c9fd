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
        self.steps, self.returned = steps, time.perf_counter()

    def advance(self):
        """The next slice: its last fraction; StopIteration (with the result) at the end."""
        seconds = bind_steps.slice_seconds(time.perf_counter() - self.returned)
        try:
            return bind_steps.advance(self.steps, seconds)
        finally:
            self.returned = time.perf_counter()

    def close(self):
        self.steps.close()
