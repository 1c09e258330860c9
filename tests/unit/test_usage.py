"""rt_runner --help and rt_launcher --help (rtcf._runtime._usage): what they list."""

from __future__ import annotations

import dataclasses

import pytest

from rtcf._core._settings import _FIELDS, RunnerSettings, parameter_help
from rtcf._runtime._usage import asks_for_help, launcher_usage, runner_usage


def test_the_runners_help_lists_every_setting_with_its_default() -> None:
    rows = {_FIELDS.get(name, name): (default, meaning)  # (dotted names: their fields)
            for name, default, meaning in parameter_help()}
    fields = {f.name for f in dataclasses.fields(RunnerSettings) if f.name != "notes"}
    assert set(rows) == fields  # a new setting without a line in the help fails here
    assert rows["frequency"][0] == "1.0" and rows["priority"][0] == "80"
    assert rows["iteration_info"][0] == "true" and rows["lanes"][0] == ""
    assert all(meaning for _, meaning in rows.values())


@pytest.mark.parametrize("middleware", ["ros1", "ros2"])
def test_the_usages_fit_a_terminal_and_name_their_docs(middleware: str) -> None:
    for text in (runner_usage(middleware), launcher_usage(middleware)):
        assert max(map(len, text.splitlines())) <= 92
        assert f"docs/{middleware}.md" in text


def test_help_is_asked_only_before_the_middlewares_own_arguments() -> None:
    assert asks_for_help(["rt_runner", "--help"])
    assert asks_for_help(["rt_launcher", "rtcf_examples", "Mimo", "-h"])
    assert not asks_for_help(["rt_runner"])
    assert not asks_for_help(["rt_runner", "--ros-args", "-p", "a:=1", "--help"])
    assert not asks_for_help(["rt_runner", "_frequency:=10", "help"])
