"""Two runners on two "hosts": network namespaces joined by a veth pair, as two
computers on one Ethernet link, talking ROS 2 over DDS (docs/ros2.md#several-machines).

The hosts are benchmarks/_hosts.py's: each namespace has its loopback and its end of
the link, a multicast route for DDS discovery, and nothing else (no traffic leaves
them). Fast DDS is told to use UDP only (``FASTDDS_BUILTIN_TRANSPORTS=UDPv4``): between
two real hosts there is no shared memory, and on this one it would otherwise carry the
data past the link.

Fig. 1 split across them by mapped topics, its stages carrying a sequence number
(benchmarks/_latency_components.Stage: each writes the smallest of its forward
inputs): host A counts (a Ramp) into H1, F1 and R1; host B runs R2 and R3, and R3's
output loops back into A's H1. The checks use the sequence numbers, not a timing bound:
each topic that crosses is read in order, every number from the first read on was read
or counted as replaced by a newer one, every message that arrived is counted, and the
traffic went over the link.
"""

import json
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from ._two_hosts import _hosts, host_env, start_on, two_hosts
from .conftest import rtcf_env

pytestmark = pytest.mark.integration


@pytest.fixture
def hosts():
    """Two network namespaces joined by a veth pair; removed afterwards."""
    yield from two_hosts("test_several_hosts")


def _launch(tmp_path: Path, name: str, frequency: float, nodes: str) -> Path:
    path = tmp_path / f"{name}.launch"
    path.write_text(f"""<launch>
  <node name="rt_runner_{name}" pkg="rtcf" type="rt_runner">
    <rosparam param="mode">"no_wait"</rosparam>
    <rosparam param="frequency">{frequency}</rosparam>
    <rosparam param="ros_mapping_whitelist">"/hosts/.*"</rosparam>
    <rosparam param="iteration_info">False</rosparam>
  </node>
{nodes}
</launch>
""")
    return path


def _stage(name: str, out: str, *inputs: str, fb: str = "") -> str:
    remaps = "".join(f'<remap from="in{k}" to="{t}"/>' for k, t in enumerate(inputs, 1))
    remaps += f'<remap from="fb1" to="{fb}"/>' if fb else ""
    return (f'  <node name="{name}" pkg="rtcf" type="rt_launcher" '
            f'args="_latency_components Stage">{remaps}<remap from="out" to="{out}"/></node>')


def _start(host, launch: Path, duration: float, out: Path) -> subprocess.Popen:
    # (host_env puts benchmarks/ on the path: the Stage component)
    return start_on(host, "-m", "rtcf", "launch", launch, "--middleware", "ros2",
                    "--duration", duration, "--record", out / "run.mcap", "--report", out,
                    env=host_env())


def _values(path: Path, topic: str) -> list[float]:
    """The distinct values a recorded std_msgs/msg/Float64 topic took, in order (CDR: a
    4-byte header, the double)."""
    from mcap.reader import make_reader

    out: list[float] = []
    with open(path, "rb") as f:
        for _, _, m in make_reader(f).iter_messages(topics=[topic]):
            v = struct.unpack_from("<d", m.data, 4)[0]
            if not out or v != out[-1]:
                out.append(v)
    return out


def _assert_followed(topic: str, read: list[float], n: int, counts: dict[str, int]) -> None:
    """A crossing topic as its reader's loop saw it, against the n numbers sent."""
    assert read, f"{topic}: nothing read"
    assert read == sorted(set(read)) and set(read) <= {float(k) for k in range(1, n + 1)}, topic
    assert read[-1] == n, topic  # the reader outlived the sender: it read the last one
    # every message that arrived was read or replaced by a newer one: none uncounted
    assert counts["arrived"] == counts["read"] + counts["superseded"], (topic, counts)
    # from the first read on, every number sent arrived (DDS lost nothing on the link)
    missing = set(range(int(read[0]), n + 1)) - set(read)
    assert len(missing) <= counts["superseded"], (topic, len(missing), counts)
    assert counts["arrived"] >= n - read[0] + 1, (topic, counts)


def test_fig1_split_across_two_hosts_follows_the_sequence_and_counts_every_message(
    hosts, tmp_path
):
    host_a, host_b = hosts
    a = _launch(tmp_path, "a", 50.0, "\n".join([
        '  <node name="count" pkg="rtcf" type="rt_launcher" args="rtcf_examples Ramp">'
        '<remap from="out" to="/fig/in"/></node>',
        _stage("H1", "/hosts/H1", "/fig/in", fb="/hosts/R3"),  # (the loop via B)
        _stage("F1", "/hosts/F1", "/hosts/H1"),
        _stage("R1", "/hosts/R1", "/hosts/H1"),
    ]))
    b = _launch(tmp_path, "b", 200.0, "\n".join([
        _stage("R2", "/fig/R2", "/hosts/F1", "/hosts/H1", "/hosts/R1"),
        _stage("R3", "/hosts/R3", "/hosts/F1", "/fig/R2"),
    ]))
    out_a, out_b = tmp_path / "a", tmp_path / "b"
    out_a.mkdir()
    out_b.mkdir()
    rx_before = host_b.received_bytes()
    # B listens from before A starts until after A ends; A counts for 8 s at 50 Hz
    proc_b = _start(host_b, b, 14.0, out_b)
    proc_a = _start(host_a, a, 8.0, out_a)
    try:
        _, err_a = proc_a.communicate(timeout=120)
        _, err_b = proc_b.communicate(timeout=120)
    finally:
        for p in (proc_a, proc_b):
            p.kill()
    assert proc_a.returncode == 0, err_a
    assert proc_b.returncode == 0, err_b
    sent = _values(out_a / "run.mcap", "/fig/in")
    n = len(sent)
    assert sent == [float(k) for k in range(1, n + 1)] and n > 300
    inputs_b = json.loads((out_b / "timing.json").read_text())["inputs"]
    assert set(inputs_b) == {"/hosts/F1", "/hosts/H1", "/hosts/R1"}
    for topic, counts in inputs_b.items():  # A's stages, as B's loop read them
        _assert_followed(topic, _values(out_b / "run.mcap", topic), n, counts)
    # B's loop follows A's values: R3, the smallest of F1 and R2, is A's sequence
    r3 = _values(out_b / "run.mcap", "/hosts/R3")
    assert r3 == sorted(set(r3)) and r3[-1] == n
    # and back: A's H1 read R3 from B (Fig. 1's loop), in order
    back = _values(out_a / "run.mcap", "/hosts/R3")
    counts = json.loads((out_a / "timing.json").read_text())["inputs"]["/hosts/R3"]
    assert back and back == sorted(set(back)) and set(back) <= set(r3)
    assert counts["arrived"] >= counts["read"] + counts["superseded"]
    assert counts["read"] >= len(back)
    # the messages went over the link (UDP), not through this machine's shared memory
    assert host_b.received_bytes() - rx_before > 3 * 20 * n


_SEES = """
import sys, time, rclpy
from rclpy.node import Node
rclpy.init()
node = Node("probe")
deadline, seen = time.monotonic() + float(sys.argv[2]), set()
while time.monotonic() < deadline and sys.argv[1] not in seen:
    rclpy.spin_once(node, timeout_sec=0.1)
    seen |= {t for t, _ in node.get_topic_names_and_types()}
print(sys.argv[1] in seen)
"""


def _sees(host, topic: str, seconds: float, **env: str) -> bool:
    """Whether a probe node on ``host`` finds ``topic`` in the graph within ``seconds``."""
    done = subprocess.run(host.command(sys.executable, "-c", _SEES, topic, str(seconds)),
                          capture_output=True, text=True, timeout=120,
                          env={**rtcf_env(), **_hosts.UDP_ONLY, **env},
                          stdin=subprocess.DEVNULL)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip() == "True"


def test_a_runner_kept_to_localhost_is_found_from_its_own_host_only(hosts, tmp_path):
    """ROS 2 Jazzy's ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (docs/security.md): a
    runner that talks only to its own computer is not found from the network."""
    host_a, host_b = hosts
    ramp = ('  <node name="{0}" pkg="rtcf" type="rt_launcher" args="rtcf_examples Ramp">'
            '<remap from="out" to="/hosts/{0}"/></node>')
    local = _launch(tmp_path, "local", 50.0, ramp.format("local"))
    open_ = _launch(tmp_path, "open", 50.0, ramp.format("open"))
    procs = []
    for launch, extra in ((local, {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}),
                          (open_, {})):
        out = tmp_path / launch.stem
        out.mkdir()
        env = {**rtcf_env(), **_hosts.UDP_ONLY, **extra}
        procs.append(subprocess.Popen(
            host_a.command(sys.executable, "-m", "rtcf", "launch", str(launch),
                           "--middleware", "ros2", "--duration", "30"),
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
            text=True, env=env))
    try:
        # on its own host, a probe kept to localhost too finds it
        assert _sees(host_a, "/hosts/local", 15, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        # from the other host: the open runner is found, the local one is not
        assert _sees(host_b, "/hosts/open", 15)
        assert not _sees(host_b, "/hosts/local", 5)
    finally:
        for p in procs:
            p.terminate()
            p.communicate(timeout=30)
