"""diff_drive_controller (rtcf_controllers.DiffDriveController), in-process on the
simulated clock: the diffbot example (MuJoCo, configured by its ros2_controllers YAML
file) against the model's ground truth, and the controller alone (open loop) for the
timeout, the limits, the frames of /tf and the feedback variants.
"""

import math

import numpy as np
import pytest
from geometry_msgs.msg import TwistStamped

import rtcf
from rtcf.testing import SimClock, run_components, run_launch
from rtcf_controllers import DiffDriveController
from rtcf_examples import MujocoDiffbot

CMD = "/diffbot_base_controller/cmd_vel"
ODOM = "/diffbot_base_controller/odom"
WHEELS = {
    "left_wheel_names": ["left_wheel_joint"],
    "right_wheel_names": ["right_wheel_joint"],
    "wheel_separation": 0.3,
    "wheel_radius": 0.05,
}


def twist(linear, angular, stamp_ns=0):
    message = TwistStamped()
    message.twist.linear.x, message.twist.angular.z = float(linear), float(angular)
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return message


def stamp_s(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


def yaw(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


@pytest.mark.parametrize(("linear", "angular"), [(0.5, 0.0), (0.3, 0.8)], ids=["straight", "turn"])
def test_odometry_of_the_diffbot_follows_the_ground_truth(linear, angular):
    # cmd_vel with a zero stamp (now) for 2 s, through the launch file and its YAML
    trace = run_launch(
        "rtcf_examples diffbot.launch", duration=2.0, inputs={CMD: twist(linear, angular)}
    )
    odom = trace.last(ODOM)
    # the odometry published last, against the truth of the same iteration (1 kHz)
    k = round(stamp_s(odom.header.stamp) * 1000.0)
    x, y, heading = trace.outputs["/diffbot/base_pose"][k]
    distance = math.hypot(x, y)
    assert distance > 0.85 * linear * 2.0  # it did drive
    position = odom.pose.pose.position
    assert math.hypot(position.x - x, position.y - y) < 0.02 * distance
    assert yaw(odom.pose.pose.orientation) == pytest.approx(heading, abs=0.02 * abs(heading) + 1e-3)
    assert odom.twist.twist.linear.x == pytest.approx(linear, rel=0.02)
    assert odom.twist.twist.angular.z == pytest.approx(angular, rel=0.02, abs=1e-3)
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    assert odom.pose.covariance[35] == 0.01  # the YAML file's pose_covariance_diagonal
    transform = trace.last("/tf").transforms[0]
    assert transform.transform.translation.x == position.x
    assert odom.header.stamp == transform.header.stamp


def controller(namespace="/", **params):
    spec = rtcf.ComponentSpec(
        "diff_drive_controller",
        DiffDriveController,
        namespace=namespace,
        params={**WHEELS, "open_loop": True, **params},
    )
    return spec, namespace.rstrip("/") + "/diff_drive_controller"


def wheel_speeds(trace):
    return [None if v is None else tuple(v) for v in trace.outputs["/velocity_command"]]


def test_wheels_stop_within_the_timeout_and_a_period_of_the_last_command():
    spec, name = controller()
    last = []

    def commands(iteration, time):  # stamped as teleop stamps them, until 1 s
        if time < 1.0:
            last[:] = [twist(0.5, 0.0, round(time * 1e9))]
        return last[0]  # then the last one stays

    trace = run_components([spec], 200, frequency=100.0, inputs={name + "/cmd_vel": commands})
    speeds = wheel_speeds(trace)
    stopped = speeds.index((0.0, 0.0))
    assert all(s == (10.0, 10.0) for s in speeds[:stopped])
    assert all(s == (0.0, 0.0) for s in speeds[stopped:])
    # the last command was stamped 0.99 s: braking starts once it is older than 0.5 s
    assert trace.times[stopped] - 0.99 == pytest.approx(0.51)
    assert trace.times[stopped] - 0.99 <= 0.5 + 0.01


def test_a_command_older_than_the_timeout_is_ignored(caplog):
    spec, name = controller(cmd_vel_timeout=0.2)
    late = twist(0.5, 0.0, stamp_ns=50_000_000)  # stamped at 0.05 s, arriving at 0.3 s

    def commands(iteration, time):
        return late if time >= 0.3 else None  # None: no message yet

    trace = run_components([spec], 40, frequency=100.0, inputs={name + "/cmd_vel": commands})
    assert {s for s in wheel_speeds(trace) if s is not None} == {(0.0, 0.0)}
    assert "ignoring a cmd_vel stamped 0.250 s ago" in caplog.text
    assert trace.components["/diff_drive_controller"].refused_messages == {"~/cmd_vel": 10}


@pytest.mark.parametrize(("linear", "angular", "field"), [
    (math.nan, 0.0, "linear.x is nan"), (0.5, math.inf, "angular.z is inf")])
def test_a_command_that_is_not_finite_is_ignored_and_the_timeout_applies(
    linear, angular, field, caplog
):
    spec, name = controller()

    def commands(iteration, time):  # good until 0.5 s, then freshly stamped bad ones
        good = time < 0.5
        return twist(0.5 if good else linear, 0.0 if good else angular, round(time * 1e9))

    trace = run_components([spec], 200, frequency=100.0, inputs={name + "/cmd_vel": commands})
    speeds = wheel_speeds(trace)
    assert all(s == (10.0, 10.0) for s in speeds[:100])  # the last good one, 0.5 s on
    assert all(s == (0.0, 0.0) for s in speeds[101:])  # then braking: nothing came
    assert all(math.isfinite(v) for s in speeds for v in s)
    assert trace.components["/" + name.strip("/")].refused_messages == {"~/cmd_vel": 150}
    ignored = [r.getMessage() for r in caplog.records if "ignored" in r.getMessage()]
    said = (f"~/cmd_vel ignored: {field} (not finite), %d refused so far; cmd_vel_timeout "
            "applies as if it had not arrived")
    assert ignored == [said % 1, said % 101 + " (99 more like it since the last record)"]


def test_velocity_acceleration_and_jerk_limits_apply_to_the_command():
    spec, name = controller(
        publish_limited_velocity=True,
        **{"linear.x.max_velocity": 0.4, "linear.x.max_acceleration": 1.0},
        angular={"z": {"max_velocity": 1.0, "max_jerk": 100.0, "max_acceleration": 50.0}},
    )
    trace = run_components(
        [spec], 60, frequency=100.0, inputs={name + "/cmd_vel": twist(1.0, 5.0)}
    )
    limited = trace.outputs[name + "/cmd_vel_out"]
    linear = [m.twist.linear.x for m in limited]
    assert linear[:3] == pytest.approx([0.01, 0.02, 0.03])  # 1 m/s^2 at 100 Hz
    assert linear[39:] == pytest.approx([0.4] * 21)
    angular = [m.twist.angular.z for m in limited]
    # jerk 100 rad/s^3: the acceleration grows by 1 rad/s^2 per period, up to 50
    assert angular[:3] == pytest.approx([0.01, 0.03, 0.06])
    assert angular[-1] == 1.0
    left, right = trace.outputs["/velocity_command"][-1]
    assert (left, right) == pytest.approx(((0.4 - 0.15) / 0.05, (0.4 + 0.15) / 0.05))


@pytest.mark.parametrize(
    ("namespace", "params", "frames"),
    [
        ("/", {}, ("odom", "base_link")),
        ("/robot1", {}, ("robot1/odom", "robot1/base_link")),
        ("/robot1", {"tf_frame_prefix": "/fleet/a"}, ("fleet/a/odom", "fleet/a/base_link")),
        ("/robot1", {"tf_frame_prefix_enable": False, "base_frame_id": "base"}, ("odom", "base")),
    ],
)
def test_tf_carries_odom_to_base_with_the_prefix_rules(namespace, params, frames):
    spec, name = controller(namespace, **params)
    trace = run_components(
        [spec], 30, frequency=100.0, inputs={name + "/cmd_vel": twist(0.5, 0.2)}
    )
    odom, tf = trace.last(name + "/odom"), trace.last("/tf")
    (transform,) = tf.transforms
    assert (transform.header.frame_id, transform.child_frame_id) == frames
    assert (odom.header.frame_id, odom.child_frame_id) == frames
    assert transform.header.stamp == odom.header.stamp
    assert transform.transform.translation.x == odom.pose.pose.position.x > 0.1
    assert transform.transform.rotation == odom.pose.pose.orientation
    # at publish_rate (50 Hz): every second iteration at 100 Hz
    stamps = {stamp_s(m.header.stamp) for m in trace.outputs[name + "/odom"]}
    assert len(stamps) == 15


class Teleop(rtcf.Component):
    """0.5 m/s on cmd_vel, every iteration (a zero stamp: now)."""

    def configure(self):
        self.cmd_vel = self.add_output("/diff_drive_controller/cmd_vel", TwistStamped)

    def update(self):
        self.cmd_vel.write(twist(0.5, 0.0))


def test_deactivating_the_controller_stops_the_wheels_and_keeps_the_odometry():
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=1000.0), clock=SimClock())
    base = runner.load(rtcf.ComponentSpec("diffbot", MujocoDiffbot, is_first=True))
    spec, name = controller(open_loop=False)
    drive = runner.load(spec)
    runner.load(rtcf.ComponentSpec("teleop", Teleop))
    try:
        runner.run(500)
        assert base.data.ctrl.tolist() == [10.0, 10.0]
        assert runner.change_state(name, "deactivate").ok
        runner.run(300)  # the servos brake the base to a standstill
        assert base.data.ctrl.tolist() == [0.0, 0.0]
        assert np.abs(base.data.qvel[base.qvel]).max() < 1e-3  # the wheels stand still
        x = drive.odometry.x
        assert x > 0.2  # 0.5 m/s for 0.5 s
        assert runner.change_state(name, "activate").ok
        runner.run(10)
        assert drive.odometry.x >= x  # from where it was, not from the origin
    finally:
        runner.shutdown()


def test_open_loop_integrates_the_commands_without_feedback():
    spec, name = controller(enable_odom_tf=False)
    trace = run_components(
        [spec], 101, frequency=100.0, inputs={name + "/cmd_vel": twist(0.5, 0.0)}
    )
    assert set(trace.components[name].inputs) == {"~cmd_vel"}  # no state interface read
    assert "/tf" not in trace.outputs
    odom = trace.last(name + "/odom")  # published at 0.99 s
    assert odom.pose.pose.position.x == pytest.approx(0.5 * stamp_s(odom.header.stamp))
    assert odom.twist.twist.linear.x == 0.5


def test_velocity_feedback_is_integrated_into_odometry():
    spec, name = controller(open_loop=False, position_feedback=False, enable_odom_tf=False)
    trace = run_components(
        [spec], 101, frequency=100.0,
        inputs={name + "/cmd_vel": twist(0.0, 0.0), "/velocity": np.array([10.0, 10.0])},
    )
    odom = trace.last(name + "/odom")  # 10 rad/s * 0.05 m
    assert odom.pose.pose.position.x == pytest.approx(0.5 * stamp_s(odom.header.stamp))
    assert odom.twist.twist.linear.x == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("params", "named"),
    [
        ({"wheel_separation": 0.0}, "'wheel_separation' is 0.0"),
        ({"right_wheel_names": ["a", "b"]}, "1 left wheels and 2 right wheels"),
        ({"linear.x.max_velocity": -1.0}, "linear.x.max_velocity is -1.0"),
        ({"angular.z.max_acceleration": 1.0, "angular.z.max_deceleration": 2.0},
         "angular.z.max_deceleration is 2.0"),
        ({"pose_covariance_diagonal": [0.1]}, "pose_covariance_diagonal has 1 numbers"),
    ],
)
def test_a_wrong_parameter_is_refused_naming_it(params, named):
    spec, _ = controller(**params)
    with pytest.raises(rtcf.ComponentError, match=named):  # configure() failed: ...
        run_components([spec], 1)
