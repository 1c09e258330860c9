"""rtcf launch --foxglove: a WebSocket client speaking Foxglove's protocol (the
subprotocol foxglove.sdk.v1) sees the channels advertised, subscribes, and receives
the loop's values, decimated to the rate asked for."""

import itertools
import json
import signal
import struct
import time

import pytest
from websockets.sync.client import connect

from .._proc import env_with, read_rest, start_rtcf, wait_for_match
from .conftest import FIXTURES, SRC, run_rtcf

pytestmark = pytest.mark.integration

CASCADE = SRC / "rtcf_examples" / "launch" / "cascade.launch"


def _start(*args):
    return start_rtcf(env_with(FIXTURES), "launch", *args)


def test_a_foxglove_client_receives_the_loops_values():
    proc = _start(CASCADE, "--duration", "30", "--foxglove", "0", "--foxglove-rate", "20",
                  "--quiet")
    try:
        url = wait_for_match(proc, r"serving (ws://127\.0\.0\.1:\d+)", timeout=60).group(1)
        got: dict[int, list[tuple[int, float]]] = {}
        with connect(url, subprotocols=["foxglove.sdk.v1"], open_timeout=20) as ws:
            channels = {}
            deadline = time.monotonic() + 20
            while len(channels) < 6 and time.monotonic() < deadline:
                msg = ws.recv(timeout=10)
                if isinstance(msg, str):
                    data = json.loads(msg)
                    if data.get("op") == "advertise":
                        for ch in data["channels"]:
                            channels[ch["topic"]] = ch
            assert {"/cascade/position", "/cascade/position_setpoint"} <= set(channels)
            assert channels["/cascade/position"]["encoding"] == "json"
            subs = {1: "/cascade/position", 2: "/cascade/position_setpoint"}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": k, "channelId": channels[t]["id"]} for k, t in subs.items()]}))
            deadline = time.monotonic() + 3
            while time.monotonic() < deadline:
                msg = ws.recv(timeout=10)
                if isinstance(msg, bytes) and msg[0] == 0x01:  # message data
                    sub, log_time = struct.unpack_from("<IQ", msg, 1)
                    value = json.loads(msg[13:])["data"]
                    got.setdefault(sub, []).append((log_time, value))
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = read_rest(proc, timeout=60)
    assert proc.returncode == 0, err
    position = got[1]
    assert len(position) >= 20  # 3 s at 20 per second, give or take the start
    times = [t for t, _ in position]
    # decimated to 20 per second of loop time: 50 ms apart at least, in order
    assert all(b - a >= 50_000_000 for a, b in itertools.pairwise(times))
    assert all(isinstance(v, float) for _, v in position)
    assert {v for _, v in got[2]} <= {0.0, 1.0}  # the supervisor's steps
    assert "foxglove: sent" in err


def test_serving_beyond_loopback_needs_an_explicit_flag():
    result = run_rtcf("launch", CASCADE, "--sim", "--duration", "0.01", "--foxglove", "0",
                      "--foxglove-host", "0.0.0.0")
    assert result.returncode == 1
    assert "needs --foxglove-any-host too" in result.stderr
