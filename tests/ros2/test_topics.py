"""Ports mapped to ROS 2 topics, end to end through a real rclpy graph."""

import contextlib
import time

import pytest
import rclpy
from std_msgs.msg import Float64

from .._launches import launch_xml, runner_xml
from .._proc import stop, wait_running
from .conftest import start_rtcf

pytestmark = pytest.mark.integration


@contextlib.contextmanager
def launched(path, *args, text=None):
    """``rtcf launch PATH ARGS --middleware ros2`` (``text`` written to PATH first, if
    given), running; stopped after (SIGINT, exit 0) if it still runs. Its ``said``:
    what it said until it ran."""
    if text is not None:
        path.write_text(text)
    proc = start_rtcf("launch", path, *args, "--middleware", "ros2")
    try:
        proc.said = wait_running(proc)
        yield proc
    finally:
        if proc.poll() is None:
            stop(proc)


def spin_until(node, predicate, timeout=15.0, publish=None):
    deadline = time.monotonic() + timeout
    executor = rclpy.executors.SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        while time.monotonic() < deadline:
            if publish is not None:
                publish()
            executor.spin_once(timeout_sec=0.02)
            if predicate():
                return True
        return False
    finally:
        executor.remove_node(node)


class FloatProbe:
    """std_msgs/Float64 values published on a component's mapped input, and those its
    mapped output sends back (``got``, in order)."""

    def __init__(self, ros_node, topic_in, topic_out):
        self._node = ros_node
        self.got = []
        ros_node.create_subscription(Float64, topic_out, lambda m: self.got.append(m.data), 10)
        self._pub = ros_node.create_publisher(Float64, topic_in, 10)

    def answers(self, x, expected, timeout=15.0):
        """Publish ``x`` again and again until the last value received equals ``expected``
        (a number, or pytest.approx of one); False if it did not within ``timeout``."""
        return spin_until(
            self._node,
            lambda: bool(self.got) and self.got[-1] == expected,
            timeout=timeout,
            publish=lambda: self._pub.publish(Float64(data=x)),
        )


@pytest.mark.parametrize("launch_file", ["sum_test.launch", "sum_test.launch.xml"])
def test_sum_test_outputs_three_times_the_input(ros_node, launch_file):
    """The original's SumTest: two chained sums in /rtcf, through real ROS 2 topics; from
    the ROS 1-style file and from its ROS 2 launch XML twin."""
    proc = start_rtcf("launch", "rtcf_examples", launch_file, "--middleware", "ros2")
    try:
        said = wait_running(proc)
        mapped = "publishes /rtcf/ros/out (float); subscribes /rtcf/ros/in (float)"
        assert f"rtcf: ros2: {mapped}" in said
        got = []
        ros_node.create_subscription(Float64, "/rtcf/ros/out", lambda m: got.append(m.data), 10)
        pub = ros_node.create_publisher(Float64, "/rtcf/ros/in", 10)

        def topics():
            return dict(ros_node.get_topic_names_and_types())

        assert spin_until(
            ros_node,
            lambda: ros_node.count_publishers("/rtcf/ros/out") > 0
            and ros_node.count_subscribers("/rtcf/ros/in") > 0,
        )
        assert "/rtcf/ros/blacklisted" not in topics()
        assert "/rtcf/sum1" not in topics()  # internal: not whitelisted
        assert topics()["/rtcf/ros/out"] == ["std_msgs/msg/Float64"]
        for value in (-10.0, 0.0, 20.0, 1234.56):
            got.clear()
            assert spin_until(
                ros_node,
                lambda v=value: bool(got) and got[-1] == pytest.approx(3 * v),
                publish=lambda v=value: pub.publish(Float64(data=v)),
            ), f"no {3 * value} on /rtcf/ros/out (last: {got[-3:]})"
    finally:
        if proc.poll() is None:
            stop(proc)


def test_message_typed_ports_cross_as_serialized_bytes(ros_node, tmp_path):
    path = tmp_path / "scale.launch"
    path.write_text(
        launch_xml("""
              <node name="a" pkg="rtcf" type="rt_launcher" args="rtcf_ros2_components ScaleMsg">
                <remap from="in" to="/ros/x"/>
                <remap from="out" to="/mid"/>
                <param name="gain" value="2.0"/>
              </node>
              <node name="b" pkg="rtcf" type="rt_launcher" args="rtcf_ros2_components ScaleMsg">
                <remap from="in" to="/mid"/>
                <remap from="out" to="/ros/y"/>
                <param name="gain" value="5.0"/>
              </node>
            """, runner_xml(200.0, ros_mapping_whitelist="/ros/.*"))
    )
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    try:
        wait_running(proc)
        probe = FloatProbe(ros_node, "/ros/x", "/ros/y")
        assert probe.answers(1.5, pytest.approx(10 * 1.5)), probe.got[-3:]
    finally:
        if proc.poll() is None:
            _, err = stop(proc)
            assert "error" not in err.lower(), err


def test_a_port_type_that_cannot_cross_is_a_clear_error(tmp_path):
    path = tmp_path / "bad.launch"
    path.write_text(
        launch_xml("""
              <node name="d" pkg="rtcf" type="rt_launcher" args="rtcf_ros2_components DictOut">
                <remap from="out" to="/ros/d"/>
              </node>
            """, runner_xml(100.0, ros_mapping_whitelist="/ros/.*"))
    )
    proc = start_rtcf("launch", path, "--middleware", "ros2", "--duration", "1")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    lines = [ln for ln in err.splitlines() if ln.startswith("rtcf: error:")]
    assert len(lines) == 1, err
    assert "/d.out" in lines[0] and "/ros/d" in lines[0] and "dict" in lines[0]
    assert "Traceback" not in err


def test_qos_of_mapped_topics_is_the_runners(ros_node, tmp_path):
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    text = launch_xml("""
          <node name="a" pkg="rtcf" type="rt_launcher" args="rtcf_ros2_components ScaleMsg">
            <remap from="in" to="/ros/qin"/>
            <remap from="out" to="/ros/qout"/>
          </node>
        """, runner_xml(100.0, ros_mapping_whitelist="/ros/.*", ros_qos_reliability="best_effort",
                        ros_qos_durability="transient_local", ros_qos_depth="3"))
    with launched(tmp_path / "qos.launch", text=text):
        # Discovery reports each endpoint on its own: wait for both.
        assert spin_until(
            ros_node,
            lambda: ros_node.count_publishers("/ros/qout") > 0
            and ros_node.count_subscribers("/ros/qin") > 0,
        )
        (pub,) = ros_node.get_publishers_info_by_topic("/ros/qout")
        assert pub.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
        assert pub.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
        (sub,) = ros_node.get_subscriptions_info_by_topic("/ros/qin")
        assert sub.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT


def test_a_bad_qos_setting_is_a_clear_error(tmp_path):
    path = tmp_path / "badqos.launch"
    path.write_text(
        '<launch><node name="rt_runner" pkg="rtcf" type="rt_runner">'
        '<param name="ros_qos_reliability" value="sometimes"/></node></launch>'
    )
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode != 0
    assert "ros_qos_reliability 'sometimes' is unknown; use reliable or best_effort" in err


@pytest.mark.parametrize("bridge", ["timed", "plain"])
def test_every_primitive_kind_crosses_both_ways(ros_node, tmp_path, monkeypatch, bridge):
    """float, int, bool and str in and out, through the bridge's own CDR bytes (timed,
    the default) and through message objects (plain): the same values either way,
    also those CDR pads or escapes (a bool's padding, a string's length and NUL)."""
    from std_msgs.msg import Bool, Int64, String

    monkeypatch.setenv("RTCF_ROS2_BRIDGE", bridge)
    kinds = {"float": (Float64, [2.5, -0.0, 1e300]), "int": (Int64, [-(2**63), 7, 2**63 - 1]),
             "bool": (Bool, [True, False, True]), "str": (String, ["grüße", "", "x" * 300])}
    nodes = "\n".join(
        f'  <node name="{k}" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">'
        f'<remap from="in_port" to="/ros/{k}_in"/><remap from="out_port" to="/ros/{k}_out"/>'
        f'<param name="msg_type" value="{k}"/></node>'
        for k in kinds
    )
    path = tmp_path / "kinds.launch"
    path.write_text(f"""<launch>
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <param name="mode" value="no_wait"/><param name="frequency" value="200.0"/>
    <param name="ros_mapping_whitelist" value="/ros/.*"/>
  </node>
{nodes}
</launch>
""")
    proc = start_rtcf("launch", path, "--middleware", "ros2")
    try:
        wait_running(proc)
        got = {k: [] for k in kinds}
        pubs = {}
        for k, (cls, _) in kinds.items():
            ros_node.create_subscription(cls, f"/ros/{k}_out",
                                         lambda m, k=k: got[k].append(m.data), 10)
            pubs[k] = ros_node.create_publisher(cls, f"/ros/{k}_in", 10)
        assert spin_until(ros_node, lambda: all(
            ros_node.count_publishers(f"/ros/{k}_out") and
            ros_node.count_subscribers(f"/ros/{k}_in") for k in kinds))
        for k, (cls, values) in kinds.items():
            for value in values:
                got[k].clear()
                assert spin_until(
                    ros_node, lambda k=k, v=value: bool(got[k]) and got[k][-1] == v,
                    publish=lambda k=k, cls=cls, v=value: pubs[k].publish(cls(data=v)),
                ), f"{bridge}: {k} {value!r} did not come back (last: {got[k][-3:]})"
    finally:
        if proc.poll() is None:
            _, err = stop(proc)
            assert "error" not in err.lower(), err
