"""The master side of benchmarks/canopen_bus.py, run inside the network namespace the
benchmark makes, beside the simulated drives: one process that runs every condition in
turn and prints one JSON object per run.

* ``rtcf``: rtcf_canopen/Cia402System as the resource manager loads it, its ``read`` and
  ``write`` timed at 1 kHz (absolute deadlines, ``clock_nanosleep``), a ramp commanded;
  then the same read and write against prebuilt frames (a bus object that hands them out
  and sends nothing): the plugin's own share, without the interface.
* ``notifier``: canopen's own way, the same exchange: ``Network.connect`` (its Notifier
  thread receives and decodes), the same PDO mapping, each cycle the TPDOs' values taken
  from the ``PdoVariable``s, ``PdoVariable.raw =`` per target, ``PdoMap.transmit`` per
  RPDO and ``network.sync.transmit()``.

Both: frames the master received per cycle, stale cycles (a drive's TPDO 1 not renewed
since the last SYNC), and the CPU the process used per cycle (both threads on the
notifier path).
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import json
import os
import struct
import sys
import time
import timeit
from collections.abc import Iterator
from typing import Any

import can
import canopen
import numpy as np

from rtcf._core._resource_manager import ResourceManager
from rtcf_canopen import _cia402
from rtcf_canopen._bringup import _map
from rtcf_canopen._config import default_eds

CHANNEL = "239.74.163.2"
PRIORITY = 80


def urdf(n: int) -> str:
    links = "".join(
        f'<link name="l{i}"/><joint name="j{i}" type="revolute"><parent link="base"/>'
        f'<child link="l{i}"/><limit lower="-3" upper="3" velocity="5" effort="10"/></joint>'
        for i in range(n))
    joints = "".join(
        f'<joint name="j{i}"><param name="node_id">{i + 2}</param>'
        '<command_interface name="position"/><state_interface name="position"/>'
        '<state_interface name="velocity"/></joint>' for i in range(n))
    return (f'<robot name="r"><link name="base"/>{links}<ros2_control name="drives" '
            'type="system"><hardware><plugin>rtcf_canopen/Cia402System</plugin><param '
            f'name="interface">udp_multicast</param><param name="channel">{CHANNEL}</param>'
            f'</hardware>{joints}</ros2_control></robot>')


def set_scheduler(fifo: bool, cpu: int) -> str:
    os.sched_setaffinity(0, {cpu})
    try:
        if fifo:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PRIORITY))
        else:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except OSError as exc:
        return f"not applied ({exc})"
    return "SCHED_FIFO" if os.sched_getscheduler(0) == os.SCHED_FIFO else "SCHED_OTHER"


def quantiles(ns: list[int]) -> dict[str, float]:
    a = np.array(ns, dtype=float) / 1000.0
    return {"p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)),
            "max": float(a.max())}


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


_LIBC = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)


def ticks(cycles: int, period_ns: int) -> Iterator[int]:
    """Absolute deadlines on CLOCK_MONOTONIC (libc's clock_nanosleep, TIMER_ABSTIME),
    one per cycle, as rtcf's loop waits."""
    ts = _Timespec()
    ref = ctypes.byref(ts)
    sleep = _LIBC.clock_nanosleep
    start = time.monotonic_ns() + period_ns
    for k in range(cycles):
        deadline = start + k * period_ns
        ts.tv_sec, ts.tv_nsec = divmod(deadline, 1_000_000_000)
        sleep(time.CLOCK_MONOTONIC, 1, ref, None)
        yield k


class ReplayBus:
    """Hands out one cycle's frames (as the drives and the echo give them) and sends
    nothing: the plugin's own cost without the interface's."""

    def __init__(self, frames: list[can.Message]) -> None:
        self.frames, self.i, self.k = frames, 0, len(frames)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        i = self.i
        if i < self.k:
            self.i = i + 1
            return self.frames[i]
        return None

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        pass


def cycle_frames(n: int) -> list[can.Message]:
    out = [can.Message(arbitration_id=0x200 + d + 2, is_extended_id=False, data=bytes(7))
           for d in range(n)]
    out.append(can.Message(arbitration_id=0x80, is_extended_id=False, data=b""))
    for d in range(n):
        out.append(can.Message(arbitration_id=0x182 + d, is_extended_id=False,
                               data=struct.pack("<Hbi", 0x0237, 8, 1000 * d)))
        out.append(can.Message(arbitration_id=0x282 + d, is_extended_id=False,
                               data=struct.pack("<ih", 5, 0)))
    return out


def run_rtcf(n: int, cycles: int, warmup: int, repeats: int) -> dict[str, Any]:
    rm = ResourceManager.from_urdf(urdf(n), update_rate=1000)
    rm.set_initial_states([], [])
    hw = rm.components["drives"].impl
    if not getattr(hw, "_active", False):
        raise SystemExit(f"rtcf: the {n} drive(s) did not come up")
    ex = hw.exchange
    idx = rm.command_indices([f"j{i}/position" for i in range(n)])
    start = rm.states[rm.state_indices([f"j{i}/position" for i in range(n)])].copy()
    goal = np.empty(n)
    reads, writes = [], []
    frames0 = syncs0 = 0
    stale0 = ex.stale.copy()
    cpu0 = time.process_time()
    clock = time.perf_counter_ns
    for k in ticks(warmup + cycles, 1_000_000):
        if k == warmup:
            frames0, syncs0, stale0 = ex.frames, ex.syncs, ex.stale.copy()
            cpu0 = time.process_time()
            reads.clear()
            writes.clear()
        t = k * 0.001
        a = clock()
        hw.read(t, 0.001)
        b = clock()
        np.multiply(start, 1.0, out=goal)
        goal += 0.2 * min(1.0, k / 2000)
        np.put(rm.commands, idx, goal)
        c = clock()
        hw.write(t, 0.001)
        d = clock()
        reads.append(b - a)
        writes.append(d - c)
    cpu = time.process_time() - cpu0
    stale = (ex.stale - stale0).tolist()
    syncs = ex.syncs - syncs0
    out = {"read_us": quantiles(reads), "write_us": quantiles(writes),
           "exchange_us": quantiles([r + w for r, w in zip(reads, writes, strict=True)]),
           "frames_per_cycle": (ex.frames - frames0) / cycles,
           "cpu_per_cycle_us": cpu / cycles * 1e6,
           "stale_share": sum(stale) / max(1, syncs * n), "stale_per_drive": stale,
           "syncs": syncs}
    # the plugin's own: the same read and write on prebuilt frames
    real, replay = ex.bus, ReplayBus(cycle_frames(n))
    ex.bus = replay

    def own_read() -> None:
        replay.i = 0
        hw.read(0.0, 0.001)

    def own_write() -> None:
        hw.write(0.0, 0.001)

    out["own_read_us"] = min(timeit.repeat(own_read, number=2000, repeat=repeats)) / 2000 * 1e6
    out["own_write_us"] = min(timeit.repeat(own_write, number=2000, repeat=repeats)) / 2000 * 1e6
    out["own_frames"] = len(replay.frames)
    ex.bus = real
    rm.shutdown_components()
    return out


class Counter(can.Listener):
    def __init__(self) -> None:
        self.n = 0

    def on_message_received(self, msg: can.Message) -> None:
        self.n += 1


def run_notifier(n: int, cycles: int, warmup: int) -> dict[str, Any]:
    network = canopen.Network()
    network.connect(interface="udp_multicast", channel=CHANNEL, fd=False)
    counter = Counter()
    assert network.notifier is not None
    network.notifier.add_listener(counter)
    nodes = []
    for d in range(n):
        nid = d + 2
        node = canopen.RemoteNode(nid, default_eds())
        network.add_node(node)
        node.nmt.state = "PRE-OPERATIONAL"
        _map(node.rpdo[1], 0x200 + nid, (0x6040, 0x6060, 0x607A))
        _map(node.rpdo[2], 0x300 + nid, ())
        _map(node.tpdo[1], 0x180 + nid, (0x6041, 0x6061, 0x6064))
        _map(node.tpdo[2], 0x280 + nid, (0x606C, 0x6077))
        for pdo in (node.rpdo[1], node.rpdo[2], node.tpdo[1], node.tpdo[2]):
            pdo.save()
        node.sdo[0x6060].raw = _cia402.CSP
        node.nmt.state = "OPERATIONAL"
        nodes.append(node)
    rp = [node.rpdo[1] for node in nodes]
    tp1 = [node.tpdo[1] for node in nodes]
    tp2 = [node.tpdo[2] for node in nodes]
    cw = [p.map[0] for p in rp]
    target = [p.map[2] for p in rp]
    for d, p in enumerate(rp):
        p.map[1].raw = _cia402.CSP
        target[d].raw = 0
    # the CiA 402 state machines to OPERATION ENABLED, by PDO
    deadline = time.monotonic() + 2.0
    while True:
        for p in rp:
            p.transmit()
        network.sync.transmit()
        time.sleep(0.005)
        states = [_cia402.state_of(p.map[0].raw) for p in tp1]
        if all(s == _cia402.OPERATION_ENABLED for s in states):
            break
        if time.monotonic() > deadline:
            raise SystemExit(f"notifier: drives not enabled: {states}")
        for d, s in enumerate(states):
            cw[d].raw = _cia402.step_toward(s, _cia402.OPERATION_ENABLED, cw[d].raw)
    start = [p.map[2].raw for p in tp1]
    for d in range(n):
        target[d].raw = start[d]
    positions, velocities = np.zeros(n), np.zeros(n)
    last = [p.timestamp for p in tp1]
    stale = [0] * n
    reads, writes = [], []
    clock = time.perf_counter_ns
    frames0 = 0
    cpu0 = time.process_time()
    for k in ticks(warmup + cycles, 1_000_000):
        if k == warmup:
            frames0 = counter.n
            stale = [0] * n
            cpu0 = time.process_time()
            reads.clear()
            writes.clear()
        a = clock()
        for d in range(n):  # what the Notifier's thread decoded since the last cycle
            p1 = tp1[d]
            if p1.timestamp == last[d]:
                stale[d] += 1
            last[d] = p1.timestamp
            positions[d] = p1.map[2].raw * 0.001
            velocities[d] = tp2[d].map[0].raw * 0.001
            if p1.map[0].raw & 0x6F != 0x27:
                raise SystemExit(f"notifier: node {d + 2} left OPERATION ENABLED")
        b = clock()
        ramp = 200 * min(1.0, k / 2000)
        for d in range(n):
            target[d].raw = int(start[d] + ramp)
            rp[d].transmit()
        network.sync.transmit()
        c = clock()
        reads.append(b - a)
        writes.append(c - b)
    cpu = time.process_time() - cpu0
    out = {"read_us": quantiles(reads), "write_us": quantiles(writes),
           "exchange_us": quantiles([r + w for r, w in zip(reads, writes, strict=True)]),
           "frames_per_cycle": (counter.n - frames0) / cycles,
           "cpu_per_cycle_us": cpu / cycles * 1e6,
           "stale_share": sum(stale) / (cycles * n), "stale_per_drive": stale,
           "syncs": cycles}
    for d in range(n):
        cw[d].raw = _cia402.CW_DISABLE_VOLTAGE
        rp[d].transmit()
    network.sync.transmit()
    time.sleep(0.01)
    for node in nodes:
        node.nmt.state = "PRE-OPERATIONAL"
    network.disconnect()
    return out


def per_frame(interface: str, channel: str, frames: int) -> dict[str, float]:
    """python-can's own cost per frame: ``send`` and a non-blocking ``recv`` of a
    frame that is there, on two buses of this process (batches of 100, the socket's
    buffer holds them)."""
    kwargs: dict[str, Any] = {"fd": False} if interface == "udp_multicast" else {}
    a = can.Bus(interface=interface, channel=channel, **kwargs)
    b = can.Bus(interface=interface, channel=channel, **kwargs)
    msg = can.Message(arbitration_id=0x181, is_extended_id=False, data=bytes(7))
    send_ns = recv_ns = empty_ns = 0
    done = 0
    clock = time.perf_counter_ns
    while done < frames:
        t0 = clock()
        for _ in range(100):
            a.send(msg, 0.0)
        t1 = clock()
        got = 0
        while got < 100:
            if b.recv(0.0) is not None:
                got += 1
        t2 = clock()
        b.recv(0.0)
        t3 = clock()
        while a.recv(0.0) is not None:  # a's own frames, echoed on udp_multicast
            pass
        send_ns += t1 - t0
        recv_ns += t2 - t1
        empty_ns += t3 - t2
        done += 100
    a.shutdown()
    b.shutdown()
    return {"send_us": send_ns / done / 1000, "recv_us": recv_ns / done / 1000,
            "empty_recv_us": empty_ns / (done / 100) / 1000}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cycles", type=int, default=5000)
    ap.add_argument("--warmup", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--drives", default="1,6")
    ap.add_argument("--cpu", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    counts = [int(x) for x in args.drives.split(",")]
    import logging

    logging.basicConfig(level=logging.WARNING)
    for rnd in range(args.rounds):
        for fifo in (False, True):
            for path in ("rtcf", "notifier"):
                for n in counts:
                    sched = set_scheduler(fifo, args.cpu)
                    if path == "rtcf":
                        res = run_rtcf(n, args.cycles, args.warmup, args.repeats)
                    else:
                        res = run_notifier(n, args.cycles, args.warmup)
                    set_scheduler(False, args.cpu)
                    res.update(round=rnd, fifo=fifo, scheduler=sched, path=path, drives=n,
                               cycles=args.cycles)
                    print(json.dumps(res), flush=True)
    set_scheduler(True, args.cpu)
    for interface, channel in (("udp_multicast", "239.74.163.3"), ("virtual", "pf")):
        res = per_frame(interface, channel, 200 if args.cycles < 1000 else 2000)
        print(json.dumps({"per_frame": interface, **res}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
