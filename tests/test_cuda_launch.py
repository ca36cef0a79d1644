"""PreparedLaunch's bookkeeping (physics/cuda/launch.py), without a GPU: the plain
path puts each step's values at their positions, a prepared launch updates its
scalar slots in place, and a launch refused before it is queued falls back."""

import ctypes

from grainfrac.physics.cuda import launch
from grainfrac.physics.cuda.launch import PreparedLaunch


class FakeDispatcher:
    """``dispatcher[grid, block](*args)`` records its calls."""

    def __init__(self):
        self.calls = []

    def __getitem__(self, config):
        return lambda *args: self.calls.append((config, args))


def test_plain_launches_put_the_varying_values_in_place():
    kernel = FakeDispatcher()
    step = PreparedLaunch(kernel, 4, 32, (0, 1.5, "u", 0, "v"), varying=(0, 3))
    assert not step.prepared  # no numba-cuda kernel object here: launched as usual
    step(7, 1)
    step(8, 0)
    assert kernel.calls == [((4, 32), (7, 1.5, "u", 1, "v")), ((4, 32), (8, 1.5, "u", 0, "v"))]


def test_prepared_launches_update_their_slots_and_fall_back_when_refused():
    kernel = FakeDispatcher()
    step = PreparedLaunch(kernel, 2, 64, (0, "u"), varying=(0,))
    slot = ctypes.c_int64(0)
    seen = []

    def fake_launch(stream, config, function, *args):
        seen.append(args[0].value)
        if len(seen) == 2:
            raise TypeError("refused")

    step._fast = (fake_launch, None, None, None, [slot, "u-pointer"], [slot])
    before = dict(launch.counts)
    step(3)
    assert seen == [3] and kernel.calls == []
    step(4)  # refused: launched through the dispatcher, and from then on
    step(5)
    assert seen == [3, 4] and not step.prepared
    assert kernel.calls == [((2, 64), (4, "u")), ((2, 64), (5, "u"))]
    assert launch.counts["plain"] == before["plain"] + 1
