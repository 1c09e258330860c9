"""rtcf's command line (rtcf._cli._main): launch arguments after the options."""

import pytest

from rtcf._cli._main import parse_arguments


def test_launch_arguments_come_before_or_after_the_options_as_roslaunch_takes_them() -> None:
    before = parse_arguments(
        ["launch", "rtcf_examples", "arm.launch", "ros_interfaces:=true", "--middleware", "ros1"])
    after = parse_arguments(
        ["launch", "rtcf_examples", "arm.launch", "--middleware", "ros1", "ros_interfaces:=true",
         "--duration", "2", "stiffness:=200"])
    assert before.target == ["rtcf_examples", "arm.launch", "ros_interfaces:=true"]
    assert after.target == ["rtcf_examples", "arm.launch", "ros_interfaces:=true",
                            "stiffness:=200"]
    assert (before.middleware, after.middleware, after.duration) == ("ros1", "ros1", 2.0)
    assert parse_arguments(["check", "f.launch", "--debug", "x:=1"]).target == [
        "f.launch", "x:=1"]


@pytest.mark.parametrize("extra", [["--no-such-option"], ["stray"], ["--bad:=1"]])
def test_what_is_not_a_launch_argument_is_still_refused_by_argparse(
    extra: list[str], capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as exit_:
        parse_arguments(["launch", "f.launch", "--duration", "1", *extra])
    assert exit_.value.code == 2
    assert "unrecognized arguments" in capsys.readouterr().err
