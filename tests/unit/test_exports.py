"""Pin the public API of the rtcf package."""

from __future__ import annotations

import types

import rtcf
from rtcf._core import (
    _action_protocol,
    _actions,
    _cdr,
    _chaining,
    _clock,
    _command_limits,
    _component,
    _errors,
    _graph,
    _hardware,
    _log,
    _params,
    _ports,
    _rates,
    _robot_description,
    _runner,
    _settings,
)

EXPECTED = {
    "ActionEvent": _action_protocol.ActionEvent,
    "ActionRequest": _action_protocol.ActionRequest,
    "GoalStatus": _action_protocol.GoalStatus,
    "ActionServer": _actions.ActionServer,
    "Clock": _clock.Clock,
    "MonotonicClock": _clock.MonotonicClock,
    "SimClock": _clock.SimClock,
    "Component": _component.Component,
    "ChainableComponent": _chaining.ChainableComponent,
    "JointLimits": _command_limits.JointLimits,
    "ComponentError": _errors.ComponentError,
    "ConfigurationError": _errors.ConfigurationError,
    "GraphError": _errors.GraphError,
    "LaunchError": _errors.LaunchError,
    "RtcfError": _errors.RtcfError,
    "Graph": _graph.Graph,
    "SystemInterface": _hardware.SystemInterface,
    "ActuatorInterface": _hardware.ActuatorInterface,
    "SensorInterface": _hardware.SensorInterface,
    "CallbackReturn": _hardware.CallbackReturn,
    "ReturnType": _hardware.ReturnType,
    "HardwareInfo": _robot_description.HardwareInfo,
    "LogLevel": _log.LogLevel,
    "ParameterStore": _params.ParameterStore,
    "FlowStatus": _ports.FlowStatus,
    "InputPort": _ports.InputPort,
    "OutputPort": _ports.OutputPort,
    "Rate": _rates.Rate,
    "ComponentSpec": _runner.ComponentSpec,
    "Runner": _runner.Runner,
    "RunResult": _runner.RunResult,
    "RunnerSettings": _settings.RunnerSettings,
    "Serialized": _cdr.Serialized,
}


def _public_names() -> set[str]:
    return {
        name
        for name, value in vars(rtcf).items()
        if not name.startswith("_") and not isinstance(value, types.ModuleType)
    }


def test_public_names_are_exactly_these() -> None:
    assert _public_names() == set(EXPECTED)


def test_public_names_are_the_implementations() -> None:
    for name, obj in EXPECTED.items():
        assert getattr(rtcf, name) is obj, name


def test_all_if_defined_matches() -> None:
    all_names = getattr(rtcf, "__all__", None)
    if all_names is not None:
        assert sorted(all_names) == sorted(EXPECTED)


def test_errors_share_a_base() -> None:
    for name in ("ComponentError", "ConfigurationError", "GraphError", "LaunchError"):
        assert issubclass(getattr(rtcf, name), rtcf.RtcfError)
    assert issubclass(rtcf.RtcfError, Exception)


def test_version() -> None:
    assert rtcf.__version__ == "0.1.0"


def test_error_str_has_file_and_line() -> None:
    assert str(rtcf.LaunchError("bad", file="a.launch", line=3)) == "a.launch:3: bad"
    assert str(rtcf.LaunchError("bad", file="a.launch")) == "a.launch: bad"
    assert str(rtcf.RtcfError("bad")) == "bad"
    err = rtcf.ComponentError("x", component="/c")
    assert (err.component, err.message, err.file, err.line) == ("/c", "x", None, None)


def test_testing_module_exports_exactly_these() -> None:
    import rtcf.testing

    assert sorted(rtcf.testing.__all__) == [
        "ActionTrace", "Cancel", "Goal", "GoalRecord", "InputValues", "SILENCE", "SimClock",
        "Trace",
        "run_components", "run_launch"
    ]
    public = {n for n in vars(rtcf.testing) if not n.startswith("_")}
    assert set(rtcf.testing.__all__) <= public


def test_recording_module_exports_exactly_these() -> None:
    import rtcf.recording
    from rtcf._runtime import _recording_reader

    assert sorted(rtcf.recording.__all__) == ["Message", "Recording", "Series", "read"]
    for name in rtcf.recording.__all__:
        assert getattr(rtcf.recording, name) is getattr(_recording_reader, name), name
