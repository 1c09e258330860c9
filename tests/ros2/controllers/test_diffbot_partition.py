"""The diffbot example on host A, a teleop on host B (test_several_hosts.py's two
network namespaces joined by a veth pair; root), and the cable between them cut for
3 s (docs/ros2.md, "When the network fails"). diff_drive_controller's own
cmd_vel_timeout (0.5 s, the example's YAML file) stops the base on A by itself during
the cut, and it drives again when the link returns. Checked from A's recording: the
commands its loop read (their stamps and sequence numbers), the odometry its
controller wrote, and the iteration's timing rows."""

import select
import time

import numpy as np
import pytest

import rtcf.recording

from ..._proc import interrupt, read_rest, wait_for
from .._two_hosts import set_link, start_on, two_hosts
from ..conftest import FIXTURES

pytestmark = pytest.mark.integration

CMD = "/diffbot_base_controller/cmd_vel"
ODOM = "/diffbot_base_controller/odom"
TIMEOUT = 0.5  # diffbot_controllers.yaml's cmd_vel_timeout
SPEED = 0.5  # m/s, the teleop's
CUT = 3.0  # s the link is down
DRIVE = 2.0  # s the base drives before the cut and after it


@pytest.fixture
def hosts():
    yield from two_hosts("test_diffbot_partition")


def test_the_base_stops_by_itself_during_a_cut_and_drives_again_after_it(hosts, tmp_path):
    host_a, host_b = hosts
    out = tmp_path / "a"
    out.mkdir()
    diffbot = start_on(host_a, "-m", "rtcf", "launch", "rtcf_examples", "diffbot.launch",
                       "--middleware", "ros2", "--record", out / "run.mcap", "--report", out)
    teleop = None
    try:
        wait_for(diffbot, "running until Ctrl-C", timeout=60)
        teleop = start_on(host_b, "-u", FIXTURES / "teleop.py", CMD, SPEED)
        ready, _, _ = select.select([teleop.stdout], [], [], 60)
        assert ready and teleop.stdout.readline().strip() == "matched", interrupt(teleop)
        # the scenario's own times: drive, cut the cable, put it back, drive
        time.sleep(DRIVE)
        set_link(host_b, False)
        time.sleep(CUT)
        set_link(host_b, True)
        time.sleep(DRIVE)
    finally:
        if teleop is not None:
            teleop.kill()
            read_rest(teleop)
        _, err = interrupt(diffbot)
    assert diffbot.returncode == 0, err

    rec = rtcf.recording.read(str(out / "run.mcap"))
    decode_cmd, decode_odom = rec.decoder(CMD), rec.decoder(ODOM)
    cmds = [(m.log_time, decode_cmd(m.data)) for m in rec.messages[CMD]]
    cmds = [c for k, c in enumerate(cmds)  # each as first read
            if k == 0 or c[1].header.frame_id != cmds[k - 1][1].header.frame_id]
    odoms = [(m.log_time, decode_odom(m.data)) for m in rec.messages[ODOM]]
    seq = np.array([int(c.header.frame_id) for _, c in cmds])
    read_ns = np.array([t for t, _ in cmds])
    assert np.all(np.diff(seq) > 0)  # read in order
    # the cut: the longest gap between two commands A's loop read
    k = int(np.argmax(np.diff(read_ns)))
    last_ns, back_ns = read_ns[k], read_ns[k + 1]
    last = cmds[k][1].header.stamp
    last_stamp = last.sec * 10**9 + last.nanosec
    assert (back_ns - last_ns) * 1e-9 > CUT - 0.5
    speed = np.array([o.twist.twist.linear.x for _, o in odoms])
    t_odom = np.array([t for t, _ in odoms])
    # A drove at the teleop's speed before the cut, up to the last command's timeout
    driving = (t_odom > last_ns - 1e9) & (t_odom < last_stamp + TIMEOUT * 1e9)
    assert driving.sum() > 20 and speed[driving].min() > SPEED - 0.05
    # then A's controller braked by itself: standing within the timeout plus the
    # wheels' stop, and standing until commands came again
    stopped = speed[(t_odom > last_stamp + (TIMEOUT + 0.25) * 1e9) & (t_odom < back_ns)]
    assert len(stopped) > 50 and np.abs(stopped).max() < 0.01
    # decided on A: its controller commanded the wheels to zero in the first
    # iteration past the last command's stamp plus cmd_vel_timeout (1 kHz)
    wheels = rec.series("/velocity_command")
    zero = wheels.t_ns[(wheels.t_ns > last_stamp) & np.all(wheels.values == 0.0, axis=1)][0]
    # (the recording may drop a record when its ring is full: 20 ms of slack)
    assert TIMEOUT < (zero - last_stamp) * 1e-9 <= TIMEOUT + 0.02
    stop_ns = t_odom[(t_odom > last_stamp) & (np.abs(speed) < 0.01)][0]
    # and it drives again when the link is back
    after = speed[t_odom > back_ns + 0.5e9]
    assert len(after) > 20 and after.min() > SPEED - 0.05
    # the commands sent during the cut (their sequence numbers): none was read; any
    # that DDS delivered late, stamped more than cmd_vel_timeout ago, the controller
    # ignores (and says so)
    ignored = err.count("ignoring a cmd_vel stamped")
    print(f"\ndiffbot: wheels commanded to 0 {(zero - last_stamp) * 1e-9:.4f} s and "
          f"standing {(stop_ns - last_stamp) * 1e-9:.3f} s after the last command's stamp; "
          f"sent during the cut {seq[k + 1] - seq[k] - 1}, late ones ignored {ignored}; "
          f"back after {(back_ns - last_ns) * 1e-9:.3f} s")
    assert (stop_ns - last_stamp) * 1e-9 < TIMEOUT + 0.25
    assert "velocity command timed out: braking" in err
