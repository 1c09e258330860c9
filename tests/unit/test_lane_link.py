"""The words that tie lanes together (rtcf._runtime._lanes.LaneLink), two lanes in one
process: how a stop is agreed, on a simulated clock where every lane waits for the
others after each iteration."""

from __future__ import annotations

import threading
from array import array

from rtcf._core._executor import CONTROL, StopFlag
from rtcf._core._lanes import Lane
from rtcf._core._loop_state import LoopState
from rtcf._runtime._lanes import W_STOP_AT, LaneLink, init_words, layout


def _links() -> tuple[LaneLink, LaneLink, StopFlag, StopFlag, memoryview]:
    lanes = layout({"main": Lane("main", ()), "right": Lane("right", ())}, {})
    buf = memoryview(bytearray(lanes.size))
    init_words(buf, lanes)
    links = []
    stops = []
    for name in lanes.lanes:
        link = LaneLink(buf, lanes, name, simulated=True, period_ns=1_000_000)
        stop = StopFlag(array("q", [0]))
        link.bound(LoopState(1000.0), stop, lambda: 0)
        links.append(link)
        stops.append(stop)
    return links[0], links[1], stops[0], stops[1], buf


def _iteration(link: LaneLink, i: int) -> None:
    link.state.iteration = i
    link.feeder()
    link.after()


def test_a_request_after_a_lanes_after_does_not_end_its_loop_where_others_wait() -> None:
    # both lanes done with iteration 5, neither asked to stop yet
    main, right, main_stop, right_stop, _ = _links()
    other = threading.Thread(target=_iteration, args=(right, 5))
    other.start()
    _iteration(main, 5)
    other.join(5)
    assert not other.is_alive()
    # now the supervisor asks both for a control stop (use_sim_time): their loops read
    # their own decision, so neither ends before the next iteration's after()
    main_stop.set(CONTROL)
    right_stop.set(CONTROL)
    assert main.decision.cell[0] == 0 and right.decision.cell[0] == 0
    other = threading.Thread(target=_iteration, args=(right, 6))
    other.start()
    _iteration(main, 6)
    other.join(5)
    assert not other.is_alive()
    assert main.decision.cell[0] == CONTROL and right.decision.cell[0] == CONTROL
    assert main.words[W_STOP_AT] == 6


def test_a_lane_waiting_for_another_stops_where_that_one_stopped() -> None:
    main, right, main_stop, _, _ = _links()
    other = threading.Thread(target=_iteration, args=(right, 5))
    other.start()  # right waits at its barrier for main's iteration 5
    main_stop.set(CONTROL)  # main is asked to stop and stops after 5
    _iteration(main, 5)
    other.join(5)
    assert not other.is_alive(), "right still waits for an iteration main never runs"
    assert right.decision.cell[0] == CONTROL and right.stopped_here
    assert main.words[W_STOP_AT] == 5


def test_a_stop_asked_before_a_run_begins_runs_no_iteration_in_any_lane() -> None:
    main, right, main_stop, _, _ = _links()
    main_stop.set(CONTROL)  # a request came while the lanes were getting ready
    starts: dict[str, tuple[int, int, int]] = {}
    other = threading.Thread(target=right.begin, args=(
        1, 10_000, None, lambda *a: starts.__setitem__("right", a)))
    other.start()
    main.begin(1, 10_000, None, lambda *a: starts.__setitem__("main", a))
    other.join(5)
    assert not other.is_alive()
    # both would start at iteration 0, but their loops end before it
    assert starts["main"][0] == starts["right"][0] == 0
    assert main.decision.cell[0] == CONTROL and right.decision.cell[0] == CONTROL
    assert main.words[W_STOP_AT] == -1
