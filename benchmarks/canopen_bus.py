"""What the CAN bus costs a 1 kHz loop: CiA 402 drives over CANopen, rtcf's non-blocking
exchange (rtcf_canopen/Cia402System) side by side with canopen's own Notifier path.

    .venv/bin/python benchmarks/canopen_bus.py [--cycles N] [--rounds N] [--quick]

Needs root (``unshare --net``, SCHED_FIFO) and ``ip``. In a network namespace of its
own (lo up, a multicast route on lo; never the machine's own interfaces): six simulated
drives (``python -m rtcf_canopen.sim_drive``, one process, SCHED_FIFO 60 on CPU 0, as a
real drive answers within microseconds) on python-can's ``udp_multicast`` bus, and one
master process on the last CPU (``_canopen_master.py``) that runs every condition in
alternating rounds: 1 and 6 drives, rtcf's path and canopen's, with and without
SCHED_FIFO 80. Per run: read and write p50/p99 (µs), frames the master received per
cycle, the CPU the process used per cycle (the Notifier's thread included) and the share
of stale cycles; for rtcf also its own read and write on prebuilt frames (the plugin
without the interface), and python-can's own cost per frame (``send``, a non-blocking
``recv``) on ``udp_multicast`` and ``virtual``. socketcan is measured where the kernel has
AF_CAN; this benchmark says so when it has not.

Writes ``results/canopen_bus.json`` and its section of docs/performance.md;
``--quick`` (200 cycles, one round: about 12 s) writes ``results/canopen_bus-quick.json``
and leaves the docs alone.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

from _common import RT_CPU, fmt, load_avg, machine_info, main_guard, now_iso, table, write_results

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"
PERIOD_US = 1000.0


def socketcan_here() -> str:
    """'' if this kernel has AF_CAN, else why not."""
    try:
        socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
    except (OSError, AttributeError) as exc:
        return f"socket(AF_CAN, SOCK_RAW, CAN_RAW) fails here: {exc}"
    return ""


def run_namespace(cycles: int, warmup: int, rounds: int, repeats: int) -> list[dict[str, Any]]:
    """The drives and the master in a network namespace; the master's JSON lines."""
    py = sys.executable
    ids = " ".join(f"--node-id {n}" for n in range(2, 8))
    sim_cpu = 0  # the master on RT_CPU (the last); on one core both share it
    script = textwrap.dedent(f"""\
        set -e
        ip link set lo up
        ip route add 224.0.0.0/4 dev lo
        log=$(mktemp)
        taskset -c {sim_cpu} {py} -m rtcf_canopen.sim_drive --priority 60 --duration 3600 \\
            {ids} > $log 2>&1 &
        sim=$!
        for i in $(seq 50); do grep -q "sim_drive:" $log && break; sleep 0.1; done
        set +e
        {py} {HERE / "_canopen_master.py"} --cycles {cycles} --warmup {warmup} \\
            --rounds {rounds} --repeats {repeats} --cpu {RT_CPU}
        echo "master exited $?"
        kill $sim
        wait
        """)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(SRC), env.get("PYTHONPATH", "")) if p)
    proc = subprocess.run(["unshare", "--net", "sh", "-c", script], capture_output=True,
                          text=True, env=env, stdin=subprocess.DEVNULL, timeout=3600)
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    if "master exited 0" not in proc.stdout:
        raise SystemExit(f"canopen_bus: the master failed:\n{proc.stdout}\n{proc.stderr}")
    return rows


def median_of(runs: list[dict[str, Any]], *keys: str) -> float:
    values = []
    for run in runs:
        v: Any = run
        for k in keys:
            v = v[k]
        values.append(float(v))
    return statistics.median(values)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=None,
                    help="cycles per run at 1 kHz (default 5000; 200 with --quick)")
    ap.add_argument("--rounds", type=int, default=None,
                    help="alternating rounds (default 3; 1 with --quick)")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: writes results/canopen_bus-quick.json, not the docs")
    args = ap.parse_args()
    if os.geteuid() != 0 or shutil.which("unshare") is None or shutil.which("ip") is None:
        print("canopen_bus: needs root, unshare and ip (a network namespace)", file=sys.stderr)
        return 2
    cycles = args.cycles or (200 if args.quick else 5000)
    rounds = args.rounds or (1 if args.quick else 3)
    machine = machine_info()
    timestamp = now_iso()
    load_before = load_avg()
    rows = run_namespace(cycles, 100 if args.quick else 500, rounds, 1 if args.quick else 5)
    load_after = load_avg()
    runs = [r for r in rows if "path" in r]
    frames = {r["per_frame"]: r for r in rows if "per_frame" in r}
    no_socketcan = socketcan_here()

    table_rows, summary = [], {}
    for n in (1, 6):
        for fifo in (False, True):
            for path in ("rtcf", "notifier"):
                mine = [r for r in runs if r["drives"] == n and r["fifo"] == fifo
                        and r["path"] == path]
                if not mine:
                    continue
                s: dict[str, float] = {}
                for k in ("read_us", "write_us", "exchange_us"):
                    for q in ("p50", "p99"):
                        s[f"{k[:-3]}_{q}"] = median_of(mine, k, q)
                for k in ("frames_per_cycle", "cpu_per_cycle_us", "stale_share"):
                    s[k] = median_of(mine, k)
                if path == "rtcf":
                    s["own_read_us"] = min(r["own_read_us"] for r in mine)
                    s["own_write_us"] = min(r["own_write_us"] for r in mine)
                summary[f"{path}-{n}-{'fifo' if fifo else 'other'}"] = s
                table_rows.append([
                    str(n), "rtcf (recv(0), no thread)" if path == "rtcf"
                    else "canopen Notifier thread", "FIFO 80" if fifo else "OTHER",
                    fmt(s["read_p50"]), fmt(s["read_p99"]), fmt(s["write_p50"]),
                    fmt(s["write_p99"]), fmt(s["exchange_p50"]),
                    f"{100 * s['exchange_p50'] / PERIOD_US:.1f} %",
                    fmt(s["cpu_per_cycle_us"]), fmt(s["frames_per_cycle"]),
                    f"{100 * s['stale_share']:.2f} %"])
    main_table = table(["drives", "path", "scheduler", "read p50 [µs]", "read p99",
                        "write p50", "write p99", "read+write p50", "of 1 ms",
                        "CPU per cycle [µs]", "frames in per cycle", "stale cycles"],
                       table_rows)
    own_rows = []
    for n in (1, 6):
        s = summary.get(f"rtcf-{n}-fifo") or summary.get(f"rtcf-{n}-other")
        if s is None:
            continue
        own = s["own_read_us"] + s["own_write_us"]
        own_rows.append([str(n), fmt(s["own_read_us"]), fmt(s["own_write_us"]), fmt(own),
                         f"{100 * own / PERIOD_US:.1f} %", fmt(s["exchange_p50"]),
                         fmt(s["exchange_p50"] - own)])
    own_table = table(["drives", "own read [µs]", "own write [µs]", "own read+write",
                       "of 1 ms", "with udp_multicast, p50 [µs]", "the interface's part"],
                      own_rows)
    frame_rows = [[name, fmt(f["send_us"], 2), fmt(f["recv_us"], 2),
                   fmt(f["empty_recv_us"], 2)] for name, f in frames.items()]
    frame_rows.append(["socketcan", "-", "-", "-"] if no_socketcan else [])
    frame_table = table(["python-can interface", "send [µs/frame]", "recv(0) of a frame",
                         "recv(0) of nothing"], [r for r in frame_rows if r])
    intro = (f"`benchmarks/canopen_bus.py`: CiA 402 drives simulated by "
             f"`rtcf_canopen.sim_drive` (one process, SCHED_FIFO 60, CPU 0) and a master "
             f"(CPU {RT_CPU}) on python-can's `udp_multicast` in a network namespace of its "
             f"own, at 1 kHz on absolute deadlines; **{cycles} cycles** per run, {rounds} "
             "alternating round(s), medians of the rounds' quantiles. *rtcf*: "
             "Cia402System's `read` (drain with `recv(timeout=0)`, convert, check) and "
             "`write` (targets, RPDOs, SYNC). *canopen Notifier*: `Network.connect` (its "
             "thread receives), the TPDOs' values from the `PdoVariable`s, "
             "`PdoVariable.raw =`, `PdoMap.transmit`, `sync.transmit` (its thread's work is "
             "in no column but CPU). Stale: a drive's TPDOs not all there at the next read. "
             f"Load average before and after: {load_before} → {load_after}.")
    repeats = 1 if args.quick else 5
    own_intro = ("The plugin's own share: the same `read` and `write` in the same process "
                 "on prebuilt frames (a bus object that hands out one cycle's frames, its "
                 f"own echoes included, and sends nothing), best of {repeats} x 2000; the "
                 "rest of the exchange is python-can's:")
    frame_intro = ("python-can's own cost per frame, two buses in one process (SCHED_FIFO "
                   "80), batches of 100 frames:" + (
                       f" socketcan not measured: {no_socketcan}." if no_socketcan else ""))
    print(intro, main_table, own_intro, own_table, frame_intro, frame_table, sep="\n\n")
    data = {"machine": machine, "timestamp": timestamp, "cycles": cycles, "rounds": rounds,
            "load_avg_before": load_before, "load_avg_after": load_after,
            "summary": summary, "per_frame": frames,
            "socketcan": {"measured": not no_socketcan, "why_not": no_socketcan},
            "runs": runs}
    write_results("canopen_bus", data, args.quick,
                  [intro, main_table, own_intro, own_table, frame_intro, frame_table])
    return 0


if __name__ == "__main__":
    main_guard(main)
