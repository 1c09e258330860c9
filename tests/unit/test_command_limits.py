"""Limits at the hardware's edge (rtcf._core._command_limits): what a hardware
component's command input passes on, clamps and refuses, in the loop on the simulated
clock; the counts and the report; whose fault an infinite command is."""

from __future__ import annotations

import gc
import math
import sys
import tracemalloc

import numpy as np
import pytest

import rtcf
from rtcf import ComponentSpec, JointLimits
from rtcf._core._clock import SimClock
from rtcf.testing import run_components

NAN, INF = math.nan, math.inf


class Hardware(rtcf.Component):
    """Records what its command input gave it in each iteration."""

    interface = "effort"
    limits = {"a": JointLimits(max_effort=10.0), "b": JointLimits(max_effort=5.0)}

    def configure(self) -> None:
        self.command = self.add_command_input("command", self.interface, ["a", "b"],
                                              self.limits)
        self.took: list[np.ndarray | None] = []

    def update(self) -> None:
        value = self.command.read()
        self.took.append(None if value is None else value.copy())


class PositionHardware(Hardware):
    interface = "position"
    limits = {"a": JointLimits(min_position=-1.0, max_position=1.0, max_velocity=100.0),
              "b": JointLimits(min_position=0.0, max_position=2.0)}


class Writer(rtcf.Component):
    """Writes ``~values[i]`` in iteration i (the last one after)."""

    def configure(self) -> None:
        self.out = self.add_output("command", np.ndarray)
        self.values = self.params.get("~values")

    def update(self) -> None:
        k = min(self.iteration, len(self.values) - 1)
        self.out.write(np.array(self.values[k], dtype=float))


def _run(hardware, values, *, policy=None, iterations=None, params=None, **kw):
    specs = [ComponentSpec("writer", Writer, params={"values": values},
                           **({"policy": policy} if policy else {})),
             ComponentSpec("hw", hardware, params=params or {})]
    return run_components(specs, iterations or len(values), frequency=100.0, **kw)


def test_good_commands_pass_unchanged_and_out_of_range_ones_are_clamped():
    trace = _run(Hardware, [[1.0, 2.0], [20.0, -7.0], [3.0, 4.0]])
    hw = trace.components["/hw"]
    assert [t.tolist() for t in hw.took] == [[1.0, 2.0], [10.0, -5.0], [3.0, 4.0]]
    guard = hw._rtcf_guards["command"]
    assert guard.clamped.tolist() == [1, 1]
    assert guard.refused == 0
    # the topic holds what the hardware took once it was checked
    assert trace.outputs["/command"][1].tolist() == [10.0, -5.0]


def test_a_nan_command_is_never_passed_on_and_the_previous_one_is_held():
    trace = _run(Hardware, [[1.0, 2.0], [NAN, 2.0], [1.5, NAN], [3.0, 4.0]])
    hw = trace.components["/hw"]
    assert [t.tolist() for t in hw.took] == [[1.0, 2.0], [1.0, 2.0], [1.0, 2.0], [3.0, 4.0]]
    guard = hw._rtcf_guards["command"]
    assert (guard.nan, guard.infinite, guard.malformed) == (2, 0, 0)
    summary = trace.result.command_limits["/hw.command"]
    assert summary["refused_not_a_number"] == 2
    assert summary["topic"] == "/command"


def test_a_first_command_that_is_refused_leaves_nothing_to_hold():
    trace = _run(Hardware, [[NAN, 1.0], [1.0, 1.0]])
    assert trace.components["/hw"].took[0] is None
    assert trace.components["/hw"].took[1].tolist() == [1.0, 1.0]


def test_a_command_of_the_wrong_shape_or_type_is_refused():
    trace = _run(Hardware, [[1.0, 2.0], [1.0, 2.0, 3.0], [3.0]])
    hw = trace.components["/hw"]
    assert [t.tolist() for t in hw.took] == [[1.0, 2.0]] * 3
    assert hw._rtcf_guards["command"].malformed == 2


def test_an_infinite_command_is_the_writers_fault_under_its_policy():
    """Default policy stop: the loop stops, naming the writer, after the hardware ran on
    the held command."""
    with pytest.raises(rtcf.ComponentError) as err:
        _run(Hardware, [[1.0, 2.0], [INF, 2.0], [3.0, 4.0]])
    text = str(err.value)
    assert text.startswith("component '/writer': wrote an infinite effort command to /command")
    assert "/hw refused" in text
    assert err.value.component == "/writer"


def test_an_infinite_command_deactivates_the_writer_when_its_policy_says_so():
    from rtcf._core._faults import FailurePolicy

    trace = _run(Hardware, [[1.0, 2.0], [INF, 2.0], [3.0, 4.0]], iterations=5,
                 policy=FailurePolicy(on_error="deactivate"))
    hw = trace.components["/hw"]
    assert all(t.tolist() == [1.0, 2.0] for t in hw.took[:2])
    faults = trace.result.faults
    assert [f.component for f in faults] == ["/writer"]
    assert "infinite effort command" in faults[0].error


def test_position_commands_are_bounded_and_rate_limited_as_joint_limits_does():
    # 100 rad/s at 100 Hz: 1 rad per period at most for joint a; b has no velocity limit
    trace = _run(PositionHardware, [[0.0, 0.5], [0.9, 3.0], [-1.5, -1.0], [-1.5, 1.0]])
    took = [t.tolist() for t in trace.components["/hw"].took]
    assert took[0] == [0.0, 0.5]
    assert took[1] == [0.9, 2.0]  # b to its max
    assert took[2] == pytest.approx([-0.1, 0.0])  # a: one period's change from 0.9
    assert took[3] == pytest.approx([-1.0, 1.0])  # a: within its range again


def test_the_launch_file_tightens_the_limits_and_cannot_widen_them():
    params = {"joint_limits": {"a": {"max_effort": 2.0}, "b": {"max_effort": 50.0}}}
    trace = _run(Hardware, [[9.0, 9.0]], params=params)
    assert trace.components["/hw"].took[0].tolist() == [2.0, 5.0]


def test_a_launch_files_limit_that_is_no_number_is_named():
    params = {"joint_limits": {"a": {"max_effort": "lots"}}}
    with pytest.raises(rtcf.RtcfError, match=r"joint_limits\.a\.max_effort is 'lots'"):
        _run(Hardware, [[1.0, 1.0]], params=params)


@pytest.mark.parametrize("limits, text", [
    (dict(min_position=1.0, max_position=0.0), "min_position 1 is above max_position 0"),
    (dict(max_effort=-1.0), "max_effort is -1.0; give a magnitude above 0"),
    (dict(max_velocity=NAN), "max_velocity is nan; give a number"),
])
def test_wrong_limits_are_refused(limits, text):
    with pytest.raises(rtcf.ConfigurationError, match=text):
        JointLimits(**limits)


def test_nothing_is_logged_per_iteration():
    trace = _run(Hardware, [[20.0, 0.0]] * 250, iterations=250)  # 2.5 s at 100 Hz
    guard = trace.components["/hw"]._rtcf_guards["command"]
    assert guard.clamped.tolist() == [250, 0]
    # logged at 0 s, 1 s and 2 s; the two later records count what came between
    assert guard._unsaid[3] == 49


def _feed(guard, value):
    slot = guard.port._slot
    slot.value = np.array(value, dtype=float)
    slot.seq += 1
    guard()
    return slot.value.tolist()


def test_a_restarted_hardware_takes_its_first_command_without_a_rate_limit():
    from rtcf._core._command_limits import Counters

    hw = PositionHardware()
    hw.configure()
    guard = hw._rtcf_guards["command"]
    guard.prepare(0.01, Counters())  # 100 rad/s: 1 rad per period for joint a
    assert _feed(guard, [0.0, 1.0]) == [0.0, 1.0]
    assert _feed(guard, [-0.9, 1.0]) == pytest.approx([-0.9, 1.0])
    assert _feed(guard, [0.9, 1.0]) == pytest.approx([0.1, 1.0])  # 1 rad from -0.9
    guard.reset()  # what activation does: the arm may have moved while inactive
    assert _feed(guard, [0.9, 1.0]) == pytest.approx([0.9, 1.0])


def test_diagnostics_count_the_clamps_and_refusals_and_warn_on_a_refusal():
    from rtcf._core._timing import TimingAggregate
    from rtcf._runtime._health import health
    from rtcf._runtime._live_status import LiveStatus

    def status(clamped, refused):
        return LiveStatus(
            iterations=10, overruns=0, jitter_p999_us=1.0, calc_p999_us=1.0,
            calc_max_us=1.0, log_records_dropped=0, elapsed_s=0.1,
            commands_clamped=clamped, commands_refused=refused)

    clamped = health("/rt_runner", status(7, 0), TimingAggregate())
    assert not clamped.warn  # limits doing their job: said, not a warning
    assert dict(clamped.values)["commands clamped to limits"] == "7"
    assert "commands clamped 7, refused 0" in clamped.message
    refused = health("/rt_runner", status(7, 2), TimingAggregate())
    assert refused.warn
    assert dict(refused.values)["commands refused (not finite)"] == "2"


def test_the_end_of_run_line_says_what_the_limits_did_and_nothing_when_idle():
    from rtcf._core._command_limits import describe_summary

    summary = {"topic": "/arm/effort_command", "interface": "effort", "joints": ["a", "b"],
               "clamped": {"a": 0, "b": 3}, "refused_not_a_number": 1,
               "refused_infinite": 0, "refused_malformed": 0}
    assert describe_summary("/arm/hw.effort_command", summary) == (
        "limits: command input '/arm/hw.effort_command' (/arm/effort_command, effort): "
        "clamped b 3 times; refused 1 not a number (the previous command held)")
    idle = dict(summary, clamped={"a": 0, "b": 0}, refused_not_a_number=0)
    assert describe_summary("/arm/hw.effort_command", idle) == ""

class SameWriter(rtcf.Component):
    """Writes the same array, within the limits, in every iteration (allocates nothing)."""

    def configure(self) -> None:
        self.out = self.add_output("command", np.ndarray)
        self.value = np.array([0.5, 0.5])

    def update(self) -> None:
        self.out.write(self.value)


def _reading_only(hardware):
    """``hardware`` that reads its command and keeps nothing of it."""
    return type(hardware.__name__, (hardware,), {"update": lambda self: self.command.read()})


@pytest.mark.parametrize("hardware", [Hardware, PositionHardware])
def test_the_check_of_a_good_command_allocates_nothing(hardware):
    """The common path (finite, within the limits) in the loop: no memory grows, and
    one check allocates nothing even for a moment (a reduction such as ``ok.all()``
    or ``changed.any()`` allocated about 900 B, beyond pymalloc, in every check)."""
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=1000.0), clock=SimClock(),
                         log_level="warning")
    writer = runner.load(ComponentSpec("writer", SameWriter))
    runner.load(ComponentSpec("hw", _reading_only(hardware)))
    try:
        runner.run(1000)
        gc.collect()
        before = sys.getallocatedblocks()
        runner.run(20_000)
        gc.collect()
        grown = sys.getallocatedblocks() - before
        (guard,) = runner._schedule.guards()
        assert guard.clamped.tolist() == [0, 0] and guard.refused == 0
        write, value = writer.out.write, writer.value
        tracemalloc.start()
        try:
            peaks = []
            for _ in range(200):
                write(value)  # a new command for the guard
                now, _ = tracemalloc.get_traced_memory()
                tracemalloc.reset_peak()
                guard()
                peaks.append(tracemalloc.get_traced_memory()[1] - now)
        finally:
            tracemalloc.stop()
    finally:
        runner.shutdown()
    assert grown < 200, f"{grown} blocks more after 20,000 iterations"
    median = sorted(peaks)[len(peaks) // 2]
    assert median < 256, f"a check allocated {median} B (the median of 200)"


def _guard(hardware):
    from rtcf._core._command_limits import Counters

    hw = hardware()
    hw.configure()
    guard = hw._rtcf_guards["command"]
    guard.prepare(0.01, Counters())  # PositionHardware: 1 rad per period for joint a
    return guard


def _give(guard, value):
    slot = guard.port._slot
    slot.value = value
    slot.seq += 1
    guard()
    return slot.value


def test_a_float_command_of_another_dtype_is_checked_and_passed_on_as_float64():
    guard = _guard(Hardware)  # effort: a within 10, b within 5
    taken = _give(guard, np.array([1.0, 2.0], dtype=np.float32))
    assert taken.dtype == np.float64 and taken.tolist() == [1.0, 2.0]
    assert guard.last is taken and guard.refused == 0
    taken = _give(guard, np.array([20.0, 2.0], dtype=">f8"))  # byte-swapped, clamped
    assert taken.dtype == np.float64 and taken.tolist() == [10.0, 2.0]
    assert guard.clamped.tolist() == [1, 0]
    held = _give(guard, np.array([NAN, 2.0], dtype=np.float32))
    assert held is guard.last and held.tolist() == [10.0, 2.0] and guard.nan == 1
    _give(guard, np.array([1, 2]))  # integers: not a command
    assert guard.malformed == 1


def test_a_view_of_a_command_is_checked_as_it_is():
    guard = _guard(Hardware)
    every_other = np.array([1.0, 0.0, 2.0, 0.0])[::2]
    assert _give(guard, every_other) is every_other
    assert _give(guard, np.array([0.0, 20.0, 0.0, 30.0])[1::2]).tolist() == [10.0, 5.0]


def test_the_rate_limit_holds_for_a_writer_that_changes_its_array_in_place():
    """The check keeps its own copy of the last command passed on: a writer that
    writes the same array again, changed in place, is still limited to a period's
    change from what it passed on before."""
    guard = _guard(PositionHardware)
    command = np.array([0.0, 1.0])
    _give(guard, command)
    command[0] = 0.9  # within [-1, 1], but 0.9 rad in one period: 1 rad is the limit
    assert _give(guard, command).tolist() == [0.9, 1.0]
    command[0] = -0.5  # 1.4 rad from 0.9
    assert _give(guard, command).tolist() == pytest.approx([-0.1, 1.0])
