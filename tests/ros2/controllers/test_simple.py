"""rtcf_controllers' joint_state_broadcaster, forward_command_controller (and its
position/velocity/effort siblings) and pid_controller, in-process on the simulated
clock (rtcf.testing): configured, with a joint_trajectory_controller and a
diff_drive_controller, by one ros2_controllers YAML file through a ROS 2 launch
file; commands refused as ros2_controllers refuses them; the PID against numbers
worked out by hand from control_toolbox's formulas."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import MultiDOFCommand
from geometry_msgs.msg import TwistStamped
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import rtcf
from rtcf import GoalStatus
from rtcf.testing import SILENCE, Goal, run_components, run_launch
from rtcf_controllers import (
    DiffDriveController,
    ForwardCommandController,
    JointGroupEffortController,
    JointGroupPositionController,
    JointStateBroadcaster,
    JointTrajectoryController,
    PidController,
)
from rtcf_controllers._jtc_settings import Cadence

FIXTURES = Path(__file__).parent / "fixtures"


def _command(*values: float) -> Float64MultiArray:
    return Float64MultiArray(data=list(values))


def _reference(values: list[float], dots: list[float] | None = None,
               names: list[str] | None = None) -> MultiDOFCommand:
    return MultiDOFCommand(dof_names=names or [], values=values, values_dot=dots or [])


def _records(caplog: pytest.LogCaptureFixture, words: str) -> list[str]:
    return [r.getMessage() for r in caplog.records if words in r.getMessage()]


# -- a ros2_controllers YAML file, through a ROS 2 launch file ------------------------


def _head_goal() -> Goal:
    """head_pan_joint alone (allow_partial_joints_goal) to 0.4 rad in 0.3 s."""
    point = JointTrajectoryPoint(positions=[0.4], time_from_start=Duration(nanosec=300_000_000))
    return Goal(FollowJointTrajectory.Goal(trajectory=JointTrajectory(
        joint_names=["head_pan_joint"], points=[point])), id=1)


def _cmd_vel(linear: float) -> TwistStamped:
    message = TwistStamped()  # stamp 0: now
    message.twist.linear.x = linear
    return message


def test_a_ros2_controllers_yaml_file_configures_every_controller() -> None:
    command = _command(0.5, -0.25, 1.0)
    trace = run_launch(
        str(FIXTURES / "simple.launch.xml"), 1000,
        inputs={
            "/forward_position_controller/commands": command,
            "/wheel_pid_controller/reference": _reference([1.0], [0.0], ["wheel_joint"]),
            # 2 m/s, over the YAML file's 0.8 m/s limit, for 0.5 s; then nothing
            "/base_controller/cmd_vel": [_cmd_vel(2.0)] * 500 + [SILENCE],
        },
        actions={"/head_controller/follow_joint_trajectory": {0: _head_goal()}},
    )
    c = trace.components
    jsb = c["/joint_state_broadcaster"]
    assert isinstance(jsb, JointStateBroadcaster)
    assert (jsb.names, jsb.frame_id) == (
        ["joint1", "joint2", "joint3", "gripper_finger"], "arm_base_link")
    assert type(c["/forward_position_controller"]) is ForwardCommandController
    assert c["/forward_position_controller"].interface_name == "position"
    assert c["/arm_effort_controller"].interface_name == "effort"  # fixed by its class
    gains = c["/wheel_pid_controller"].pids[0].gains
    assert (gains.p, gains.i, gains.d, gains.i_clamp_max, gains.antiwindup) == (
        200.0, 2.0, 40.0, 5.0, True)
    assert [type(x).ros2_control_type for x in c.values() if hasattr(x, "ros2_control_type")] == [
        "joint_state_broadcaster/JointStateBroadcaster",
        "forward_command_controller/ForwardCommandController",
        "effort_controllers/JointGroupEffortController",
        "pid_controller/PidController",
        "joint_trajectory_controller/JointTrajectoryController",
        "diff_drive_controller/DiffDriveController",
    ]
    head = c["/head_controller"]
    assert isinstance(head, JointTrajectoryController)
    assert (head.joints, head.cfg.allow_partial) == (["head_pan_joint", "head_tilt_joint"], True)
    assert (head.cfg.feedback, head.cfg.state) == (Cadence(1, 100), Cadence(1, 40))  # 10, 25 Hz
    tolerances = head.cfg.defaults  # constraints: goal 0.01, stopped velocity 0.05
    assert (tolerances.goal_time, tolerances.goal[:2].tolist(), tolerances.path[0].tolist()) == (
        0.5, [[0.01, 0.01], [0.05, 0.05]], [0.2, 0.2])
    base = c["/base_controller"]
    assert isinstance(base, DiffDriveController)
    assert (base.separation, base.left_radius, base.timeout_ns) == (0.4, 0.1, 250_000_000)

    # the command reached the arm, and /joint_states says so at the broadcaster's 100 Hz
    assert trace.last("/arm/position_command").tolist() == [0.5, -0.25, 1.0]
    states = trace.outputs["/joint_states"]
    assert [k for k in range(30)
            if states[k].header.stamp != states[k - 1].header.stamp] == [0, 10, 20]
    last = trace.last("/joint_states")
    assert list(last.name) == ["joint1", "joint2", "joint3", "gripper_finger"]
    assert list(last.position) == [0.5, -0.25, 1.0, 0.0]
    assert list(last.effort) == [1.5, 1.5, 1.5, 0.0]
    assert last.header.frame_id == "arm_base_link"
    assert (last.header.stamp.sec, last.header.stamp.nanosec) == (0, 990_000_000)
    first = states[0]  # the arm's initial positions, before the command's first period
    assert list(first.position)[:3] == [0.0, 0.3, 0.6]

    # the wheel's PID (p 200, d 40 on a 2 kg mass: critically damped) brought it to 1.0
    wheel = trace.last("/wheel/position")
    assert wheel[0] == pytest.approx(1.0, abs=0.01)
    state = trace.last("/wheel_pid_controller/controller_state").dof_states[0]
    assert (state.name, state.reference, state.feedback) == ("wheel_joint", 1.0, wheel[0])
    assert state.output == trace.last("/wheel/effort_command")[0]
    assert state.time_step == pytest.approx(0.001)

    # the head's partial goal: followed to SUCCEEDED, feedback at 10 Hz, the tilt held
    goal = trace.actions["/head_controller/follow_joint_trajectory"].goals[1]
    assert goal.status == GoalStatus.SUCCEEDED
    assert [i for i, _ in goal.feedback][:3] == [0, 100, 200]
    assert trace.last("/head/position").tolist() == pytest.approx([0.4, 0.0])
    head_states = trace.outputs["/head_controller/controller_state"]
    assert head_states[40].header.stamp.nanosec - head_states[39].header.stamp.nanosec == (
        40_000_000)  # 25 Hz

    # the base: the wheels at the limit (0.8 m/s on 0.1 m wheels) while cmd_vel comes,
    # stopped within cmd_vel_timeout (0.25 s) of the last one; odom in the YAML's frames
    wheels = [v.tolist() for v in trace.outputs["/base/velocity_command"]]
    assert wheels[499] == pytest.approx([8.0, 8.0])
    assert wheels[-1] == [0.0, 0.0]
    assert 499 < wheels.index([0.0, 0.0], 1) <= 499 + 250 + 1
    odom = trace.last("/base_controller/odom")
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    assert odom.pose.pose.position.x == pytest.approx(trace.last("/base/position")[0] * 0.1)


# -- forward_command_controller ---------------------------------------------------------


def _forward(cls: type = ForwardCommandController, **params: object) -> rtcf.ComponentSpec:
    params = {"joints": ["j1", "j2", "j3"], "interface_name": "velocity", **params}
    return rtcf.ComponentSpec("forward", cls, params=params)


def test_a_command_of_the_wrong_length_is_refused_and_logged_once_per_occurrence(
    caplog: pytest.LogCaptureFixture,
) -> None:
    good, short = _command(1.0, 2.0, 3.0), _command(4.0, 5.0)
    # at 100 Hz: good, then a short one in iterations 1-3, good, and short again 2 s later
    fed = [good, short, short, short, good] + [good] * 195 + [short, _command(7.0, 8.0, 9.0)]
    with caplog.at_level(logging.WARNING):
        trace = run_components([_forward()], len(fed), frequency=100.0,
                               inputs={"/forward/commands": fed})
    written = [v.tolist() for v in trace.outputs["/velocity_command"]]
    assert written[:5] == [[1.0, 2.0, 3.0]] * 5  # the short ones never applied
    assert written[-2:] == [[1.0, 2.0, 3.0], [7.0, 8.0, 9.0]]
    refused = _records(caplog, "refused")
    # one record per occurrence, the repeats within a second counted on the next one
    assert refused == [
        "/forward/commands refused: 2 values for 3 joints (j1, j2, j3); the last command stays",
        "/forward/commands refused: 2 values for 3 joints (j1, j2, j3); the last command "
        "stays (2 more like it since the last record)",
    ]


def test_a_command_that_is_not_finite_is_refused_and_nothing_is_written_before_the_first(
    caplog: pytest.LogCaptureFixture,
) -> None:
    fed = [_command(1.0, math.nan, 3.0), _command(1.0, 2.0, 3.0)]
    with caplog.at_level(logging.WARNING):
        trace = run_components([_forward(JointGroupPositionController)], 2,
                               inputs={"/forward/commands": fed})
    assert trace.outputs["/position_command"][0] is None
    assert trace.outputs["/position_command"][1].tolist() == [1.0, 2.0, 3.0]
    assert _records(caplog, "not finite") == [
        "/forward/commands refused: position of j2 is nan (not finite); the last "
        "command stays"]
    # interface_name is the class's: velocity in the parameters is named and ignored
    assert _records(caplog, "interface_name 'velocity' ignored")


def test_the_effort_controller_leaves_zero_effort_when_it_stops() -> None:
    spec = _forward(JointGroupEffortController, interface_name="effort")
    trace = run_components([spec], 3, inputs={"/forward/commands": _command(1.0, 2.0, 3.0)})
    assert trace.outputs["/effort_command"][-1].tolist() == [1.0, 2.0, 3.0]
    forward = trace.components["/forward"]
    assert forward.command._slot.value.tolist() == [0.0, 0.0, 0.0]  # written by stop()


def test_missing_joints_or_interface_are_configuration_errors() -> None:
    with pytest.raises(rtcf.RtcfError, match=r"'joints' is \[\]; give a list of at least one"):
        run_components([_forward(joints=[])], 1)
    with pytest.raises(rtcf.RtcfError, match=r"'interface_name' is empty"):
        run_components([_forward(interface_name="")], 1)


# -- joint_state_broadcaster ------------------------------------------------------------


def _jsb(**params: object) -> rtcf.ComponentSpec:
    return rtcf.ComponentSpec("jsb", JointStateBroadcaster, params=params)


def test_joint_states_carry_the_joints_values_names_stamp_and_frame_id(
    caplog: pytest.LogCaptureFixture,
) -> None:
    q = [np.array([0.1, 0.2]), np.array([0.3, 0.4]), np.array([9.0, 9.0, 9.0])]
    with caplog.at_level(logging.WARNING):
        trace = run_components(
            [_jsb(joints=["shoulder", "elbow"], extra_joints=["finger"], frame_id="base")],
            3, frequency=100.0,
            inputs={"/position": q, "/velocity": np.array([1.0, -1.0])},
        )
    states = trace.outputs["/joint_states"]
    assert [list(s.position) for s in states] == [
        [0.1, 0.2, 0.0], [0.3, 0.4, 0.0], [0.3, 0.4, 0.0]]  # the 3-value array ignored
    last = states[-1]
    assert list(last.name) == ["shoulder", "elbow", "finger"]
    assert list(last.velocity) == [1.0, -1.0, 0.0]
    assert [math.isnan(e) for e in last.effort] == [True, True, False]  # effort: no value
    assert last.header.frame_id == "base"
    assert (last.header.stamp.sec, last.header.stamp.nanosec) == (0, 20_000_000)
    assert _records(caplog, "has 3 values for 2 joints (shoulder, elbow)")
    assert trace.components["/jsb"].refused_messages == {
        "position": 1, "velocity": 0, "effort": 0}
    dynamic = trace.last("/dynamic_joint_states")
    assert list(dynamic.joint_names) == ["shoulder", "elbow", "finger"]
    assert [list(v.interface_names) for v in dynamic.interface_values] == [
        ["position", "velocity", "effort"]] * 3
    assert list(dynamic.interface_values[1].values)[:2] == [0.4, -1.0]


def test_joints_and_interfaces_select_what_is_read_and_the_rest_is_nan() -> None:
    trace = run_components(
        [_jsb(joints=["a"], interfaces=["position"], use_local_topics=True,
              publish_dynamic_joint_states=False)],
        1, inputs={"/position": np.array([0.5])},
    )
    jsb = trace.components["/jsb"]
    assert list(jsb.inputs) == ["position"]
    assert "/dynamic_joint_states" not in trace.outputs
    msg = trace.last("/jsb/joint_states")  # use_local_topics: in the broadcaster's name
    assert list(msg.position) == [0.5] and math.isnan(msg.velocity[0])
    assert msg.header.frame_id == "base_link"  # ros2_controllers' default


def test_states_that_are_not_finite_are_broadcast_as_they_are() -> None:
    # states only: nothing to refuse, and nothing to crash on
    q = [np.array([math.nan, 1.0]), np.array([math.inf, -math.inf])]
    trace = run_components([_jsb(joints=["a", "b"])], 2, inputs={
        "/position": q, "/velocity": np.array([math.nan, math.nan])})
    first, last = trace.outputs["/joint_states"]
    assert math.isnan(first.position[0]) and first.position[1] == 1.0
    assert list(last.position) == [math.inf, -math.inf]
    assert all(math.isnan(v) for v in last.velocity)
    dynamic = trace.last("/dynamic_joint_states")
    assert dynamic.interface_values[1].values[0] == -math.inf


def test_without_joints_the_first_array_names_them() -> None:
    trace = run_components([_jsb()], 1, inputs={"/position": np.array([1.0, 2.0])})
    assert list(trace.last("/joint_states").name) == ["joint1", "joint2"]


# -- pid_controller against a hand computation ----------------------------------------

DT = 0.01  # 100 Hz


def _pid(gains: dict, interfaces: tuple[str, ...] = ("position",), **params: object
         ) -> rtcf.ComponentSpec:
    return rtcf.ComponentSpec("pid", PidController, params={
        "dof_names": ["j"], "command_interface": "effort",
        "reference_and_state_interfaces": list(interfaces), "gains": {"j": gains}, **params})


def _run_pid(spec: rtcf.ComponentSpec, positions: list[float], reference: MultiDOFCommand,
             velocities: list[float] | None = None) -> rtcf.testing.Trace:
    inputs = {"/position": [np.array([q]) for q in positions], "/pid/reference": reference}
    if velocities is not None:
        inputs["/velocity"] = [np.array([v]) for v in velocities]
    return run_components([spec], len(positions), frequency=1 / DT, inputs=inputs)


def _efforts(trace: rtcf.testing.Trace) -> list[float]:
    return [float(v[0]) for v in trace.outputs["/effort_command"]]


@pytest.mark.parametrize("antiwindup", [True, False])
def test_pid_p_i_with_its_clamp_and_d_by_hand(antiwindup: bool) -> None:
    gains = {"p": 2.0, "i": 10.0, "d": 0.1, "i_clamp_max": 0.3, "i_clamp_min": -0.3,
             "antiwindup": antiwindup}
    trace = _run_pid(_pid(gains), [0.0, 0.1, 0.2, 0.2, 0.2, 1.5], _reference([1.0]))
    # e = 1 - q; d term = 0.1 (e - e_before) / 0.01, e_before = 0 after a reset;
    # i term += 10 * 0.01 * e, held within [-0.3, 0.3] (Jazzy's control_toolbox clamps
    # the integral itself with antiwindup true or false: it never winds up)
    assert _efforts(trace) == pytest.approx([
        2 * 1.0 + 0.1 + 0.1 * 100,      # e 1.0:  p 2.0, i 0.1,  d 10 (from 0)
        2 * 0.9 + 0.19 + 0.1 * -10,     # e 0.9:  p 1.8, i 0.19, d -1
        2 * 0.8 + 0.27 + 0.1 * -10,     # e 0.8:  p 1.6, i 0.27, d -1
        2 * 0.8 + 0.3 + 0.0,            # e 0.8:  i 0.35 clamped to 0.3
        2 * 0.8 + 0.3 + 0.0,            # e 0.8:  i stays 0.3
        2 * -0.5 + 0.25 + 0.1 * -130,   # e -0.5: i 0.3 - 0.05 at once, d -13
    ], rel=1e-12)
    state = trace.last("/pid/controller_state").dof_states[0]
    assert (state.name, state.reference, state.feedback, state.time_step) == ("j", 1.0, 1.5, DT)
    assert state.error == pytest.approx(-0.5)
    assert state.output == pytest.approx(_efforts(trace)[-1])


def test_pid_with_two_interfaces_takes_the_error_rate_from_the_velocities_and_feeds_forward(
) -> None:
    gains = {"p": 2.0, "d": 0.5, "feedforward_gain": 3.0}
    spec = _pid(gains, ("position", "velocity"), enable_feedforward=True)
    trace = _run_pid(spec, [0.0, 0.2], _reference([1.0], [0.4], ["j"]), velocities=[0.0, 1.0])
    # feedforward 3 * 0.4 (the reference's rate), p 2 e, d 0.5 (0.4 - velocity)
    assert _efforts(trace) == pytest.approx([
        3 * 0.4 + 2 * 1.0 + 0.5 * (0.4 - 0.0),
        3 * 0.4 + 2 * 0.8 + 0.5 * (0.4 - 1.0),
    ], rel=1e-12)
    state = trace.last("/pid/controller_state").dof_states[0]
    assert (state.feedback_dot, state.error_dot) == (1.0, pytest.approx(-0.6))


def test_pid_feedforward_needs_enable_feedforward_as_in_jazzy() -> None:
    one = {"p": 1.0, "feedforward_gain": 0.5}
    on = _run_pid(_pid(one, enable_feedforward=True), [0.0], _reference([2.0]))
    off = _run_pid(_pid(one), [0.0], _reference([2.0]))
    assert (_efforts(on), _efforts(off)) == ([0.5 * 2.0 + 1.0 * 2.0], [2.0])


def test_pid_angle_wraparound_takes_the_short_way_round() -> None:
    wrapped = _run_pid(_pid({"p": 1.0, "angle_wraparound": True}), [-3.0], _reference([3.0]))
    plain = _run_pid(_pid({"p": 1.0}), [-3.0], _reference([3.0]))
    assert _efforts(wrapped) == pytest.approx([6.0 - 2 * math.pi], rel=1e-12)
    assert _efforts(plain) == [6.0]
    state = wrapped.last("/pid/controller_state").dof_states[0]
    assert state.error == pytest.approx(6.0 - 2 * math.pi)


def test_pid_holds_where_it_starts_until_a_reference_and_refuses_a_wrong_one(
    caplog: pytest.LogCaptureFixture,
) -> None:
    fed = [_reference([], names=[]), _reference([0.2], names=["other"]), _reference([0.7])]
    with caplog.at_level(logging.WARNING):
        trace = run_components(
            [_pid({"p": 10.0})], 3, frequency=1 / DT,
            inputs={"/position": np.array([0.5]), "/pid/reference": fed},
        )
    # first setpoint: where it was (0.5): no effort; the wrong references change nothing
    assert _efforts(trace) == pytest.approx([0.0, 0.0, 10.0 * 0.2])
    assert _records(caplog, "0 names, 0 values and 0 values_dot for 1 dofs (j)")
    assert _records(caplog, "dof 'other' is not one of j")
    assert trace.components["/pid"].refused_messages == {"~/reference": 2, "position": 0}


def test_pid_refuses_an_infinite_reference_and_keeps_the_last_good_one(
    caplog: pytest.LogCaptureFixture,
) -> None:
    fed = [_reference([0.7]), _reference([math.inf]), _reference([0.9], [-math.inf], ["j"]),
           _reference([math.nan])]  # NaN: "leave it", ros2_controllers' convention
    with caplog.at_level(logging.WARNING):
        trace = run_components(
            [_pid({"p": 10.0}, ("position", "velocity"))], 4, frequency=1 / DT,
            inputs={"/position": np.array([0.5]), "/velocity": np.array([0.0]),
                    "/pid/reference": fed})
    assert _efforts(trace) == pytest.approx([10.0 * 0.2] * 4)  # 0.7 all along
    assert trace.components["/pid"].refused_messages == {
        "~/reference": 2, "position": 0, "velocity": 0}
    assert _records(caplog, "not finite") == [
        "/pid/reference refused: the value of j is inf (not finite); the last reference "
        "stays"]  # the second within the second: counted, not said


def test_pid_ignores_a_state_that_is_not_finite_and_keeps_the_last_good_one(
    caplog: pytest.LogCaptureFixture,
) -> None:
    positions = [0.5, math.nan, 0.6, math.inf]
    with caplog.at_level(logging.WARNING):
        trace = _run_pid(_pid({"p": 10.0}), positions, _reference([0.7]))
    # the NaN and inf samples are refused: the last good position stands in for them
    assert _efforts(trace) == pytest.approx([2.0, 2.0, 1.0, 1.0])
    assert all(math.isfinite(e) for e in _efforts(trace))
    assert trace.components["/pid"].refused_messages["position"] == 2
    assert _records(caplog, "not finite") == [
        "/position ignored: the value of j is nan (not finite); the last ones stay"]


def test_pid_never_writes_an_output_that_overflowed(caplog: pytest.LogCaptureFixture) -> None:
    """A finite reference so large that p times the error is not finite (found by the
    fuzz: -inf and NaN efforts from -1.8e308): not written, the last command stays."""
    fed = [_reference([0.7]), _reference([-1.7976931348623157e308]), _reference([0.9])]
    with caplog.at_level(logging.WARNING):
        trace = run_components(
            [_pid({"p": 200.0})], 4, frequency=1 / DT,
            inputs={"/position": np.array([0.5]), "/pid/reference": fed})
    assert all(math.isfinite(e) for e in _efforts(trace))
    assert _efforts(trace) == pytest.approx([200.0 * 0.2, 200.0 * 0.2, 200.0 * 0.4, 200.0 * 0.4])
    # (the overflow left nothing in the PID: the next good reference is followed at once)
    assert trace.components["/pid"].refused_samples == 1
    assert _records(caplog, "not written") == [
        "effort_command of j not written: the output nan is not finite (reference "
        "-1.7976931348623157e+308, state 0.5); the last command stays, the PID starts "
        "afresh"]


def test_pid_gains_that_control_toolbox_refuses_are_configuration_errors() -> None:
    with pytest.raises(rtcf.RtcfError, match=r"'gains\.j\.i_clamp_min' is 1\.0; give a number <= "):
        run_components([_pid({"i_clamp_min": 1.0})], 1)
    with pytest.raises(rtcf.RtcfError, match=r"antiwindup_strategy' is 'x'; give one of"):
        run_components([_pid({"antiwindup_strategy": "x"})], 1)
