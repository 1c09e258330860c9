"""rtcf_policy: the deploy configuration, the observation it assembles, the model's
shapes, what update allocates, and the cart-pole example on the simulated clock (the
action exactly every-N iterations after its observation, the PD stage's safe behaviour,
and the policy without the delay it was trained with)."""

from __future__ import annotations

import os
import tracemalloc
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ort = pytest.importorskip("onnxruntime")
onnx = pytest.importorskip("onnx")

from onnx import TensorProto, helper, numpy_helper  # noqa: E402

from rtcf import ComponentError, ComponentSpec, ConfigurationError, Rate  # noqa: E402
from rtcf.testing import run_components, run_launch  # noqa: E402
from rtcf_policy import JointPd, Policy, load_config  # noqa: E402

HZ = 100.0


def linear_model(path: Path, weights: np.ndarray) -> Path:
    """An ONNX model: actions = obs @ weights ([1, n] -> [1, m])."""
    n, m = weights.shape
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["obs", "W"], ["actions"])], "linear",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, n])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, m])],
        [numpy_helper.from_array(weights.astype(np.float32), "W")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    path.write_bytes(model.SerializeToString())
    return path


CONFIG = """
model: {model}
observation:
  - {{name: q, port: position, index: [1, 0], scale: [2.0, 1.0], offset: [0.5, 0.0], clip: 3.0}}
  - {{name: cmd, port: command, default: [7.0], clip: [-1.0, 5.0]}}
  - {{name: last_action, last_action: true, history: 2}}
action: {{port: target, scale: 0.5, offset: [1.0], clip: 10.0}}
kps: [10.0]
kds: [1.0]
"""


def write_config(tmp_path: Path, weights: np.ndarray, text: str = CONFIG) -> str:
    model = linear_model(tmp_path / "m.onnx", weights)
    path = tmp_path / "policy.yaml"
    path.write_text(text.format(model=model.name))
    return str(path)


class Source:
    pass


def _source(values: list[Any]) -> Any:
    from rtcf import Component

    class Feed(Component):
        def configure(self) -> None:
            self.out = self.add_output("position", np.ndarray)

        def update(self) -> None:
            self.out.write(values[self.iteration])

    return Feed


def test_the_observation_is_scaled_offset_clipped_with_history_and_the_last_action(
    tmp_path: Path,
) -> None:
    # 5 numbers: q (2: elements 1 then 0), cmd (1, its default 7 clipped to 5),
    # last_action x 2 (oldest first); the action: 0.1 * sum of the observation
    config = write_config(tmp_path, np.full((5, 1), 0.1))
    positions = [np.array([float(i), 0.5 + 0.25 * i]) for i in range(4)]
    trace = run_components([
        ComponentSpec("feed", _source(positions)),
        ComponentSpec("policy", Policy, params={
            "config": config, "publish_observation": True}),
    ], 4, frequency=HZ)
    observations = [o.tolist() for o in trace.outputs["/observation"]]
    # iteration 0: q = ((0.5 - 0.5) * 2, (0 - 0) * 1), cmd 5, no action yet (0, 0)
    raw0 = np.float32(0.1) * np.float32(5.0)
    assert observations[0] == [0.0, 0.0, 5.0, 0.0, 0.0]
    # iteration 1: q = ((0.75 - 0.5) * 2, 1), the last raw action as newest history row
    assert observations[1] == pytest.approx([0.5, 1.0, 5.0, 0.0, raw0])
    assert observations[2][3:] == pytest.approx([raw0, observations[1][:5] and
                                                 0.1 * sum(observations[1])], rel=1e-6)
    # iteration 3: q clipped at 3 ((1.25 - 0.5) * 2 = 1.5; 3 > 3? no: 3.0 stays)
    assert observations[3][:2] == [1.5, 3.0]
    targets = [float(t[0]) for t in trace.outputs["/target"]]
    assert targets == pytest.approx([0.1 * sum(o) * 0.5 + 1.0 for o in observations], rel=1e-6)


def test_a_model_of_another_shape_names_both_shapes_the_file_and_the_terms(
    tmp_path: Path,
) -> None:
    config = write_config(tmp_path, np.ones((4, 1)))
    with pytest.raises(ComponentError) as err:
        run_components([ComponentSpec("policy", Policy, params={"config": config})], 1)
    text = str(err.value)
    assert text.startswith("component '/policy': configure() failed: model ")
    assert "m.onnx: its input 'obs' has shape" in text
    assert "[1, 4]" in text and "[1, 5]" in text
    assert "q (2) + cmd (1) + last_action (1 x 2) = 5" in text
    assert "\n" not in text


def test_an_action_of_another_shape_names_the_action(tmp_path: Path) -> None:
    config = write_config(tmp_path, np.ones((5, 2)))
    with pytest.raises(ComponentError, match=r"output 'actions' has shape \[1, 2\].*"
                       r"action \[1, 1\]: action \(target: 1 numbers\)"):
        run_components([ComponentSpec("policy", Policy, params={"config": config})], 1)


@pytest.mark.parametrize(("text", "message"), [
    ("model: m.onnx\nobservation: [{name: a, port: p}]\n",
     r"term 'a': give index, size or default"),
    ("model: m.onnx\nobservation: [{name: a, port: p, size: 1, scael: 2}]\n",
     r"term 'a': unknown field 'scael'"),
    ("model: m.onnx\nobservation: [{name: a, port: p, size: 2, scale: [1, 2, 3]}]\n",
     r"term 'a': scale is \[1, 2, 3\]: give a number or a list of 2"),
    ("model: m.onnx\nnum_obs: 3\nobservation: [{name: a, port: p, size: 2}]\n",
     r"num_obs is 3 but the terms make a \(2\) = 2"),
    ("observation: [{name: a, port: p, size: 2}]\n", r"no model"),
    ("model: m.onnx\nobservaton: []\n", r"unknown field 'observaton'"),
])
def test_configuration_errors_name_the_file_and_the_term(
    tmp_path: Path, text: str, message: str,
) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigurationError, match=rf"policy configuration {path}: {message}"):
        load_config(str(path))


def test_unitree_field_names_are_read(tmp_path: Path) -> None:
    path = tmp_path / "g1.yaml"
    path.write_text(
        "policy_path: motion.onnx\ncontrol_decimation: 10\nsimulation_dt: 0.002\n"
        "kps: [100, 150]\nkds: [2, 4]\ndefault_angles: [-0.1, 0.3]\naction_scale: 0.25\n"
        "num_actions: 2\nclip_actions: 5\n"
        "observation: [{name: cmd, port: cmd, default: [0.5, 0, 0]}]\n")
    config = load_config(str(path))
    assert config.model == str(tmp_path / "motion.onnx")
    assert config.control_dt == pytest.approx(0.02)
    assert config.action.offset.tolist() == [-0.1, 0.3] and config.action.scale.tolist() == [
        0.25, 0.25]
    assert config.kps.tolist() == [100.0, 150.0] and config.action.clip == 5.0  # type: ignore[union-attr]


# -- control_dt and trained_delay against how the policy runs ----------------------------

def _timed(tmp_path: Path, fields: str) -> str:
    """The test configuration with ``fields`` (control_dt, trained_delay, ...) added."""
    return write_config(tmp_path, np.full((5, 1), 0.1), CONFIG + fields)


def _policy(config: str, every: int = 1, lane: str = "", **params: Any) -> Any:
    """Configure the Policy at 100 Hz, every ``every``, in ``lane``: its component."""
    trace = run_components([ComponentSpec(
        "policy", Policy, rate=Rate(every=every), lane=lane,
        params={"config": config, **params})], 1, frequency=HZ)
    return trace.components["/policy"]


@pytest.mark.parametrize(("every", "lane", "fields"), [
    (5, "slow", "control_dt: 0.05\ntrained_delay: 0.06\n"),  # LET: (5 + 1) / 100 Hz
    (5, "", "control_dt: 0.05\ntrained_delay: 0.0\n"),  # inline in main: no delay
    (1, "other", "control_dt: 0.01\ntrained_delay: 0\n"),  # a lock-step lane: none
    (4, "slow", "control_decimation: 4\nsimulation_dt: 0.01\ntrained_delay: 0.05\n"),
    # a trainer at a 25 ms physics step models (5 + 1) x 10 ms as 2 steps (rounded)
    (5, "slow", "control_decimation: 2\nsimulation_dt: 0.025\ntrained_delay: 0.05\n"),
])
def test_control_dt_and_trained_delay_that_match_how_it_runs_pass(
    tmp_path: Path, every: int, lane: str, fields: str,
) -> None:
    policy = _policy(_timed(tmp_path, fields), every, lane)
    assert policy.timing.every == every and policy.timing.on_let == (lane != "" and every > 1)


def test_a_control_dt_other_than_its_period_names_the_file_both_values_and_the_fix(
    tmp_path: Path,
) -> None:
    config = _timed(tmp_path, "control_dt: 0.02\n")
    with pytest.raises(ComponentError) as err:
        _policy(config, 5, "slow")  # 5 / 100 Hz = 0.05 s
    text = str(err.value)
    assert f"policy configuration {config}: control_dt is 0.02 s" in text
    assert "on LET in lane 'slow', every 5 at 100 Hz, a period of 0.05 s" in text
    assert "every:=2 or the loop's frequency 250 Hz" in text
    assert "(control_dt: 0.05)" in text and "\n" not in text
    with pytest.raises(ComponentError, match=r"control_dt \(control_decimation 4 x "
                       r"simulation_dt 0.005\) is 0.02 s"):
        _policy(_timed(tmp_path, "control_decimation: 4\nsimulation_dt: 0.005\n"), 1)


@pytest.mark.parametrize(("every", "lane", "delay", "runs"), [
    (5, "slow", 0.05, "its action acts 5 + 1 loop periods after the state it saw: 0.06 s"),
    (5, "", 0.06, "inline in lane 'main', every 5 at 100 Hz, where its action acts with no "
     "delay"),
    (5, "slow", 0.0, "on LET in lane 'slow'"),
    (5, "slow", 0.05, "0.06 s; retrain it for the delay it runs with, or, if training "
     "modelled 0.06 s, say so in the YAML (trained_delay: 0.06); a trainer whose physics "
     "step could not model it finer gives its simulation_dt"),
])
def test_a_trained_delay_other_than_the_one_it_runs_with_is_an_error(
    tmp_path: Path, every: int, lane: str, delay: float, runs: str,
) -> None:
    config = _timed(tmp_path, f"control_dt: 0.05\ntrained_delay: {delay}\n")
    with pytest.raises(ComponentError) as err:
        _policy(config, every, lane)
    text = str(err.value)
    assert f"policy configuration {config}: trained_delay is {delay:g} s" in text
    assert runs in text and "~on_delay_mismatch:=warn runs it anyway" in text
    assert "\n" not in text


def test_on_delay_mismatch_warn_runs_it_with_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture,
) -> None:
    config = _timed(tmp_path, "control_dt: 0.05\ntrained_delay: 0.06\n")
    policy = _policy(config, 5, "", on_delay_mismatch="warn")  # inline: no delay
    assert policy.timing.delay == 0.0
    assert any("trained_delay is 0.06 s" in r.getMessage() for r in caplog.records)
    with pytest.raises(ComponentError, match=r"~on_delay_mismatch is 'never': give error or "
                       "warn"):
        _policy(config, 5, "slow", on_delay_mismatch="never")


def test_a_component_knows_its_lane_and_whether_it_runs_on_let(tmp_path: Path) -> None:
    config = write_config(tmp_path, np.full((5, 1), 0.1))
    assert (_policy(config, 5, "slow").lane_name, _policy(config, 5, "slow").on_let) == (
        "slow", True)
    assert (_policy(config, 5).lane_name, _policy(config, 5).on_let) == ("main", False)
    assert _policy(config, 1, "other").on_let is False  # lock step


# -- JointPd in the driver's joint order ----------------------------------------------

PD_CONFIG = """
model: m.onnx
joints: [a, b, c]
observation: [{name: x, port: position, size: 1}]
action: {port: target, offset: [0.1, 0.2, 0.3]}
kps: [1.0, 2.0, 3.0]
kds: [0.5, 0.5, 0.5]
"""


def _driver(position: list[float], velocity: list[float], target: list[float]) -> Any:
    from rtcf import Component

    class Driver(Component):  # its arrays, and from iteration 1 the policy's target
        def configure(self) -> None:
            self.q = self.add_output("position", np.ndarray)
            self.qd = self.add_output("velocity", np.ndarray)
            self.target = self.add_output("target", np.ndarray)

        def update(self) -> None:
            self.q.write(np.array(position))
            self.qd.write(np.array(velocity))
            if self.iteration:
                self.target.write(np.array(target))

    return Driver


def _pd(tmp_path: Path, **params: Any) -> Any:
    path = tmp_path / "pd.yaml"
    path.write_text(PD_CONFIG)
    # the driver measures [c, x, b, a] (x: a joint the policy does not drive) and takes
    # commands for [b, c, a]
    driver = _driver([3.0, 9.0, 2.0, 1.0], [0.3, 9.0, 0.2, 0.1], [10.0, 20.0, 30.0])
    return run_components([
        ComponentSpec("driver", driver),
        ComponentSpec("pd", JointPd, params={"config": str(path), **params}),
    ], 2)


def test_joint_pd_writes_in_the_drivers_joint_order_by_name(tmp_path: Path) -> None:
    trace = _pd(tmp_path, joints=["c", "x", "b", "a"], command_joints=["b", "c", "a"])
    pd = trace.components["/pd"]
    assert pd.index.tolist() == [2, 0, 3] and pd.order.tolist() == [1, 2, 0]
    effort = [e.tolist() for e in trace.outputs["/effort_command"]]
    # b, c, a: kp (target - q) - kd qd; the default target first (action.offset)
    assert effort[0] == pytest.approx([2.0 * (0.2 - 2.0) - 0.1, 3.0 * (0.3 - 3.0) - 0.15,
                                       1.0 * (0.1 - 1.0) - 0.05])
    assert effort[1] == pytest.approx([2.0 * (20.0 - 2.0) - 0.1, 3.0 * (30.0 - 3.0) - 0.15,
                                       1.0 * (10.0 - 1.0) - 0.05])


def test_joint_pd_maps_its_target_without_allocating(tmp_path: Path) -> None:
    pd = _pd(tmp_path, joints=["c", "x", "b", "a"], command_joints=["b", "c", "a"]
             ).components["/pd"]
    first, second, peak = _traced(pd.update, 2000)
    assert second - first < 256 and peak < 4096  # the effort it writes, freed


@pytest.mark.parametrize(("params", "message"), [
    ({"joints": ["c", "b"]}, r"policy joint 'a' \(.*pd.yaml\) is not among the driver's "
     r"~joints \['c', 'b'\]"),
    ({"joints": ["c", "x", "b", "a"]}, r"driver joint 'x' \(~joints\) is not among the "
     r"policy's joints \['a', 'b', 'c'\] \(.*pd.yaml\): the PD stage has no target for it"),
    ({"joints": ["c", "x", "b", "a"], "command_joints": ["b", "a"]},
     r"policy joint 'c' \(.*\) is not among the driver's ~command_joints \['b', 'a'\]"),
    ({"joints": ["c", "b", "a"], "command_joints": ["b", "c", "a", "d"]},
     r"driver joint 'd' \(~command_joints\) is not among the policy's joints"),
    ({"joints": ["c", "b", "a", "b"]}, r"joint 'b' is in ~joints twice"),
    ({"joints": ["c", "b", "a"], "index": [0, 1, 2]}, r"give ~joints .* or ~index, not both"),
    ({"command_joints": ["a", "b", "c"]}, r"~command_joints needs ~joints"),
    ({"joints": "a, b, c"}, r"~joints is 'a, b, c': give a list of joint names"),
])
def test_joint_pd_names_an_unknown_or_missing_joint(
    tmp_path: Path, params: dict[str, Any], message: str,
) -> None:
    with pytest.raises(ComponentError, match=r"component '/pd': configure\(\) failed: "
                       + message):
        _pd(tmp_path, **params)


def _tasks() -> int:
    return len(os.listdir("/proc/self/task"))


def _traced(call: Any, n: int) -> tuple[int, int, int]:
    """tracemalloc over n calls after a warm one: memory kept after n and after 2 n
    calls, and the peak above the first (what an interpreter makes once when it is traced,
    as 3.10 does, falls in the first n)."""
    call()
    tracemalloc.start()
    try:
        for _ in range(n):
            call()
        first, _ = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        for _ in range(n):
            call()
        second, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return first, second, peak - first


def test_inference_allocates_nothing_and_configure_starts_no_thread(tmp_path: Path) -> None:
    config = write_config(tmp_path, np.full((5, 1), 0.1))
    positions = [np.array([0.1, 0.2])] * 3
    before = _tasks()
    trace = run_components([
        ComponentSpec("feed", _source(positions)),
        ComponentSpec("policy", Policy, params={"config": config}),
    ], 3, frequency=HZ)
    assert _tasks() == before  # one intra-op, one inter-op thread: onnxruntime's own none
    policy = trace.components["/policy"]

    def infer() -> None:  # the observation assembled, the model run: bound arrays only
        policy.observation.assemble()
        policy.model.run()

    first, second, peak = _traced(infer, 2000)
    assert second - first < 256  # nothing kept (2000 calls)
    assert peak < 2048  # transient only: numpy's casting, the binding's call
    # a whole update adds the value it writes (a new array: a reader may keep it), freed
    first, second, peak = _traced(policy.update, 2000)
    assert second - first < 256 and peak < 4096


# -- the cart-pole example --------------------------------------------------------------

EXAMPLE = "rtcf_examples cartpole.launch"


def _onnx_action(observation: np.ndarray) -> float:
    path = resources.files("rtcf_examples").joinpath("models", "cartpole_policy_small.onnx")
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return float(session.run(None, {"obs": observation.reshape(1, -1)})[0][0, 0])


def test_the_action_lands_exactly_every_iterations_after_its_observation() -> None:
    pytest.importorskip("mujoco")
    trace = run_launch(EXAMPLE, 200)
    position = trace.outputs["/cartpole/position"]
    observation = trace.outputs["/cartpole/observation"]
    target = trace.outputs["/cartpole/target"]
    # release 0 has no state yet (the hardware writes its first at 0): release 20's
    # action is the first, and lands at 40
    assert all(t is None for t in target[:40])
    for i in range(40, 200):
        r = (i // 20 - 1) * 20  # the release whose action the PD stage sees at i
        seen = observation[r]  # (traced as written: the lane's own slot, no reader)
        # it saw the state iteration r - 1 left
        assert seen[:2].tolist() == position[r - 1].astype(np.float32).tolist(), i
        assert float(target[i][0]) == pytest.approx(0.5 * _onnx_action(seen), rel=1e-6), i
        if i % 20:
            assert target[i] is target[i - 1]  # nothing new between windows


def _pole_rms(trace: Any) -> float:
    angles = np.array([p[1] for p in trace.outputs["/cartpole/position"]])
    return float(np.sqrt(np.mean(angles ** 2)))


def test_it_balances_through_the_push_and_without_its_trained_delay_does_worse() -> None:
    pytest.importorskip("mujoco")
    let = run_launch(EXAMPLE, 4000)
    inline = run_launch(EXAMPLE, 4000, args={"policy_lane": "main",
                                             "on_delay_mismatch": "warn"})
    angles = np.array([p[1] for p in let.outputs["/cartpole/position"]])
    assert abs(angles[2400]) < 0.01 and abs(angles[-1]) < 0.05  # before the push; after
    assert np.max(np.abs(angles[2500:])) > 0.1  # the push did push
    assert _pole_rms(inline) > 2.0 * _pole_rms(let)


@pytest.mark.parametrize(("behaviour", "held"), [("hold", True), ("brake", False)])
def test_a_policy_gone_quiet_leaves_the_pd_stage_in_its_safe_behaviour(
    behaviour: str, held: bool,
) -> None:
    pytest.importorskip("mujoco")
    # the last release that writes is 980 (before 1.0 s); its action lands at 1000 and
    # arrives there; past 1000 + 50 ms: iteration 1051
    trace = run_launch(EXAMPLE, 1400, args={
        "silent_after_s": "1.0", "safe_behaviour": behaviour, "push_at_s": "inf"})
    pd = trace.components["/cartpole/pd"]
    assert pd.changes == [(1051, "safe")]
    (event,) = trace.result.deadline_events
    assert (event.iteration, event.last_arrival) == (1051, 1.0)
    x = np.array([p[0] for p in trace.outputs["/cartpole/position"]])
    if held:  # the cart held where it was at 1051
        assert abs(x[-1] - x[1051]) < 0.05
    effort = trace.outputs["/cartpole/effort_command"]
    assert isinstance(pd, JointPd) and effort[-1] is not None


@pytest.mark.parametrize("lane", ["policy", "main"])
def test_both_launch_formats_give_the_same_run(lane: str) -> None:
    pytest.importorskip("mujoco")
    args = {"policy_lane": lane, "silent_after_s": "0.3",  # the deadline passes at 351
            "on_delay_mismatch": "warn"}  # inline: not the delay it was trained with
    a = run_launch(EXAMPLE, 400, args=args)
    b = run_launch(EXAMPLE + ".xml", 400, args=args)
    assert set(a.outputs) == set(b.outputs) and "/cartpole/target" in a.outputs
    for topic in a.outputs:
        for x, y in zip(a.outputs[topic], b.outputs[topic], strict=True):
            assert (x is None and y is None) or np.array_equal(x, y), topic
    assert a.components["/cartpole/pd"].changes == b.components["/cartpole/pd"].changes != []
    assert a.ran["/cartpole/policy"] == b.ran["/cartpole/policy"] == list(range(0, 400, 20))
