"""Lanes: two branches on two cores, and a heavy slow controller on logical execution time.

Side by side in one run, in alternating rounds, at SCHED_FIFO 80:

(a) two independent branches at 1 kHz, each a `Busy` component with 150 µs of CPU per
    iteration reading one source, in one lane (one after the other) and in two lanes
    (one worker process each, on a CPU each): the loop's calculation time per
    iteration, each lane's, and what one cross-lane handover costs (a send and a
    receive of a float, in a tight in-process loop, and as the loop measured them);
(b) a heavy controller (`Busy`, 4 ms of CPU every 10 iterations) beside a 1 kHz loop,
    sequentially in the main lane and in a lane on logical execution time: overruns
    and wake-up jitter of the 1 kHz loop (target: overruns in at most 1 % of the
    iterations).

No chrt/taskset wrapper: every lane's worker pins and schedules itself (a wrapper's
affinity would put all lanes on one CPU).

    .venv/bin/python benchmarks/lanes.py [--duration S] [--rounds N] [--quick]
"""

from __future__ import annotations

import sys
import time
from typing import Any

import _common as c

NAME = "lanes"
FREQUENCY = 1000.0
BRANCH_US = 150
HEAVY_US = 4000
HEAVY_EVERY = 10
TARGET_OVERRUNS = 0.01


def branches(two_lanes: bool) -> list[c.Node]:
    lane = {"lane": '"right"'} if two_lanes else {}
    return [
        c.Node("src", "rtcf_examples", "Sine", [("out", "/x")]),
        c.Node("left", "rtcf_examples", "Busy", [("in_port", "/x"), ("out_port", "/l")],
               {"cost_us": str(BRANCH_US)}),
        c.Node("right", "rtcf_examples", "Busy", [("in_port", "/x"), ("out_port", "/r")],
               {"cost_us": str(BRANCH_US), **lane}),
    ]


def heavy(let: bool) -> list[c.Node]:
    lane = {"lane": '"mpc"'} if let else {}
    return [
        c.Node("src", "rtcf_examples", "Sine", [("out", "/x")]),
        c.Node("mpc", "rtcf_examples", "Busy", [("in_port", "/x"), ("out_port", "/u")],
               {"cost_us": str(HEAVY_US), "every": str(HEAVY_EVERY), **lane}),
        c.Node("sink", "rtcf_examples", "Identity", [("in_port", "/u"), ("out_port", "/y")]),
    ]


def handover_ns(n: int = 200_000) -> dict[str, float]:
    """ns per send and per receive of a float through a lanes channel, in one process."""
    from rtcf._core._lanes import RECV, SEND, Lane, Step
    from rtcf._core._loop_state import LoopState
    from rtcf._core._ports import OutputPort
    from rtcf._runtime._lanes import LaneLink, init_words, layout
    from rtcf._runtime._shm import Segment

    lanes = {"main": Lane("main", ("/a",)), "b": Lane("b", ("/b",))}
    lay = layout(lanes, {"/x": ("main", 8)})
    with Segment.create(lay.size, "bench") as seg:
        init_words(seg.buf, lay)
        state = LoopState(FREQUENCY)
        producer = OutputPort("/a", "out", float, state)
        producer.topic = "/x"
        stub = OutputPort("/b", "out", float)
        stub.topic = "/x"
        link = LaneLink(seg.buf, lay, "main", simulated=False, period_ns=1_000_000)
        link.bound(state, None, time.monotonic_ns)  # type: ignore[arg-type]
        link.words[6] = 0  # W_FIRST: values from iteration 0 on
        send = link.bind(Step(SEND, "/x"), producer)
        recv = link.bind(Step(RECV, "/x", False, "main"), stub)
        out: dict[str, float] = {}
        for label, steps in (("send", (send,)), ("receive", (recv,))):
            best = float("inf")
            for _ in range(3):
                state.iteration = 0
                producer.write(1.5)
                send()
                t0 = time.perf_counter_ns()
                for _ in range(n):
                    for step in steps:
                        step()
                best = min(best, (time.perf_counter_ns() - t0) / n)
            out[label] = best
        assert stub._slot.value == 1.5
        link.release()
    return out


def lane_calc(run: c.RtcfRun, lane: str) -> dict[str, Any]:
    return run.timing.get("lanes", {}).get(lane, {})


def main() -> int:
    parser = c.parser(__doc__.splitlines()[0], 10)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    duration = args.duration or (2.0 if args.quick else 10.0)
    rounds = 1 if args.quick else args.rounds
    machine = c.machine_info()
    started = time.perf_counter()
    runs: dict[str, list[c.RtcfRun]] = {k: [] for k in ("one", "two", "seq", "let")}
    with c.workdir() as work, c.cpu_dma_latency_zero() as held:
        files = {
            "one": c.launch_xml(branches(False), frequency=FREQUENCY),
            "two": c.launch_xml(branches(True), frequency=FREQUENCY),
            "seq": c.launch_xml(heavy(False), frequency=FREQUENCY),
            "let": c.launch_xml(heavy(True), frequency=FREQUENCY),
        }
        for key, text in files.items():
            (work / f"{key}.launch").write_text(text)
        for r in range(rounds):
            for pair in (("one", "two"), ("seq", "let")):
                for key in pair if r % 2 == 0 else pair[::-1]:
                    print(f"round {r + 1}: {key}, {duration:g} s ...", file=sys.stderr)
                    runs[key].append(
                        c.run_rtcf(work / f"{key}.launch", duration, work / f"{key}-{r}")
                    )
    ns = handover_ns()
    elapsed = time.perf_counter() - started

    def worst(key: str, path: tuple[str, ...], q: str) -> float:
        values = []
        for run in runs[key]:
            d: Any = run.timing
            for p in path:
                d = d.get(p, {})
            if d.get(q) is not None:
                values.append(d[q])
        return max(values) if values else float("nan")

    def handover_p50(key: str) -> float:
        comps = [
            v["calc_us"]["p50"] for run in runs[key]
            for k, v in lane_calc(run, "main").get("components", {}).items()
            if k.startswith("@")
        ]
        return min(comps) if comps else float("nan")

    rows_a = [
        ["one lane (sequential)", c.fmt(worst("one", ("calc_us",), "p50")),
         c.fmt(worst("one", ("calc_us",), "p99")), "",
         str(sum(r.timing["overruns"] for r in runs["one"]))],
        ["two lanes: the loop (first start to last end)",
         c.fmt(worst("two", ("calc_us",), "p50")),
         c.fmt(worst("two", ("calc_us",), "p99")), "",
         str(sum(r.timing["overruns"] for r in runs["two"]))],
        ["two lanes: main (src, left)", c.fmt(worst("two", ("lanes", "main", "calc_us"), "p50")),
         c.fmt(worst("two", ("lanes", "main", "calc_us"), "p99")), c.fmt(handover_p50("two")),
         str(sum(lane_calc(r, "main").get("overruns", 0) for r in runs["two"]))],
        ["two lanes: right", c.fmt(worst("two", ("lanes", "right", "calc_us"), "p50")),
         c.fmt(worst("two", ("lanes", "right", "calc_us"), "p99")), "",
         str(sum(lane_calc(r, "right").get("overruns", 0) for r in runs["two"]))],
    ]
    tab_a = c.table(
        ["(a) 2 x 150 µs at 1 kHz", "calc p50 [µs]", "calc p99 [µs]",
         "handover p50 in the loop [µs]", "overruns"], rows_a
    )
    iterations = {k: sum(r.timing["iterations"] for r in runs[k]) for k in ("seq", "let")}
    overruns = {k: sum(r.timing["overruns"] for r in runs[k]) for k in ("seq", "let")}
    rows_b = []
    for key, label in (("seq", "sequential (main lane)"), ("let", "LET lane")):
        rows_b.append([
            label, str(iterations[key]), str(overruns[key]),
            f"{100.0 * overruns[key] / max(1, iterations[key]):.2f} %",
            c.fmt(worst(key, ("jitter_us",), "p50")), c.fmt(worst(key, ("jitter_us",), "p99")),
            c.fmt(worst(key, ("jitter_us",), "max")),
            c.fmt(worst(key, ("lanes", "mpc", "let_margin_us"), "p99")) if key == "let" else "",
        ])
    tab_b = c.table(
        ["(b) 4 ms every 10 at 1 kHz", "iterations", "overruns", "share",
         "jitter p50 [µs]", "p99", "max", "LET margin at p99 [µs]"], rows_b
    )
    share = overruns["let"] / max(1, iterations["let"])
    one = worst("one", ("calc_us",), "p50")
    speedup = one / max(
        worst("two", ("lanes", "main", "calc_us"), "p50"),
        worst("two", ("lanes", "right", "calc_us"), "p50"),
    )
    whole = one / worst("two", ("calc_us",), "p50")
    met = "met" if share <= TARGET_OVERRUNS else "NOT met"
    summary = (
        f"(a) the longer lane's calc p50 is {speedup:.2f}x shorter than one lane's, the "
        f"loop's as a whole (first start to last end) {whole:.2f}x; one "
        f"handover costs {ns['send']:.0f} ns to send and {ns['receive']:.0f} ns to receive "
        f"(a float, in-process tight loop). (b) overruns {100 * share:.2f} % with LET "
        f"(target ≤ {100 * TARGET_OVERRUNS:.0f} %: {met})"
        f", against {100.0 * overruns['seq'] / max(1, iterations['seq']):.1f} % sequentially"
    )
    c.print_report(machine, elapsed, tab_a, tab_b, summary)
    data = {
        "benchmark": NAME,
        "timestamp": c.now_iso(),
        "duration_s_per_run": duration,
        "rounds": rounds,
        "machine": machine,
        "load_avg_after": c.load_avg(),
        "cpu_dma_latency_zero": held,
        "handover_ns": ns,
        "runs": {k: [r.timing for r in v] for k, v in runs.items()},
        "elapsed_s": elapsed,
    }
    paragraphs = [
        f"`benchmarks/lanes.py`: {rounds} alternating rounds of **{duration:g} s** per "
        "system, idle, every lane's worker at SCHED_FIFO 80 on a CPU of its own (the main "
        "lane on the last CPU, the other lane on the next one down). (a) Two branches "
        f"of one `Busy` with {BRANCH_US} µs of CPU each, reading one `Sine`, in one "
        "lane and in two; the worst round's quantiles. (b) A `Busy` with "
        f"{HEAVY_US / 1000:g} ms of CPU every {HEAVY_EVERY} iterations beside a 1 kHz loop "
        "(`Sine` -> `Busy` -> `Identity`), in the main lane and in a LET lane.",
        tab_a,
        tab_b,
        summary + ".",
    ]
    c.write_results(NAME, data, args.quick, paragraphs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
