"""Train the cart-pole example's policy: behaviour cloning of a delay-aware LQR expert,
with numpy, in seconds; exported to ONNX with the onnx package's helper API.

    python -m rtcf_examples.train_cartpole_policy [--config YAML] [--out DIR]

The expert plans for the delay the policy runs with (docs/policies.md): the policy,
on logical execution time with ``every`` N at 1 kHz, sees the state that iteration
``r - 1`` left and its action reaches the PD stage at ``r + N``. Over one period of the
policy the cart's PD stage therefore follows the action of two releases before for one
millisecond and the last release's for the rest: the expert's state is the cart-pole's
with those two actions in flight (and the policy's observation has both, as its
``last_action`` history). The model of it is MuJoCo's own linearisation of the shipped
MJCF about the upright pole, the PD stage closed around it at 1 ms.

Writes ``cartpole_policy_small.onnx`` (7-64-64-1, ReLU: what the example ships) and
``cartpole_policy_large.onnx``: the same function, made wide and deep by exact identity
layers (2304 wide, generated inside the graph, so the file stays small) to take a few
milliseconds per inference: the LET case. Fixed seeds: the same bytes on every run.
"""

from __future__ import annotations

import argparse
import itertools
import time
from importlib import resources
from pathlib import Path

import numpy as np

from rtcf_policy import PolicyConfig, load_config

SEED = 40
HIDDEN = (64, 64)
LARGE_WIDTH, LARGE_LAYERS = 2304, 4


def shipped(*parts: str) -> str:
    return str(resources.files("rtcf_examples").joinpath(*parts))


def linearised(model_path: str, kp: float, kd: float) -> tuple[np.ndarray, np.ndarray]:
    """One 1 ms step of the cart-pole with the PD stage closed around the cart: ``s' =
    A s + B u`` about the upright pole, s = [cart, angle, cart velocity, angular velocity],
    u the PD stage's target."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(model_path)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    a, b = np.zeros((4, 4)), np.zeros((4, 1))
    mujoco.mjd_transitionFD(model, data, 1e-6, True, a, b, None, None)
    pd = np.array([[kp, 0.0, kd, 0.0]])  # force = kp (u - x) - kd xdot
    return a - b @ pd, b * kp


def delayed(a: np.ndarray, b: np.ndarray, every: int, delay: bool) -> tuple[np.ndarray, ...]:
    """From one release to the next (``every`` steps): z' = F z + G u with z the state the
    policy sees and, with ``delay``, the two actions in flight [u(k-1), u(k-2)]."""
    power = np.linalg.matrix_power
    if not delay:  # inline: the action acts from the step after the state it saw
        return power(a, every), sum((power(a, i) @ b for i in range(every)), np.zeros((4, 1)))
    first = power(a, every - 1) @ b  # u(k-2) for the first step
    rest = sum((power(a, i) @ b for i in range(every - 1)), np.zeros((4, 1)))  # u(k-1)
    f = np.zeros((6, 6))
    f[:4, :4], f[:4, 4:5], f[:4, 5:6] = power(a, every), rest, first
    f[5, 4] = 1.0  # u(k-1) becomes u(k-2)
    g = np.zeros((6, 1))
    g[4, 0] = 1.0
    return f, g


def lqr(f: np.ndarray, g: np.ndarray, q: np.ndarray, r: float) -> np.ndarray:
    """The discrete LQR gain (the Riccati recursion to its fixed point)."""
    p = q.copy()
    for _ in range(5000):
        k = np.linalg.solve(r + g.T @ p @ g, g.T @ p @ f)
        nxt = q + f.T @ p @ (f - g @ k)
        if np.max(np.abs(nxt - p)) < 1e-10 * max(1.0, np.max(np.abs(p))):
            p = nxt
            break
        p = nxt
    return np.linalg.solve(r + g.T @ p @ g, g.T @ p @ f)


def expert(config: PolicyConfig, every: int) -> np.ndarray:
    """The delay-aware expert's gain on [s - s*, u(k-1) - c, u(k-2) - c]."""
    kp, kd = float(config.kps[0]), float(config.kds[0])  # type: ignore[index]
    a, b = linearised(shipped("models", "cartpole.xml"), kp, kd)
    f, g = delayed(a, b, every, delay=True)
    q = np.diag([4.0, 40.0, 0.5, 1.0, 0.01, 0.01])
    gain = lqr(f, g, q, 0.2)
    worst = max(abs(np.linalg.eigvals(f - g @ gain)))
    if not worst < 1.0:
        raise SystemExit(f"train_cartpole_policy: the expert is not stable ({worst:.3f})")
    return gain


def dataset(config: PolicyConfig, gain: np.ndarray, n: int,
            rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Observations as the configuration assembles them, and the expert's raw action."""
    scale, offset = float(config.action.scale[0]), float(config.action.offset[0])
    x = rng.uniform(-0.6, 0.6, n)
    angle = rng.uniform(-0.3, 0.3, n)
    xd = rng.uniform(-1.5, 1.5, n)
    ad = rng.uniform(-2.5, 2.5, n)
    c = rng.uniform(-0.5, 0.5, n)
    u1 = c + rng.uniform(-1.0, 1.0, n)  # the targets in flight
    u2 = c + rng.uniform(-1.0, 1.0, n)
    z = np.stack([x - c, angle, xd, ad, u1 - c, u2 - c], axis=1)
    u = c - z @ gain[0]
    raw = lambda target: (target - offset) / scale  # noqa: E731 (the action's inverse)
    obs = np.zeros((n, config.num_obs))
    values = {"joint_pos": [x, angle], "joint_vel": [xd, ad], "command": [c],
              "last_action": [raw(u2), raw(u1)]}  # history: oldest first
    at = 0
    for term in config.terms:
        for k, v in enumerate(values[term.name]):
            j = k % term.size
            obs[:, at] = np.clip((v - term.offset[j]) * term.scale[j], term.low[j], term.high[j])
            at += 1
    return obs, np.clip(raw(u), -config.action.clip, config.action.clip)[:, None]


def train(obs: np.ndarray, act: np.ndarray, rng: np.random.Generator,
          steps: int = 4000, batch: int = 256) -> list[tuple[np.ndarray, np.ndarray]]:
    """A ReLU MLP by Adam on the squared error: its layers' (W, b)."""
    sizes = (obs.shape[1], *HIDDEN, act.shape[1])
    layers = [(rng.standard_normal((m, k)) * np.sqrt(2.0 / m), np.zeros(k))
              for m, k in itertools.pairwise(sizes)]
    moments = [[np.zeros_like(p) for p in layer for _ in (0, 1)] for layer in layers]
    lr, b1, b2 = 3e-3, 0.9, 0.999
    for step in range(1, steps + 1):
        pick = rng.integers(0, len(obs), batch)
        h, hs = obs[pick], []
        for k, (w, b) in enumerate(layers):
            hs.append(h)
            h = h @ w + b
            if k < len(layers) - 1:
                h = np.maximum(h, 0.0)
        grad = 2.0 * (h - act[pick]) / batch
        rate = lr * (0.1 ** (step / steps))  # decays tenfold over the run
        for k in range(len(layers) - 1, -1, -1):
            w, b = layers[k]
            gw, gb = hs[k].T @ grad, grad.sum(axis=0)
            if k:
                grad = (grad @ w.T) * (hs[k] > 0.0)
            for j, (p, g) in enumerate(((w, gw), (b, gb))):
                m, v = moments[k][2 * j], moments[k][2 * j + 1]
                m *= b1
                m += (1 - b1) * g
                v *= b2
                v += (1 - b2) * g * g
                p -= rate * (m / (1 - b1 ** step)) / (np.sqrt(v / (1 - b2 ** step)) + 1e-8)
    return layers


def forward(layers: list[tuple[np.ndarray, np.ndarray]], obs: np.ndarray) -> np.ndarray:
    h = obs
    for k, (w, b) in enumerate(layers):
        h = h @ w + b
        if k < len(layers) - 1:
            h = np.maximum(h, 0.0)
    return h


def export(layers: list[tuple[np.ndarray, np.ndarray]], path: Path, large: bool,
           doc: str) -> None:
    """The MLP as ONNX: Gemm and Relu nodes; ``large``: the same function with exact
    identity layers between (ReLU after ReLU changes nothing), 2304 wide."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    nodes, inits = [], []

    def constant(name: str, value: np.ndarray) -> str:
        inits.append(numpy_helper.from_array(value, name))
        return name

    n_in, n_out = layers[0][0].shape[0], layers[-1][0].shape[1]
    x = "obs"
    last = len(layers) - 1
    for k, (w, b) in enumerate(layers):
        w32, b32 = w.astype(np.float32), b.astype(np.float32)
        if large:  # widen: zeros past the trained units (Pad, in the graph: a small file)
            rows = n_in if k == 0 else LARGE_WIDTH
            cols = n_out if k == last else LARGE_WIDTH
            pads = [0, 0, rows - w32.shape[0], cols - w32.shape[1]]
            nodes.append(helper.make_node("Pad", [constant(f"W{k}_trained", w32), constant(
                f"W{k}_pads", np.array(pads, dtype=np.int64))], [f"W{k}"]))
            weight = f"W{k}"
            b32 = np.pad(b32, (0, cols - b32.size))
        else:
            weight = constant(f"W{k}", w32)
        y = "actions" if k == last else f"h{k}"
        nodes.append(helper.make_node("Gemm", [x, weight, constant(f"b{k}", b32)],
                                      [y if k == last else f"g{k}"]))
        if k < last:
            nodes.append(helper.make_node("Relu", [f"g{k}"], [y]))
        x = y
        if large and k == 0:  # identity layers: generated in the graph (EyeLike)
            shape = constant("eye_shape", np.array([LARGE_WIDTH, LARGE_WIDTH], dtype=np.int64))
            nodes.append(helper.make_node("ConstantOfShape", [shape], ["eye_zeros"],
                                          value=helper.make_tensor("z", TensorProto.FLOAT, [1],
                                                                   [0.0])))
            nodes.append(helper.make_node("EyeLike", ["eye_zeros"], ["eye"]))
            for j in range(LARGE_LAYERS):
                nodes.append(helper.make_node("MatMul", [x, "eye"], [f"i{j}"]))
                nodes.append(helper.make_node("Relu", [f"i{j}"], [f"ih{j}"]))
                x = f"ih{j}"
    graph = helper.make_graph(
        nodes, "cartpole_policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, n_in])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, n_out])], inits)
    model = helper.make_model(graph, producer_name="rtcf_examples.train_cartpole_policy",
                              opset_imports=[helper.make_opsetid("", 17)], doc_string=doc)
    model.ir_version = 8  # what onnxruntime >= 1.14 reads
    onnx.checker.check_model(model)
    path.write_bytes(model.SerializeToString())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rtcf_examples.train_cartpole_policy",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=shipped("config", "cartpole_policy.yaml"))
    parser.add_argument("--out", default=shipped("models"), help="where the .onnx files go")
    parser.add_argument("--every", type=int, default=20,
                        help="the policy's period in loop iterations at 1 kHz")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    config = load_config(args.config, model="unused.onnx")
    rng = np.random.default_rng(SEED)
    gain = expert(config, args.every)
    obs, act = dataset(config, gain, 60_000, rng)
    layers = train(obs, act, rng)
    test_obs, test_act = dataset(config, gain, 5_000, np.random.default_rng(SEED + 1))
    error = float(np.sqrt(np.mean((forward(layers, test_obs) - test_act) ** 2)))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    doc = (f"cart-pole balance policy: behaviour cloning of a delay-aware LQR expert "
           f"(every {args.every} at 1 kHz, LET), seed {SEED}")
    export(layers, out / "cartpole_policy_small.onnx", False, doc)
    export(layers, out / "cartpole_policy_large.onnx", True, doc + "; widened by identities")
    print(f"train_cartpole_policy: expert gain {np.round(gain[0], 3).tolist()}; "
          f"validation RMS error {error:.4f} (raw action); wrote cartpole_policy_small.onnx and "
          f"cartpole_policy_large.onnx to {out} in {time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
