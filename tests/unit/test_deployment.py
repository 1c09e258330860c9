"""From a hand-built launch description to runners and component specs."""

from __future__ import annotations

from typing import Any

import pytest

from rtcf import LaunchError, ParameterStore, Runner, SimClock
from rtcf._core._errors import Location
from rtcf._launch._deployment import Deployment, is_launcher, is_runner, plan
from rtcf._launch._description import LaunchDescription, NodeDescription

FILE = "test.launch"


def node(
    name: str,
    executable: str,
    line: int,
    *,
    namespace: str = "/",
    args: str = "",
    package: str = "rtcf",
    remaps: list[tuple[str, str]] | None = None,
    dialect: str = "ros1",
) -> NodeDescription:
    return NodeDescription(
        package=package,
        executable=executable,
        name=name,
        namespace=namespace,
        location=Location(FILE, line),
        dialect=dialect,  # type: ignore[arg-type]
        args=args,
        remaps=remaps or [],
    )


def runner(name: str = "rt_runner", line: int = 2, **kw: Any) -> NodeDescription:
    return node(name, "rt_runner", line, **kw)


def launcher(name: str, args: str = "", line: int = 5, **kw: Any) -> NodeDescription:
    return node(name, "rt_launcher", line, args=args, **kw)


def describe(*nodes: NodeDescription, params: dict[str, Any] | None = None) -> LaunchDescription:
    return LaunchDescription(FILE, list(nodes), ParameterStore(params or {}))


def one_spec(launcher_node: NodeDescription, params: dict[str, Any] | None = None):
    all_params = {"/rt_runner/frequency": 10, **(params or {})}
    d = plan(describe(runner(), launcher_node, params=all_params))
    (spec,) = d.runner.components
    return spec


def launch_error(description: LaunchDescription) -> LaunchError:
    with pytest.raises(LaunchError) as info:
        plan(description)
    return info.value


# -- runners -------------------------------------------------------------------------


def test_runner_settings_from_private_params() -> None:
    d = plan(describe(runner(namespace="/robot"), params={
        "/robot/rt_runner": {"mode": "wait_for_components", "num_components_expected": 2,
                             "frequency": "250", "cpu_affinity_mask": "0x3"},
        "/rt_runner/frequency": 5,  # another node's parameters
    }))
    r = d.runner
    assert r.name == "/robot/rt_runner"
    assert r.location == Location(FILE, 2)
    assert (r.settings.mode, r.settings.num_components_expected) == ("wait_for_components", 2)
    assert (r.settings.frequency, r.settings.cpu_affinity_mask) == (250.0, 3)
    assert r.components == []
    assert d.warnings == []
    assert d.source == FILE


def test_runner_setting_error_has_file_and_line() -> None:
    err = launch_error(describe(runner(line=7), params={"/rt_runner/frequency": "fast"}))
    assert (err.file, err.line) == (FILE, 7)
    assert str(err) == (
        "test.launch:7: rt_runner '/rt_runner': parameter 'frequency' has value 'fast', "
        "which is not a number"
    )


def test_runner_validation_error_has_file_and_line() -> None:
    err = launch_error(describe(runner(line=4), params={"/rt_runner/mode": "wait_for_components"}))
    assert str(err).startswith("test.launch:4: rt_runner '/rt_runner': mode 'wait_for_components'")


def test_runner_notes_become_warnings_with_location() -> None:
    d = plan(describe(runner(line=3), params={"/rt_runner/typo": 1}))
    assert d.warnings[0].startswith(
        "test.launch:3: rt_runner '/rt_runner': unknown parameter 'typo'"
    )
    assert d.warnings[1:] == [
        "test.launch:3: rt_runner '/rt_runner': no mode given, using 'no_wait'",
        "test.launch:3: rt_runner '/rt_runner': no frequency given, using 1.0 Hz",
    ]


def test_description_warnings_are_kept() -> None:
    desc = describe(runner(), params={"/rt_runner": {"mode": "no_wait", "frequency": 1}})
    desc.warnings.append("from the parser")
    assert plan(desc).warnings == ["from the parser"]


def test_ros2_exec_runner_is_a_runner() -> None:
    n = runner(dialect="ros2")
    assert is_runner(n) and not is_launcher(n)
    assert not is_runner(node("rt_runner", "rt_runner", 1, package="other"))


# -- launchers -----------------------------------------------------------------------


def test_launcher_args_module_and_class() -> None:
    spec = one_spec(launcher("ctrl", "rtcf_examples PaperExample", namespace="/ns",
                             remaps=[("in_port", "/x"), ("out_port", "y")], line=9))
    assert (spec.name, spec.namespace, spec.full_name) == ("ctrl", "/ns", "/ns/ctrl")
    assert (spec.module, spec.class_name, spec.cls) == ("rtcf_examples", "PaperExample", None)
    assert spec.remaps == [("in_port", "/x"), ("out_port", "y")]
    assert spec.is_first is False
    assert spec.topics_ignore_for_graph == ""
    assert spec.location == Location(FILE, 9)
    assert spec.type_name == "rtcf_examples.PaperExample"


@pytest.mark.parametrize(
    "args",
    ["rtcf_examples PaperExample -f", "-f rtcf_examples PaperExample",
     "rtcf_examples PaperExample --is_first", "rtcf_examples PaperExample -s -f"],
)
def test_is_first_flags(args: str) -> None:
    spec = one_spec(launcher("c", args))
    assert spec.is_first is True
    assert (spec.module, spec.class_name) == ("rtcf_examples", "PaperExample")


def test_is_sync_flag_alone_is_accepted_and_not_is_first() -> None:
    assert one_spec(launcher("c", "rtcf_examples PaperExample --is_sync")).is_first is False


def test_dotted_class_without_module() -> None:
    spec = one_spec(launcher("c", "rtcf_examples._components.Sine"))
    assert (spec.module, spec.class_name) == ("rtcf_examples._components", "Sine")


def test_rt_package_and_rt_type_params() -> None:
    spec = one_spec(launcher("c"), {"/c/rt_package": "rtcf_examples", "/c/rt_type": "Sine"})
    assert (spec.module, spec.class_name) == ("rtcf_examples", "Sine")
    spec = one_spec(launcher("c", "Sine"), {"/c/rt_package": "rtcf_examples"})
    assert (spec.module, spec.class_name) == ("rtcf_examples", "Sine")


def _launcher_error(n: NodeDescription, params: dict[str, Any] | None = None) -> str:
    all_params = {"/rt_runner/frequency": 10, **(params or {})}
    err = launch_error(describe(runner(), n, params=all_params))
    assert (err.file, err.line) == (FILE, n.location.line)
    return str(err)


@pytest.mark.parametrize(
    ("args", "params", "fragment"),
    [
        ("rtcf_examples Sine", {"/c/rt_package": "other"},
         "rt_package is given both in args and as parameter ~rt_package; keep one"),
        ("rtcf_examples Sine", {"/c/rt_type": "Other"},
         "rt_type is given both in args and as parameter ~rt_type; keep one"),
        ("", {"/c/rt_package": 3, "/c/rt_type": "Sine"}, "parameter ~rt_package must be a string"),
        ("rtcf_examples Sine -x", {}, "unknown option '-x' in args; allowed: -f/--is_first"),
        ("rtcf_examples Sine --first", {}, "unknown option '--first'"),
        ("a b c", {}, "has too many words"),
        ("", {}, "no component class given"),
        ("Sine", {}, "no module given for class 'Sine'"),
        ("rtcf_examples 'Sine", {}, "cannot be split"),
        ("rtcf_examples Sine -f", {"/c/is_first": False},
         "conflicting is_first: args has -f but parameter ~is_first is false"),
        ("rtcf_examples Sine", {"/c/is_first": "maybe"},
         "parameter '~is_first' is 'maybe'; use true or false"),
        ("rtcf_examples Sine", {"/c/topics_ignore_for_graph": 5},
         "parameter ~topics_ignore_for_graph is 5; it must be a regex string"),
    ],
)
def test_launcher_errors(args: str, params: dict[str, Any], fragment: str) -> None:
    msg = _launcher_error(launcher("c", args, line=11), params)
    assert msg.startswith("test.launch:11: rt_launcher '/c': ")
    assert fragment in msg


@pytest.mark.parametrize(
    ("value", "expected"), [(True, True), ("true", True), ("True", True), (False, False),
                            ("false", False), (1, True), (0, False)],
)
def test_is_first_param(value: Any, expected: bool) -> None:
    spec = one_spec(launcher("c", "rtcf_examples Sine"), {"/c/is_first": value})
    assert spec.is_first is expected


def test_is_first_flag_and_true_param_agree() -> None:
    assert one_spec(launcher("c", "rtcf_examples Sine -f"), {"/c/is_first": True}).is_first


def test_topics_ignore_for_graph_param() -> None:
    spec = one_spec(launcher("c", "rtcf_examples Sine", namespace="/ns"),
                    {"/ns/c/topics_ignore_for_graph": "/fb/.*"})
    assert spec.topics_ignore_for_graph == "/fb/.*"
    assert spec.is_first is False


def test_components_keep_file_order() -> None:
    d = plan(describe(runner(), launcher("b", "m B", line=5), launcher("a", "m A", line=6),
                      params={"/rt_runner/frequency": 1}))
    assert [s.name for s in d.runner.components] == ["b", "a"]


# -- runners and launchers together -------------------------------------------------------


def test_launcher_without_runner_is_an_error_at_the_launcher() -> None:
    err = launch_error(describe(launcher("c", "rtcf_examples Sine", line=8)))
    assert (err.file, err.line) == (FILE, 8)
    assert "defines no runner" in str(err)
    assert 'pkg="rtcf" type="rt_runner"' in str(err)


def test_deployment_runner_property_needs_exactly_one() -> None:
    with pytest.raises(LaunchError, match="defines 0 runners") as info:
        _ = plan(describe()).runner
    assert info.value.file == FILE
    two = plan(describe(runner("r1", 2), runner("r2", 3)))
    with pytest.raises(LaunchError, match=r"defines 2 runners \(/r1, /r2\)"):
        _ = two.runner


def test_multiple_runners_need_the_runner_param() -> None:
    msg = _launcher_error_multi(launcher("c", "rtcf_examples Sine", line=12), {})
    assert "the file has 2 runners" in msg and '<param name="runner"' in msg


def _multi(*launchers: NodeDescription, params: dict[str, Any]) -> Deployment:
    return plan(describe(runner("r1", 2), runner("r2", 3, namespace="/ns"), *launchers,
                         params={"/r1/frequency": 1, "/ns/r2/frequency": 2, **params}))


def _launcher_error_multi(n: NodeDescription, params: dict[str, Any]) -> str:
    with pytest.raises(LaunchError) as info:
        _multi(n, params=params)
    assert (info.value.file, info.value.line) == (FILE, n.location.line)
    return str(info.value)


def test_runner_param_picks_the_runner() -> None:
    d = _multi(
        launcher("a", "m A", line=5),
        launcher("b", "m B", line=6, namespace="/ns"),
        launcher("c", "m C", line=7),
        params={"/a/runner": "/r1", "/ns/b/runner": "r2", "/c/runner": "ns/r2"},
    )
    by_runner = {r.name: [s.name for s in r.components] for r in d.runners}
    assert by_runner == {"/r1": ["a"], "/ns/r2": ["b", "c"]}


def test_runner_param_naming_no_runner() -> None:
    msg = _launcher_error_multi(launcher("c", "m C", line=9), {"/c/runner": "r3"})
    assert "parameter ~runner names 'r3', but the runners are /r1, /ns/r2" in msg


def test_non_rtcf_nodes_are_kept_for_rtcf_launch_to_start() -> None:
    talker = node("talker", "talker.py", 4, package="rospy_tutorials")
    d = plan(describe(runner(), talker, params={"/rt_runner": {"mode": "no_wait", "frequency": 1}}))
    assert d.other_nodes == [talker]
    assert d.warnings == []  # rtcf launch starts it (rtcf._cli._other_nodes)
    # a node of the rtcf package that is neither is another node too
    d = plan(describe(node("tool", "other_tool", 6)))
    assert [n.name for n in d.other_nodes] == ["tool"]


def test_planned_specs_load_with_the_description_parameters() -> None:
    d = plan(describe(
        runner(),
        launcher("sine", "rtcf_examples Sine", namespace="/ns", remaps=[("out", "/signal")]),
        params={"/rt_runner/frequency": 4, "/rt_runner/mode": "no_wait",
                "/ns/sine/amplitude": 3.0, "/ns/sine/is_first": True},
    ))
    target = d.runner
    r = Runner(target.settings, clock=SimClock(), parameters=d.parameters, name=target.name,
               log_sink=lambda rec: None)
    (spec,) = target.components
    comp = r.load(spec)
    assert comp.amplitude == 3.0  # type: ignore[attr-defined]
    assert comp.outputs["out"].topic == "/signal"
    assert r.graph.nodes[0].is_first is True
    r.run(2)
    assert comp.outputs["out"]._slot.value == pytest.approx(3.0)  # sin(2 pi 0.25)
