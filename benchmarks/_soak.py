"""The parts of soak.py that run in processes of their own.

* :class:`SeqLogger`, an rtcf component (it runs in the worker, so this module
  imports nothing but rtcf at the top): every iteration it logs ``seq N`` and writes
  N on its output, which the soak maps to a ROS 2 topic; in ``stop`` it writes how
  many it wrote to a JSON file.
* ``python _soak.py supervisor LAUNCH ...``: the supervisor, wired as
  ``rtcf launch --middleware ros2`` wires it (a :class:`WorkerRunner` with a
  :class:`Ros2Bridge`, component records handed to Python logging and written to
  stderr one line each), with two additions that change nothing in the loop: the
  bridge also aggregates the timing rows it is handed for ``~/iteration_info`` into
  one window of iterations at a time (wake-up jitter and calculation histograms,
  exact maximum, overrun rows) and prints each window as a JSON line on stdout; and
  after the run it prints the run's counts (the loop's overruns, the aggregate's
  overrun rows, dropped timing rows and log records) as a JSON line.
* ``python _soak.py subscriber --topic T``: an rclpy node that counts every message
  on the mapped topic, with sequence gaps, duplicates and reordering; it prints its
  progress as JSON lines and, on SIGINT, its totals.

The supervisor keeps no state that grows with the run: the windows are printed and
forgotten, the histograms are reset.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import rtcf

WINDOW_QUANTILES = ("p50", "p99", "p999", "max")


class SeqLogger(rtcf.Component):
    """Logs ``seq N`` and writes N (an int, mapped to std_msgs/Int64) every iteration.

    It reads Fig. 1's last output so that it runs after R3. ``~counts_file``: where
    ``stop`` writes how many records and messages it wrote.
    """

    def configure(self) -> None:
        self.inp = self.add_input("in", float)
        self.out = self.add_output("seq", int)
        self.counts_file = str(self.params.get("~counts_file", ""))
        self.seq = 0

    def update(self) -> None:
        self.inp.read()
        seq = self.seq + 1
        self.seq = seq
        self.log.info("seq %d", seq)
        self.out.write(seq)

    def stop(self) -> None:
        if self.counts_file:
            with open(self.counts_file, "w") as f:
                json.dump(
                    {
                        "updates": self.seq,
                        "log_records_written": self.seq,
                        "messages_written": self.seq,
                    },
                    f,
                )


# -- the supervisor ---------------------------------------------------------------------


def _emit(event: str, **fields: Any) -> None:
    """One JSON line on stdout (soak.py reads them as they come)."""
    sys.stdout.write(json.dumps({"event": event, **fields}) + "\n")
    sys.stdout.flush()


def malloc_kb() -> dict[str, int]:
    """glibc's heap of this process, and the blocks CPython's own allocator holds."""
    from rtcf._runtime._heap import malloc_kb as heap

    return {**heap(), "py_blocks": sys.getallocatedblocks()}


class Windows:
    """Timing rows aggregated per window of ``size`` iterations (iteration // size).

    Fixed memory: two histograms, reset after each window is printed. ``emit`` gets
    each finished window as a dict.
    """

    def __init__(self, size: int, period_ns: int, emit: Any) -> None:
        from rtcf._core._histogram import LogHistogram

        self.size = size
        self.period_ns = period_ns
        self.emit = emit
        self.jitter = LogHistogram()
        self.calc = LogHistogram()
        self.index = 0
        self.rows = 0
        self.overruns = 0
        self.late = 0
        self.first = -1
        self.last = -1

    def add(self, rows: Any) -> None:
        import numpy as np

        from rtcf._core._timing import COL_CALC, COL_ITERATION, COL_JITTER, COL_OVERRAN

        index = rows[:, COL_ITERATION] // self.size
        start, n = 0, len(rows)
        while start < n:
            k = int(index[start])
            if k != self.index:
                self.flush()
                self.index = k
            end = start + int(np.searchsorted(index[start:], k, side="right"))
            part = rows[start:end]
            self.jitter.add(part[:, COL_JITTER])
            self.calc.add(part[:, COL_CALC])
            self.overruns += int(part[:, COL_OVERRAN].sum())
            self.late += int((part[:, COL_JITTER] >= self.period_ns).sum())
            if self.first < 0:
                self.first = int(part[0, COL_ITERATION])
            self.last = int(part[-1, COL_ITERATION])
            self.rows += len(part)
            if self.last == (k + 1) * self.size - 1:  # the window's last iteration
                self.flush()
                self.index = k + 1
            start = end

    def flush(self) -> None:
        if self.rows == 0:
            return
        jitter, calc = self.jitter.summary_us(), self.calc.summary_us()
        self.emit(
            {
                "index": self.index,
                "first_iteration": self.first,
                "last_iteration": self.last,
                "rows": self.rows,
                "overrun_rows": self.overruns,
                "late_by_a_period": self.late,
                "jitter_us": {k: jitter[k] for k in WINDOW_QUANTILES},
                "calc_us": {k: calc[k] for k in WINDOW_QUANTILES},
                "malloc_kb": malloc_kb(),
            }
        )
        self.jitter.reset()
        self.calc.reset()
        self.rows = self.overruns = self.late = 0
        self.first = self.last = -1


def supervisor_main(argv: list[str]) -> int:
    import argparse
    import logging
    import os
    import signal
    import time

    from rtcf._core._names import basename, namespace_of
    from rtcf._launch._deployment import plan
    from rtcf._launch._xml import parse_launch_file
    from rtcf._ros2._bridge import Ros2Bridge
    from rtcf._runtime._supervisor import WorkerRunner

    p = argparse.ArgumentParser(prog="_soak.py supervisor")
    p.add_argument("launch")
    p.add_argument("--iterations", type=int, required=True)
    p.add_argument("--window", type=int, required=True, help="iterations per window")
    p.add_argument(
        "--wait-for-node",
        default="",
        help="start the loop once this ROS node is in the graph (the counting subscriber)",
    )
    args = p.parse_args(argv)

    # as rtcf launch prints component records: one line each on stderr
    from rtcf._cli._main import _Formatter

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Formatter())
    root = logging.getLogger("rtcf")
    root.handlers[:] = [handler]
    root.setLevel(logging.INFO)
    root.propagate = False

    deployment = plan(parse_launch_file(args.launch, {}))
    target = deployment.runner
    period_ns = round(1e9 / target.settings.frequency)
    windows = Windows(args.window, period_ns, lambda w: _emit("window", **w))

    class SoakBridge(Ros2Bridge):
        """The ROS 2 bridge; the rows it publishes as iteration_info also go to windows."""

        def iteration_info(self, rows: Any) -> None:
            windows.add(rows)
            super().iteration_info(rows)

    bridge = SoakBridge(basename(target.name), namespace_of(target.name))
    runner = WorkerRunner(
        target.settings,
        name=target.name,
        parameters=deployment.parameters,
        log_level="info",
        on_started=lambda realtime: _emit(
            "started", supervisor_pid=os.getpid(), worker_pid=runner.pid, realtime=realtime
        ),
        bridge=bridge,
    )
    stops: list[int] = []

    def on_signal(signum: int, frame: Any) -> None:
        if stops:
            raise KeyboardInterrupt
        stops.append(signum)
        runner.request_stop()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        runner.start()
        for spec in target.components:
            runner.load(spec)
        info = runner.describe()
        if info["not_ready"]:
            raise SystemExit(f"the loop would never start: {info['not_ready']}")
        _emit("loaded", order=info["order"], worker_pid=runner.pid)
        if args.wait_for_node:
            # discovery between the two participants can take seconds on a loaded
            # machine (the periodic announcements); once it is done, the topic's writer,
            # created as the run starts, is matched within milliseconds
            t0 = time.monotonic()
            while args.wait_for_node not in bridge.node.get_node_names():
                if time.monotonic() - t0 > 60:
                    raise SystemExit(f"node {args.wait_for_node} not discovered in 60 s")
                time.sleep(0.05)
            _emit("discovered", node=args.wait_for_node, after_s=time.monotonic() - t0)
        result = runner.run(args.iterations)
        windows.flush()  # the last (maybe partial) window
        aggregate = result.aggregate
        assert aggregate is not None
        _emit(
            "result",
            iterations=result.iterations,
            stopped_by=str(result.stopped_by),
            overruns_loop=result.timing.overruns,
            overrun_rows=aggregate.overruns,
            timing_rows=aggregate.rows,
            timing_rows_dropped=aggregate.dropped,
            log_records_dropped=result.log_records_dropped,
            jitter_us=result.timing.jitter_us,
            calc_us=result.timing.calc_us,
            components_us=result.timing.components_us,
            order=result.order,
            realtime=result.realtime,
            histograms_ns={k: v for k, v in aggregate.histograms().items() if k != "components"},
        )
        errors = [str(e) for e in runner.shutdown()]
        _emit("shutdown", errors=errors)
    finally:
        runner.close()
    return 0


# -- the subscriber ---------------------------------------------------------------------


def subscriber_main(argv: list[str]) -> int:
    import argparse
    import time

    p = argparse.ArgumentParser(prog="_soak.py subscriber")
    p.add_argument("--topic", required=True)
    p.add_argument("--depth", type=int, required=True, help="QoS history depth")
    p.add_argument("--progress-s", type=float, default=0.5)
    p.add_argument("--window", type=int, default=1, help="count arrivals per N numbers")
    args = p.parse_args(argv)

    from _ros2_node import spin_until_stopped, start_node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Int64

    node = start_node("rtcf_soak_counter")
    s: dict[str, float] = {
        "received": 0,
        "first": 0,
        "last": 0,  # the highest sequence number seen
        "missing": 0,  # numbers skipped between first and last
        "duplicates_or_reordered": 0,
        "first_at": 0.0,
        "last_at": 0.0,
    }
    gap_runs: list[list[int]] = []  # [first missing, how many], the first 100
    per_window: dict[int, int] = {}  # numbers received per window of --window numbers

    def on_message(msg: Int64) -> None:
        seq = int(msg.data)
        s["received"] += 1
        last = int(s["last"])
        if seq > last:
            if last == 0:
                s["first"] = seq
                s["first_at"] = time.monotonic()
            elif seq > last + 1:
                s["missing"] += seq - last - 1
                if len(gap_runs) < 100:
                    gap_runs.append([last + 1, seq - last - 1])
            s["last"] = seq
            s["last_at"] = time.monotonic()
            k = (seq - 1) // args.window
            per_window[k] = per_window.get(k, 0) + 1
        else:
            s["duplicates_or_reordered"] += 1

    qos = QoSProfile(
        depth=args.depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    node.create_subscription(Int64, args.topic, on_message, qos)

    def progress() -> None:
        sys.stdout.write(json.dumps({"event": "progress", **s}) + "\n")
        sys.stdout.flush()

    node.create_timer(args.progress_s, progress)
    spin_until_stopped(node, lambda: _emit("ready"))
    final = {"event": "final", **s, "gap_runs": gap_runs, "per_window": per_window}
    sys.stdout.write(json.dumps(final) + "\n")
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    role, rest = sys.argv[1], sys.argv[2:]
    sys.exit(supervisor_main(rest) if role == "supervisor" else subscriber_main(rest))
