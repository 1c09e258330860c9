"""The worker's watch on its supervisor's heartbeat word."""

from array import array

from rtcf._core._executor import ABORT, StopFlag
from rtcf._runtime._worker import heartbeat_watch


def test_the_watch_fires_after_limit_iterations_without_a_beat_and_not_before() -> None:
    beat = array("q", [7])
    stop = StopFlag()
    watch = heartbeat_watch(beat, 3, stop)
    for _ in range(2):
        watch()
    assert not watch.fired and stop.cell[0] == 0
    beat[0] += 1  # a sign of life: the count starts again
    for _ in range(3):  # the one that sees the beat, then two without one
        watch()
    assert not watch.fired
    watch()
    assert watch.fired and stop.cell[0] == ABORT
    watch.release()
    watch()  # released: nothing happens (the words may be gone)
