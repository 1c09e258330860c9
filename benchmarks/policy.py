"""A learned policy in the loop: what an inference costs, and what it does to a 1 kHz loop.

Side by side in one run, with the cart-pole example's two networks (rtcf_examples
models, small 7-64-64-1 and large, the same function 2304 wide):

(a) one inference, in this process, in alternating rounds: `Policy.update` as the loop
    calls it (observation assembled from its ports, the model, the action written),
    onnxruntime called bare on the same model with the same session options and
    IOBinding (what the component adds is the difference), and torch on the same
    weights if it is importable (not a dependency of rtcf: skipped with a note
    otherwise). Back to back (warm caches) and paced at the policy's 50 Hz (a 20 ms
    sleep before each call: the caches as the loop finds them). p50 and p99.
(b) allocations per inference: tracemalloc around many `Policy.update` calls (what is
    kept, and the peak).
(c) the loop: `rtcf launch rtcf_examples cartpole.launch --report` at 1 kHz in real
    time, the large network inline (`policy_lane:=main`: in the loop's own iteration)
    and on logical execution time (`every` 20, a lane of its own), and the small one on
    LET as shipped: wake-up jitter, overruns, LET overruns, the policy's time per run.

    .venv/bin/python benchmarks/policy.py [--duration S] [--rounds N] [--quick]
"""

from __future__ import annotations

import sys
import time
import tracemalloc
from importlib import resources
from pathlib import Path
from typing import Any

import _common as c
import numpy as np

NAME = "policy"
MODELS = Path(str(resources.files("rtcf_examples") / "models"))
CONFIG = str(resources.files("rtcf_examples") / "config" / "cartpole_policy.yaml")
LAUNCH = Path(str(resources.files("rtcf_examples") / "launch" / "cartpole.launch"))


def policy_component(model: Path) -> Any:
    """A configured, started Policy fed by a source: update() as the loop calls it."""
    from rtcf import Component, ComponentSpec
    from rtcf.testing import run_components
    from rtcf_policy import Policy

    class State(Component):
        def configure(self) -> None:
            self.position = self.add_output("position", np.ndarray)
            self.velocity = self.add_output("velocity", np.ndarray)

        def update(self) -> None:
            self.position.write(np.array([0.01, 0.02]))
            self.velocity.write(np.array([0.0, -0.1]))

    # at the policy's own 50 Hz (control_dt 0.02 s: configure checks it) and inline, so
    # without the delay it was trained with (said, not refused): update() as the loop
    # calls it, whatever the schedule
    trace = run_components(
        [ComponentSpec("state", State),
         ComponentSpec("policy", Policy, params={"config": CONFIG, "model": str(model),
                                                 "on_delay_mismatch": "warn"})],
        2, frequency=50.0)
    return trace.components["/policy"]


def bare_session(model: Path) -> Any:
    """onnxruntime on the same model, the same options and IOBinding: run()."""
    from rtcf_policy._session import import_onnxruntime, session_options

    ort = import_onnxruntime("benchmark")
    session = ort.InferenceSession(str(model), session_options(ort),
                                   providers=["CPUExecutionProvider"])
    x = np.zeros((1, 7), np.float32)
    y = np.zeros((1, 1), np.float32)
    binding = session.io_binding()
    binding.bind_cpu_input(session.get_inputs()[0].name, x)
    binding.bind_output(session.get_outputs()[0].name, "cpu", 0, np.float32, [1, 1],
                        y.ctypes.data)
    options = ort.RunOptions()
    session.run_with_iobinding(binding, options)
    return lambda: session.run_with_iobinding(binding, options)


def torch_model(model: Path) -> Any:
    """The same MLP in torch (Gemm/MatMul + Add + activation, read from the ONNX
    file), or None with the reason."""
    try:
        import torch
    except ImportError:
        return None
    import onnx
    from onnx import numpy_helper

    graph = onnx.load(str(model)).graph
    weights = {t.name: torch.from_numpy(numpy_helper.to_array(t).copy())
               for t in graph.initializer}
    ops = [(n.op_type, list(n.input)) for n in graph.node]
    x = torch.zeros((1, 7))

    def run() -> None:
        with torch.inference_mode():
            h = x
            for op, inputs in ops:
                if op == "Gemm":
                    h = h @ weights[inputs[1]].T + weights[inputs[2]]
                elif op == "MatMul":
                    h = h @ weights[inputs[1]]
                elif op == "Add":
                    h = h + weights[inputs[1]]
                elif op == "Tanh":
                    h = torch.tanh(h)
                elif op == "Relu":
                    h = torch.relu(h)
                elif op == "Elu":
                    h = torch.nn.functional.elu(h)

    run()
    return run


def timed(fn: Any, n: int, pace_s: float) -> list[float]:
    """µs per call of fn, n calls, each after a sleep of pace_s (0: back to back)."""
    out = []
    for _ in range(n):
        if pace_s:
            time.sleep(pace_s)
        t0 = time.perf_counter_ns()
        fn()
        out.append((time.perf_counter_ns() - t0) / 1e3)
    return out


def allocations(policy: Any, n: int) -> dict[str, float]:
    """Bytes kept per update over n updates, and the peak above the start."""
    for _ in range(100):
        policy.update()
    tracemalloc.start()
    start, _ = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    for _ in range(n):
        policy.update()
    end, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {"kept_bytes_per_update": (end - start) / n, "peak_bytes": peak - start, "n": n}


def main() -> int:
    parser = c.parser(__doc__.splitlines()[0], 10)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    duration = args.duration or (0.5 if args.quick else 10.0)
    rounds = 1 if args.quick else args.rounds
    calls = {"small": 200 if args.quick else 5000, "large": 5 if args.quick else 300}
    paced = 5 if args.quick else 150
    machine = c.machine_info()
    started = time.perf_counter()
    # (a) and (b), in this process
    systems: dict[str, dict[str, Any]] = {}
    notes = []
    for net in ("small", "large"):
        model = MODELS / f"cartpole_policy_{net}.onnx"
        policy = policy_component(model)
        fns = {"Policy.update (observation, model, action)": policy.update,
               "onnxruntime bare (same options, IOBinding)": bare_session(model)}
        torch_run = torch_model(model)
        if torch_run is None:
            notes[:] = ["torch is not installed here (not a dependency of rtcf): its rows "
                        "are skipped"]
        else:
            fns["torch (same weights, inference_mode)"] = torch_run
        samples: dict[str, dict[str, list[float]]] = {k: {"warm": [], "paced": []} for k in fns}
        for r in range(rounds):
            for label in (list(fns) if r % 2 == 0 else list(fns)[::-1]):
                print(f"round {r + 1}: {net}: {label} ...", file=sys.stderr)
                samples[label]["warm"] += timed(fns[label], calls[net], 0.0)
                samples[label]["paced"] += timed(fns[label], paced // rounds + 1, 0.02)
        systems[net] = {
            "samples": {k: {m: c.summarize(v) for m, v in d.items()} for k, d in samples.items()},
            "allocations": allocations(policy, calls[net]),
        }
    # (c) the loop, real time, alternating rounds
    loops = {"large inline (main lane)": ("network:=large", "policy_lane:=main",
                                          "on_delay_mismatch:=warn"),
             "large on LET (lane policy, every 20)": ("network:=large",),
             "small on LET (as shipped)": ()}
    if args.quick:  # a smoke: the two that differ
        del loops["small on LET (as shipped)"]
    runs: dict[str, list[c.RtcfRun]] = {k: [] for k in loops}
    with c.workdir() as work, c.cpu_dma_latency_zero() as held:
        for r in range(rounds):
            for k, key in enumerate(loops if r % 2 == 0 else list(loops)[::-1]):
                print(f"round {r + 1}: loop: {key}, {duration:g} s ...", file=sys.stderr)
                runs[key].append(c.run_rtcf(LAUNCH, duration, work / f"{r}-{k}",
                                            extra_args=loops[key]))
    elapsed = time.perf_counter() - started

    rows_a = []
    for net, d in systems.items():
        bare = d["samples"]["onnxruntime bare (same options, IOBinding)"]
        for label, s in d["samples"].items():
            rows_a.append([
                net, label, c.fmt(s["warm"]["p50"]), c.fmt(s["warm"]["p99"]),
                c.fmt_ratio(c.ratio(s["warm"]["p50"], bare["warm"]["p50"])),
                c.fmt(s["paced"]["p50"]), c.fmt(s["paced"]["p99"]),
            ])
    tab_a = c.table(["model", "called", "back to back p50 [µs]", "p99", "p50 / bare",
                     "at 50 Hz p50 [µs]", "p99"], rows_a)
    rows_b = [[net, f"{d['allocations']['kept_bytes_per_update']:.2f}",
               str(int(d["allocations"]["peak_bytes"]))] for net, d in systems.items()]
    tab_b = c.table(["model", "bytes kept per Policy.update", "peak above the start [B]"],
                    rows_b)

    def worst(key: str, *path: str) -> float:
        values = []
        for run in runs[key]:
            d: Any = run.timing
            for p in path:
                d = d.get(p, {}) if isinstance(d, dict) else {}
            if isinstance(d, (int, float)):
                values.append(float(d))
        return max(values) if values else float("nan")

    rows_c = []
    for key in loops:
        policy_path = (("components", "/cartpole/policy", "calc_us") if "inline" in key
                       else ("lanes", "policy", "components", "/cartpole/policy", "calc_us"))
        iterations = sum(r.timing["iterations"] for r in runs[key])
        overruns = sum(r.timing["overruns"] for r in runs[key])
        let = sum(r.timing.get("lanes", {}).get("policy", {}).get("overruns", 0)
                  for r in runs[key])
        rows_c.append([
            key, str(iterations), f"{overruns} ({100.0 * overruns / max(1, iterations):.1f} %)",
            "" if "inline" in key else str(let),
            c.fmt(worst(key, "jitter_us", "p50")), c.fmt(worst(key, "jitter_us", "p99")),
            c.fmt(worst(key, "jitter_us", "max")), c.fmt(worst(key, "calc_us", "p99")),
            c.fmt(worst(key, *policy_path, "p50")), c.fmt(worst(key, *policy_path, "p99")),
        ])
    tab_c = c.table(["1 kHz loop, real time", "iterations", "overruns", "LET overruns",
                     "jitter p50 [µs]", "p99", "max", "iteration calc p99 [µs]",
                     "policy p50 [µs]", "policy p99"], rows_c)
    c.print_report(machine, elapsed, tab_a, tab_b, tab_c, *notes)
    data = {
        "benchmark": NAME, "timestamp": c.now_iso(), "duration_s_per_run": duration,
        "rounds": rounds, "machine": machine, "load_avg_after": c.load_avg(),
        "cpu_dma_latency_zero": held, "inference": systems, "notes": notes,
        "loops": {k: [r.timing for r in v] for k, v in runs.items()}, "elapsed_s": elapsed,
    }
    paragraphs = [
        f"`benchmarks/policy.py`: {rounds} alternating rounds; load average after the runs "
        f"{', '.join(f'{x:.1f}' for x in data['load_avg_after'])}. (a) One inference in the "
        "benchmark's process (normal scheduling): `Policy.update` as the loop calls it, "
        "onnxruntime bare on the same model with the same session options and IOBinding, "
        "back to back and paced at 50 Hz (a 20 ms sleep before each call). (b) tracemalloc "
        f"around `Policy.update`. (c) `cartpole.launch` at 1 kHz for **{duration:g} s** per "
        "run in real time, every lane at SCHED_FIFO 80 on a CPU of its own; the worst "
        "round's quantiles.",
        tab_a, tab_b, tab_c, *notes,
    ]
    c.write_results(NAME, data, args.quick, paragraphs)
    return 0


if __name__ == "__main__":
    c.main_guard(main)
