"""Tunable parameters: declaration, validation, update records, applied between iterations."""

from __future__ import annotations

from typing import Any

import pytest

from rtcf import (
    Component,
    ComponentError,
    ComponentSpec,
    ConfigurationError,
    Runner,
    RunnerSettings,
    SimClock,
)
from rtcf._core._rings import Ring
from rtcf._core._tunables import (
    LOG_LEVEL,
    PARAMETER,
    UPDATE_RECORD_SIZE,
    TunableSpec,
    UpdateReader,
    decode_update,
    encode_update,
)


class Gain(Component):
    """out = gain * iteration; also records what each update saw."""

    def configure(self) -> None:
        self.out = self.add_output("out", float)
        self.gain = self.params.declare(
            "gain", 2.0, description="output per input", min=0.0, max=10.0
        )
        self.mode = self.params.declare("mode", "fast", choices=["fast", "slow"])
        self.seen: list[tuple[int, float, int]] = []

    def update(self) -> None:
        self.seen.append((self.iteration, self.gain.value, self.gain.version))
        self.out.write(self.gain.value * self.iteration)


class Follower(Component):
    """Reads the same tunable object as Gain through the port: records what it saw."""

    def configure(self) -> None:
        self.inp = self.add_input("out", float)
        self.seen: list[float | None] = []

    def update(self) -> None:
        self.seen.append(self.inp.read())


def runner(**params: Any) -> Runner:
    r = Runner(RunnerSettings(frequency=100.0), clock=SimClock())
    r.load(ComponentSpec("gain", Gain, params=params))
    r.load(ComponentSpec("follower", Follower))
    return r


def test_declared_default_and_launch_file_value() -> None:
    r = runner()
    gain = r.components["/gain"]
    assert isinstance(gain, Gain)
    assert gain.gain.value == 2.0 and gain.gain.spec.type == "float"
    r2 = runner(gain=4)  # a launch file's int for a float parameter
    g2 = r2.components["/gain"]
    assert isinstance(g2, Gain)
    assert g2.gain.value == 4.0 and isinstance(g2.gain.value, float)


def test_launch_file_value_out_of_range_is_refused_naming_it() -> None:
    with pytest.raises(ComponentError, match=r"'/gain'.*'gain'.*12.0 is above its maximum 10.0"):
        runner(gain=12.0)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (11.0, "above its maximum 10.0"),
        (-1, "below its minimum 0.0"),
        ("x", "is a float; 'x' \\(str\\) is not"),
        (True, "is a float; True \\(bool\\) is not"),
    ],
)
def test_set_parameter_validates(value: Any, message: str) -> None:
    r = runner()
    with pytest.raises(ConfigurationError, match=message):
        r.set_parameter("/gain", "gain", value)
    gain = r.components["/gain"]
    assert isinstance(gain, Gain)
    assert gain.gain.value == 2.0 and gain.gain.version == 0  # nothing changed


def test_choices_and_unknown_names() -> None:
    r = runner()
    with pytest.raises(ConfigurationError, match="'medium' is not one of 'fast', 'slow'"):
        r.set_parameter("/gain", "mode", "medium")
    assert r.set_parameter("/gain", "mode", "slow") == "slow"
    with pytest.raises(ConfigurationError, match=r"no tunable parameter 'gian' .*gain, mode"):
        r.set_parameter("/gain", "gian", 1.0)
    with pytest.raises(ComponentError, match="'/nope' is not loaded"):
        r.set_parameter("/nope", "gain", 1.0)


class BadDeclarations(Component):
    def configure(self) -> None:
        which = self.params.get("~which")
        if which == "type":
            self.params.declare("x", [1, 2])
        elif which == "name":
            self.params.declare("a/b", 1)
        elif which == "twice":
            self.params.declare("x", 1)
            self.params.declare("x", 2)
        elif which == "range":
            self.params.declare("x", 1, min=5, max=2)
        elif which == "default":
            self.params.declare("x", 20, max=10)


@pytest.mark.parametrize(
    ("which", "message"),
    [
        ("type", "default \\[1, 2\\] is a list; a tunable parameter is a bool, int, float or str"),
        ("name", "a tunable parameter's name is a letter"),
        ("twice", "'x' is declared twice"),
        ("range", "min 5 is above max 2"),
        ("default", "20 is above its maximum 10"),
    ],
)
def test_bad_declarations_fail_configure_naming_component(which: str, message: str) -> None:
    r = Runner(RunnerSettings(), clock=SimClock())
    with pytest.raises(ComponentError, match="'/bad'.*" + message):
        r.load(ComponentSpec("bad", BadDeclarations, params={"which": which}))


def test_declare_after_configure_is_an_error() -> None:
    r = runner()
    with pytest.raises(ConfigurationError, match="after configure"):
        r.components["/gain"].params.declare("late", 1)


@pytest.mark.parametrize("value", [True, False, -7, 2**62, 3.25, -0.0, "", "héllo"])
def test_update_records_round_trip(value: Any) -> None:
    record = encode_update(PARAMETER, "/ns/comp", "p", value)
    padded = record + b"\x00" * (UPDATE_RECORD_SIZE - len(record))  # as a ring slot holds it
    kind, comp, name, back = decode_update(padded)
    assert (kind, comp, name) == (PARAMETER, "/ns/comp", "p")
    assert back == value and type(back) is type(value)


def test_long_text_is_refused_before_it_reaches_the_ring() -> None:
    spec = TunableSpec("/c", "text", "str", "")
    with pytest.raises(ConfigurationError, match="longer than an update record holds"):
        spec.validate("x" * UPDATE_RECORD_SIZE)
    assert spec.validate("x" * 900) == "x" * 900


def test_spec_round_trips_through_a_dict() -> None:
    spec = TunableSpec("/c", "mode", "str", "a", "which", choices=("a", "b"))
    assert TunableSpec.from_dict(spec.to_dict()) == spec


def test_updates_apply_between_iterations_never_during_one() -> None:
    """An update pushed during iteration 4 is seen by every update from iteration 5 on."""
    r = runner()
    ring = Ring.create(bytearray(Ring.nbytes(8, UPDATE_RECORD_SIZE)), 8, UPDATE_RECORD_SIZE)
    reader = UpdateReader(ring, r.apply_update)
    gain = r.components["/gain"]
    follower = r.components["/follower"]
    assert isinstance(gain, Gain) and isinstance(follower, Follower)

    def on_iteration() -> None:
        if r.state.iteration == 4:
            ring.push(encode_update(PARAMETER, "/gain", "gain", 5.0))
            ring.push(encode_update(LOG_LEVEL, "/gain", "", 40))

    r.run(8, on_iteration=on_iteration, feeders=[reader])
    assert [(i, g) for i, g, _ in gain.seen] == [(i, 2.0 if i <= 4 else 5.0) for i in range(8)]
    assert [v for _, _, v in gain.seen] == [0] * 5 + [1] * 3
    assert follower.seen == [(2.0 if i <= 4 else 5.0) * i for i in range(8)]
    assert gain.log.level == 40 and reader.applied == 2


def test_update_for_an_unloaded_component_is_ignored() -> None:
    r = runner()
    r.apply_update(PARAMETER, "/gone", "gain", 1.0)  # sent before an unload: no error
    r.apply_update(PARAMETER, "/gain", "unknown", 1.0)
    gain = r.components["/gain"]
    assert isinstance(gain, Gain)
    assert gain.gain.value == 2.0


def test_describe_component_lists_tunables_and_parameters() -> None:
    r = Runner(RunnerSettings(), clock=SimClock())
    r.load(ComponentSpec("gain", Gain, namespace="/ns", params={"gain": 3.0, "other": [1, 2]}))
    info = r.describe_component("/ns/gain")
    assert info["type"].endswith("Gain")
    assert info["outputs"] == [{"name": "out", "topic": "/ns/out", "type": "builtins.float"}]
    assert info["parameters"] == {"gain": 3.0, "other": [1, 2]}
    tunables = {t["name"]: t for t in info["tunables"]}
    assert tunables["gain"]["value"] == 3.0 and tunables["gain"]["max"] == 10.0
    assert tunables["mode"]["choices"] == ["fast", "slow"]
