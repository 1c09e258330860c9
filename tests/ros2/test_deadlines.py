"""Input deadlines on one host, with a real publisher process: one that stalls
(SIGSTOP) and resumes (SIGCONT), then one that dies (SIGKILL). The relay's input
/dl/cmd has a deadline of 0.5 s (on_deadline deactivate, fallback hold): its output
/dl/u turns -1.0 (the fallback) while the publisher is silent, and the relay is back
when values come again. Asserted from what the runner records (timing.json, its log),
waiting on messages, never on the wall clock. The input is taken the direct way (the
bridge's own thread, not rclpy's executor), and DDS's events about its publisher are
logged all the same. One rtcf process for the module."""

import json
import signal
import subprocess
import sys

import pytest
from std_msgs.msg import Float64

from rtcf._ros2._bridge import fetch_introspection

from .._launches import launch_xml, runner_xml
from .._proc import read_rest, wait_for, wait_for_match
from .conftest import FIXTURES, rtcf_env, start_rtcf
from .test_topics import spin_until

pytestmark = pytest.mark.integration

LAUNCH = launch_xml(
    """
    <node name="relay" pkg="rtcf" type="rt_launcher" args="rtcf_deadline_components Relay">
      <remap from="cmd" to="/dl/cmd"/><remap from="u" to="/dl/u"/>
      <param name="deadline/cmd" value="0.5"/><param name="on_deadline" value="deactivate"/>
      <param name="fallback" value="hold"/>
    </node>
    <node name="hold" pkg="rtcf" type="rt_launcher" args="rtcf_deadline_components HoldStill">
      <remap from="u" to="/dl/u"/>
    </node>
    """,
    runner_xml(100.0, ros_mapping_whitelist="/dl/.*", ros_qos_deadline="true"),
)


def _publisher():
    # offers a QoS deadline and lease of 0.2 s: no longer than the 0.5 s requested
    return subprocess.Popen(
        [sys.executable, str(FIXTURES / "float_publisher.py"), "/dl/cmd", "0.2"],
        env=rtcf_env(), stdin=subprocess.DEVNULL,
    )


def test_a_stalled_publisher_hands_over_to_the_fallback_and_back_then_a_killed_one(
    ros_node, tmp_path
):
    launch = tmp_path / "deadlines.launch"
    launch.write_text(LAUNCH)
    report = tmp_path / "report"
    proc = start_rtcf("launch", launch, "--middleware", "ros2", "--report", report)
    pub = None
    u = []
    ros_node.create_subscription(Float64, "/dl/u", lambda m: u.append(m.data), 100)

    def next_u(predicate):  # a value of /dl/u that arrives from now on
        start = len(u)
        return spin_until(ros_node, lambda: any(predicate(v) for v in u[start:]), timeout=30)

    try:
        wait_for(proc, "running until Ctrl-C", timeout=60)
        pub = _publisher()
        assert next_u(lambda v: v > 0), "the relay passes the publisher's values on"
        # a deadline does not send the input the slow way: DirectInputs takes it
        paths = fetch_introspection("/rt_runner")["ros2_inputs"]
        assert paths == {"/dl/cmd": "direct"}
        wait_for(proc, "ROS 2 input /dl/cmd: a publisher matched; 1 publishers now")
        pub.send_signal(signal.SIGSTOP)
        assert next_u(lambda v: v == -1.0), "the fallback holds while the publisher stalls"
        # the middleware's own view, beside the loop's: DDS reports the silence too
        wait_for(proc, "ROS 2 input /dl/cmd: QoS deadline missed; 1 publishers now")
        pub.send_signal(signal.SIGCONT)
        assert next_u(lambda v: v > 0), "the relay is active again once values come"
        pub.kill()
        pub.wait()
        assert next_u(lambda v: v == -1.0), "the fallback holds after the publisher died"
        # DDS reports the silence: liveliness lost for the stall; for the dead publisher
        # its lease running out, or its participant's (the writer removed: which one
        # Fast DDS says first depends on which lease it checks first)
        wait_for_match(proc, r"(?s)ROS 2 input /dl/cmd: liveliness lost \(0 alive\).*"
                             r"ROS 2 input /dl/cmd: (liveliness lost \(0 alive\)|a publisher "
                             r"was lost; 0 publishers now)")
    finally:
        if pub is not None and pub.poll() is None:
            pub.kill()
            pub.wait()
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        _, err = read_rest(proc, timeout=60)
    assert proc.returncode == 0, err
    doc = json.loads((report / "timing.json").read_text())
    summary = doc["deadlines"]["/relay.cmd"]
    events = doc["deadline_events"]
    assert summary["topic"] == "/dl/cmd" and summary["deadline"] == 0.5
    assert summary["expired"] == len(events) >= 2 and summary["past_deadline_now"]
    # each silence but the last ended: the relay came back in a later iteration; the
    # last (the killed publisher) never did
    for event in events:
        assert event["action"] == "deactivated" and event["fallback"] == "/hold"
        # exact on the loop's clock: the first iteration that starts after the deadline
        assert event["time"] > event["last_arrival"] + 0.5 >= event["time"] - 0.01 - 1e-9
    assert all(e["back_iteration"] > e["iteration"] for e in events[:-1])
    assert events[-1]["back_iteration"] == -1
    assert "input '/relay.cmd' (/dl/cmd) past its deadline of 0.5 s" in err
    assert "deadline: input '/relay.cmd' (/dl/cmd) passed its deadline of 0.5 s" in err
    assert "/relay]: lifecycle: activate: inactive -> active" in err
