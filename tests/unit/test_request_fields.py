"""The fields of requests to a runner, type-checked (rtcf._runtime._request_fields)."""

from __future__ import annotations

import pytest

from rtcf._runtime._request_fields import RequestRefused, check_request

GOOD = {"module": "rtcf_examples", "class": "Mimo", "name": "sum1", "namespace": "/arm",
        "remaps": ["in1:=/x", ""], "is_first": False, "autostart": False,
        "topics_ignore_for_graph": "/ros/.*",
        "launcher": "/arm/sum1", "param.gain": 2.0, "param.names": ["a", "b"]}


def test_a_well_formed_load_passes_as_it_is() -> None:
    assert check_request("load_component", GOOD) == GOOD


@pytest.mark.parametrize("field, value, said", [
    ("remaps", 7, "field 'remaps' got 7 (int); it wants a list of 'from:=to' strings"),
    ("remaps", ["a=b"], "('a=b' is not one)"),
    ("is_first", "yes", "field 'is_first' got 'yes' (str); it wants true or false"),
    ("autostart", "no", "field 'autostart' got 'no' (str); it wants true or false"),
    ("name", "x" * 5000, "of at most 255 characters"),
    ("name", "no spaces", "field 'name' got 'no spaces' (str); it wants a name of letters"),
    ("module", "os; rm -rf /", "it wants a Python module name"),
    ("module", 3.5, "field 'module' got 3.5 (float); it wants a string"),
    ("class", "", "missing field(s) class"),
    ("topics_ignore_for_graph", "(", "it wants a regular expression"),
    ("log_level", True, "it wants an integer"),
    ("param.gain", {"kp": 1}, "it wants a bool, int, float or string, or a list of them"),
    ("lane", "left", "unknown field 'lane'; it takes autostart, class, is_first"),
])
def test_a_load_field_that_is_not_what_it_must_be_is_refused_by_name(field, value, said) -> None:
    with pytest.raises(RequestRefused) as exc:
        check_request("load_component", {**GOOD, field: value})
    text = str(exc.value)
    assert text.startswith("load_component: ") and said in text, text
    assert "\n" not in text and len(text) < 300  # one line, whatever came in


def test_the_other_services_check_their_own_fields() -> None:
    assert check_request("unload_component", {"name": "/arm/sum1"})
    with pytest.raises(RequestRefused, match="unload_component: missing field"):
        check_request("unload_component", {})
    with pytest.raises(RequestRefused, match=r"unknown field 'param\.gain'"):
        check_request("unload_component", {"name": "a", "param.gain": 1.0})
    assert check_request("tune_component", {"name": "a", "param.gain": 1.5, "log_level": 20})
    with pytest.raises(RequestRefused, match="field 'log_level' got '20' \\(str\\)"):
        check_request("tune_component", {"name": "a", "log_level": "20"})
    assert check_request("lifecycle_component", {"name": "a", "transition": "deactivate"})
    with pytest.raises(RequestRefused, match="a transition's label or id"):
        check_request("lifecycle_component", {"name": "a", "transition": [3]})
