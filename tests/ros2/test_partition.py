"""The cable cut between two hosts (docs/ros2.md, "When the network fails"): host B's
runner feeds a controller on host A, which drives a plant and has a fallback that holds
it (``deadline/cmd`` 0.5 s, ``on_deadline deactivate``). One A runner for the module:
first the link between the hosts goes down for 3 s and up again, then B's runner is
killed (SIGKILL) and started anew. Checked from what A records (timing.json's
deadline events and input counts, its recording's values and timing rows): the
deadline applies in the first iteration that starts later than the last arrival plus
0.5 s, the plant stands while the fallback holds it, A's loop keeps its period through
the cut, the controller is active again once values come, and every number B sent is
accounted for: read, superseded, or never arrived. The hosts are test_several_hosts.py's
(two network namespaces and a veth pair; root)."""

import json
import time

import numpy as np
import pytest

import rtcf.recording

from .._launches import launch_xml, launcher_xml, runner_xml
from .._proc import interrupt, read_rest, wait_for, wait_for_count
from ._two_hosts import set_link, start_on, two_hosts

pytestmark = pytest.mark.integration

DEADLINE = 0.5
PERIOD = 0.01  # A's loop: 100 Hz
CUT = 3.0  # seconds the link is down
FED = 1.0  # seconds B feeds A before each cut and after it (the scenario's, not a wait)
DEPTH = 10  # the history of B's publisher (ros_qos_depth): what DDS sends again
RESUMED = "/ctl]: lifecycle: activate: inactive -> active"
EXPIRED = "input '/ctl.cmd' (/hosts/cmd) past its deadline of 0.5 s at iteration"

A = launch_xml(
    launcher_xml("ctl", "rtcf_partition_components Drive", {"cmd": "/hosts/cmd", "u": "/part/u"},
                 **{"deadline/cmd": DEADLINE, "on_deadline": "deactivate", "fallback": "hold"})
    + launcher_xml("hold", "rtcf_partition_components Hold", {"u": "/part/u"})
    + launcher_xml("plant", "rtcf_partition_components Plant", {"u": "/part/u", "x": "/part/x"}),
    runner_xml(1 / PERIOD, ros_mapping_whitelist="/hosts/.*"),
)
# B: a Ramp at 50 Hz, 1.0, 2.0, ... on /hosts/cmd: the numbers are the sequence
B = launch_xml(
    launcher_xml("feed", "rtcf_examples Ramp", {"out": "/hosts/cmd"}),
    runner_xml(50.0, ros_mapping_whitelist="/hosts/.*"),
)


@pytest.fixture(scope="module")
def hosts():
    yield from two_hosts("test_partition")


def _rtcf(host, launch, out, *extra):
    return start_on(host, "-m", "rtcf", "launch", launch, "--middleware", "ros2",
                    "--record", out / "run.mcap", "--report", out, *extra)


def test_a_cut_link_and_a_killed_feed_hand_over_to_the_fallback_and_back(hosts, tmp_path):
    host_a, host_b = hosts
    (tmp_path / "a.launch").write_text(A)
    (tmp_path / "b.launch").write_text(B)
    for name in ("a", "b1", "b2"):
        (tmp_path / name).mkdir()
    proc_a = _rtcf(host_a, tmp_path / "a.launch", tmp_path / "a")
    feeds = []
    try:
        wait_for(proc_a, "running until Ctrl-C", timeout=60)
        feeds.append(_rtcf(host_b, tmp_path / "b.launch", tmp_path / "b1"))
        wait_for(proc_a, "partition: the feed is here", timeout=60)
        time.sleep(FED)
        # the cable: down for CUT seconds (the deadline applies meanwhile), then up
        down = time.monotonic()
        set_link(host_b, False)
        wait_for_count(proc_a, EXPIRED, 1, timeout=30)
        time.sleep(max(0.0, CUT - (time.monotonic() - down)))
        set_link(host_b, True)
        cut = time.monotonic() - down
        wait_for_count(proc_a, RESUMED, 1, timeout=60)
        time.sleep(FED)
        # B's runner killed, then started anew
        feeds[0].kill()
        killed = time.monotonic()
        wait_for_count(proc_a, EXPIRED, 2, timeout=30)
        feeds.append(_rtcf(host_b, tmp_path / "b.launch", tmp_path / "b2"))
        restarted = time.monotonic() - killed
        wait_for_count(proc_a, RESUMED, 2, timeout=60)
        time.sleep(FED)
        _, err_b = interrupt(feeds[1])
        assert feeds[1].returncode == 0, err_b
    finally:
        for proc in feeds:  # kill any still running, read those not yet read
            if not proc.stdout.closed:
                proc.kill()
                read_rest(proc)
        _, err_a = interrupt(proc_a)
    assert proc_a.returncode == 0, err_a

    doc = json.loads((tmp_path / "a" / "timing.json").read_text())
    events = doc["deadline_events"]
    # the cut, the killed runner, and the restarted one's end (never back: A ended)
    assert len(events) == 3 and events[-1]["back_iteration"] == -1, events
    for e in events:
        assert e["action"] == "deactivated" and e["fallback"] == "/hold"
        # exact on A's clock: the first iteration that starts after the deadline
        assert e["time"] > e["last_arrival"] + DEADLINE >= e["time"] - PERIOD - 1e-9
    partition, kill = events[0], events[1]

    rec = rtcf.recording.read(str(tmp_path / "a" / "run.mcap"))
    x = rec.series("/part/x")
    timing = rec.series("/rt_runner/iteration_info")
    for e in (partition, kill):
        held = (x.iterations >= e["iteration"]) & (x.iterations < e["back_iteration"])
        # the plant stands while the fallback holds it, and moves before and after
        assert held.sum() >= (e["back_iteration"] - e["iteration"]) - 1
        assert np.ptp(x.values[held]) == 0.0
        before = x.values[x.iterations < e["iteration"]]
        after = x.values[x.iterations > e["back_iteration"]]
        assert before[-1] > before[-10] and after[-1] > after[0]
        # A's loop keeps its period through the cut: every iteration ran, none late
        rows = timing.values[(timing.iterations >= e["iteration"] - 1)
                             & (timing.iterations <= e["back_iteration"])]
        its = rows[:, 0]
        assert np.array_equal(its, np.arange(its[0], its[0] + len(its)))
        late = rows[:, 3] + rows[:, 2] > PERIOD  # jitter + calculation past the period
        assert not late.any(), rows[late]

    # every number B sent accounted for: arrived (read or superseded), or never arrived
    counts = doc["inputs"]["/hosts/cmd"]
    assert counts["arrived"] == counts["read"] + counts["superseded"], counts
    cmd = rec.series("/hosts/cmd")
    run1 = cmd.iterations < kill["back_iteration"]
    read1, read2 = cmd.values[run1], cmd.values[~run1]
    assert len(read1) + len(read2) == counts["read"]
    for read in (read1, read2):
        assert np.all(np.diff(read) > 0)  # each run read in order, none twice
    # the restarted runner ended first: A read the last number it wrote
    sent2 = rtcf.recording.read(str(tmp_path / "b2" / "run.mcap")).series("/hosts/cmd").values
    assert read2[-1] == sent2[-1] == len(sent2)
    before = read1[cmd.iterations[run1] < partition["iteration"]]
    after = read1[cmd.iterations[run1] >= partition["back_iteration"]]
    in_cut = int(after[0] - before[-1] - 1)  # B's numbers A did not read across the cut
    # B counts 1, 2, ...: every number from A's first read of a run to its last was
    # sent (the killed runner's last ones after it, and those before DDS matched, are
    # outside); those A did not read were superseded or never arrived
    window = int(read1[-1] - read1[0] + 1 + read2[-1] - read2[0] + 1)
    unread = window - counts["read"]
    never = window - counts["arrived"]
    # outside the cut the link lost nothing: every number A did not read was superseded
    assert unread - in_cut <= counts["superseded"]
    # what never arrived was sent during the cut; of those, at most the history of
    # B's publisher (reliable, keep_last DEPTH) came late, when the link was back
    assert in_cut - DEPTH <= never <= in_cut, (in_cut, never, counts)
    resume = partition["back_time"] - partition["last_arrival"] - cut
    back = kill["back_time"] - kill["last_arrival"] - restarted
    print(f"\npartition: cut {cut:.2f} s (B sent about {cut * 50:.0f} meanwhile), never "
          f"arrived {never}, A did not read {in_cut} across it; A read {counts['read']}, "
          f"arrived {counts['arrived']}, superseded {counts['superseded']}; feed back "
          f"{resume:.3f} s after the link; killed runner: back {back:.3f} s after its "
          f"restart; DDS: {[ln for ln in err_a.splitlines() if 'ROS 2 input' in ln]}")
