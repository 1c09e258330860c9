"""rtcf replay: the recorded launch file on the recorded inputs gives the recording
again; a launch file without the plant is fed the plant's recorded outputs, and a
changed controller shows up in what it writes."""

import re
import struct

import pytest
from mcap.reader import make_reader

from .conftest import SRC, run_rtcf

pytestmark = pytest.mark.integration

LAUNCH = SRC / "rtcf_examples" / "launch"


def messages(path):
    """(topic, iteration, log time, CDR bytes) of every message, in a stable order."""
    with open(path, "rb") as f:
        out = [(c.topic, m.sequence, m.log_time, bytes(m.data))
               for _, c, m in make_reader(f).iter_messages()
               if not c.topic.endswith("/iteration_info")]  # timing: a replay has none
    return sorted(out)


def record(tmp_path, name, *args):
    path = tmp_path / name
    result = run_rtcf("launch", *args, "--sim", "--record", path)
    assert result.returncode == 0, result.stderr
    return path


def test_a_replay_of_the_complex_architecture_is_identical_to_its_recording(tmp_path):
    rec = record(tmp_path, "complex.mcap", LAUNCH / "complex_architecture.launch",
                 "--duration", "300")  # 1 Hz: 300 iterations
    result = run_rtcf("replay", rec)
    assert result.returncode == 0, result.stderr
    replay = tmp_path / "complex.replay.mcap"
    original = messages(rec)
    assert len(original) > 1000
    assert messages(replay) == original
    # and one whose values move: the cascade at three rates
    rec = record(tmp_path, "cascade.mcap", LAUNCH / "cascade.launch", "--duration", "0.2")
    assert run_rtcf("replay", rec).returncode == 0
    assert messages(tmp_path / "cascade.replay.mcap") == messages(rec)


def test_a_controller_replayed_on_the_recorded_plant(tmp_path):
    rec = record(tmp_path, "cascade.mcap", LAUNCH / "cascade.launch", "--duration", "0.2")
    text = (LAUNCH / "cascade.launch").read_text()
    # the same cascade without its motor: position and velocity come from the recording
    no_motor = re.sub(r"<node name=\"motor\".*?</node>", "", text, flags=re.S)
    no_motor = no_motor.replace('"num_components_expected" value="4"',
                                '"num_components_expected" value="3"')
    same = tmp_path / "controllers.launch"
    same.write_text(no_motor)
    out = tmp_path / "same.mcap"
    result = run_rtcf("replay", rec, same, "--record", out)
    assert result.returncode == 0, result.stderr
    assert "fed from the recording: /cascade/position, /cascade/velocity" in result.stderr
    original = messages(rec)
    replayed = messages(out)
    # the controllers wrote exactly what they wrote with the motor in the loop, and
    # the fed topics are recorded as they were fed
    assert replayed == original
    # a changed position gain: the first value it writes after the first step differs
    changed = tmp_path / "changed.launch"
    changed.write_text(no_motor.replace('<param name="kp" value="20.0"/>',
                                        '<param name="kp" value="5.0"/>'))
    out2 = tmp_path / "changed.mcap"
    result = run_rtcf("replay", rec, changed, "--record", out2)
    assert result.returncode == 0, result.stderr
    before = {(t, i): d for t, i, _, d in original if t == "/cascade/velocity_setpoint"}
    after = {(t, i): d for t, i, _, d in messages(out2) if t == "/cascade/velocity_setpoint"}
    assert before.keys() == after.keys()
    differ = sorted(i for (_, i) in before if before[("/cascade/velocity_setpoint", i)]
                    != after[("/cascade/velocity_setpoint", i)])
    assert differ[0] == 1  # its first run: kp 5 on a step of 1 is 5, kp 20 saturates at 10
    key = ("/cascade/velocity_setpoint", 1)
    assert struct.unpack("<d", before[key][4:12])[0] == 10.0
    assert struct.unpack("<d", after[key][4:12])[0] == 5.0
    fed = {(t, i) for t, i, _, _ in messages(out2) if t == "/cascade/position"}
    assert len(fed) == 400  # the plant's recorded values, fed every iteration


def test_bad_replays_are_one_clear_line(tmp_path):
    not_mcap = tmp_path / "x.mcap"
    not_mcap.write_text("hello")
    result = run_rtcf("replay", not_mcap)
    assert result.returncode == 1
    assert result.stderr == (
        f"rtcf: error: {not_mcap}: not an MCAP file (no MCAP magic at its start)\n"
    )
    result = run_rtcf("replay", tmp_path / "missing.mcap")
    assert result.returncode == 1
    assert "cannot read it: No such file or directory" in result.stderr
