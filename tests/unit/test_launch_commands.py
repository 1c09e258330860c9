"""``$(command ...)``, ``$(find-exec ...)`` and ROS 1's ``<param command= binfile=>``:
real programs, run while the launch file is read."""

from __future__ import annotations

import os
import shutil
import sys
import textwrap
from pathlib import Path

import pytest

from rtcf._core._errors import LaunchError
from rtcf._launch import _commands
from rtcf._launch._description import LaunchDescription
from rtcf._launch._substitutions import SubstitutionError, split_words
from rtcf._launch._xml import parse_launch_file

SH = shutil.which("sh")


def load(tmp_path: Path, text: str, args: dict[str, str] | None = None) -> LaunchDescription:
    path = tmp_path / "main.launch"
    path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
    return parse_launch_file(path, args)


def error_of(tmp_path: Path, text: str) -> LaunchError:
    with pytest.raises(LaunchError) as info:
        load(tmp_path, text)
    return info.value


def value_of(tmp_path: Path, attribute: str, **args: str) -> object:
    """The value of a ROS 2 node's parameter given by ``attribute``'s value."""
    description = load(
        tmp_path,
        f"""
        <launch>
          <arg name="who" default="wor ld"/>
          <node pkg="p" exec="e" name="n">
            <param name="v" value="{attribute}" type="str"/>
          </node>
        </launch>
        """,
        args,
    )
    return description.parameters.get("/n/v")


# --------------------------------------------------------------------------- $(command)


def test_command_gives_the_programs_stdout(tmp_path: Path) -> None:
    assert value_of(tmp_path, "$(command 'echo hello')") == "hello\n"
    # inner substitutions first, then shlex: the arg's space splits it, unless quoted
    assert value_of(tmp_path, "$(command &quot;printf '[%s]' $(var who)&quot;)") == "[wor][ld]"
    assert value_of(tmp_path, "$(command &quot;printf '[%s]' '$(var who)'&quot;)") == "[wor ld]"


def test_a_failing_command_is_one_line_naming_file_line_command_and_stderr(
    tmp_path: Path,
) -> None:
    error = error_of(
        tmp_path,
        """
        <launch>
          <node pkg="p" exec="e" name="n">
            <param name="robot_description"
              value="$(command 'sh -c &quot;echo first>&amp;2;echo second>&amp;2;exit 3&quot;')"/>
          </node>
        </launch>
        """,
    )
    text = str(error)
    assert "\n" not in text
    assert text.startswith(f"{tmp_path / 'main.launch'}:3: ")
    assert "$(command 'sh -c \"echo first>&2;echo second>&2;exit 3\"') failed" in text
    assert text.endswith("exited with code 3; stderr: first | second")


def test_a_missing_program_is_named(tmp_path: Path) -> None:
    error = error_of(
        tmp_path,
        '<launch>\n<node pkg="p" exec="e" name="n" args="$(command \'no-such-tool -x\')"/>'
        "\n</launch>",
    )
    assert error.line == 2
    assert "$(command 'no-such-tool -x') failed: program 'no-such-tool' is not on PATH" in str(
        error)


@pytest.mark.parametrize(
    ("on_stderr", "value", "warned"),
    [("ignore", "out\n", False), ("warn", "out\n", True), ("capture", "err\nout\n", False)],
)
def test_on_stderr(tmp_path: Path, on_stderr: str, value: str, warned: bool) -> None:
    description = load(
        tmp_path,
        f"""
        <launch>
          <node pkg="p" exec="e" name="n">
            <param name="v" type="str"
                   value="$(command 'sh -c &quot;echo err >&amp;2; echo out&quot;' {on_stderr})"/>
          </node>
        </launch>
        """,
    )
    assert description.parameters.get("/n/v") == value
    warnings = [w for w in description.warnings if "stderr" in w]
    if warned:
        assert warnings == [f"{tmp_path / 'main.launch'}:3: $(command 'sh -c \"echo err >&2; "
                            "echo out\"') wrote to stderr: err"]
    else:
        assert warnings == []


def test_stderr_fails_by_default_as_in_launch(tmp_path: Path) -> None:
    error = error_of(
        tmp_path,
        """
        <launch>
          <node pkg="p" exec="e" name="n">
            <param name="v" value="$(command 'sh -c &quot;echo careful >&amp;2&quot;')"/>
          </node>
        </launch>
        """,
    )
    assert error.line == 3
    assert "wrote to stderr: careful (on_stderr 'fail', the default" in error.message


def test_on_stderr_must_be_known(tmp_path: Path) -> None:
    error = error_of(
        tmp_path,
        '<launch>\n<node pkg="p" exec="e" name="n" args="$(command \'echo\' loud)"/>\n</launch>',
    )
    assert "on_stderr is 'loud'; use one of fail, ignore, warn, capture" in error.message


def test_the_command_sees_the_files_environment(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <set_env name="RTCF_TEST_SETTING" value="from the file"/>
          <node pkg="p" exec="e" name="n">
            <param name="v" type="str" value="$(command 'printenv RTCF_TEST_SETTING')"/>
          </node>
        </launch>
        """,
    )
    assert description.parameters.get("/n/v") == "from the file\n"


def test_commands_run_once_while_reading_and_not_in_skipped_elements(tmp_path: Path) -> None:
    count = tmp_path / "count"
    load(
        tmp_path,
        f"""
        <launch>
          <node pkg="p" exec="e" name="n">
            <param name="v" value="$(command 'sh -c &quot;echo x >> {count}&quot;')"/>
            <param name="w" if="false"
                   value="$(command 'sh -c &quot;echo y >> {count}&quot;')"/>
          </node>
        </launch>
        """,
    )
    assert count.read_text() == "x\n"


def test_the_ament_index_of_this_python_is_on_the_commands_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    monkeypatch.setattr(sys, "prefix", str(tmp_path))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    assert _commands.environment()["AMENT_PREFIX_PATH"] == str(tmp_path)
    monkeypatch.setenv("AMENT_PREFIX_PATH", "/opt/ros/jazzy")
    assert _commands.environment()["AMENT_PREFIX_PATH"] == f"/opt/ros/jazzy:{tmp_path}"
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    assert _commands.environment()["AMENT_PREFIX_PATH"] == str(tmp_path)
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "no_index"))
    monkeypatch.delenv("AMENT_PREFIX_PATH")
    assert "AMENT_PREFIX_PATH" not in _commands.environment()


def test_arguments_split_into_words_before_their_substitutions() -> None:
    assert split_words("a 'b c' \"d e\" ''") == ["a", "b c", "d e", ""]
    assert split_words("'$(find-exec xacro) $(var f)' warn") == [
        "$(find-exec xacro) $(var f)", "warn"]
    assert split_words("$(var 'a b') x") == ["$(var 'a b')", "x"]
    with pytest.raises(SubstitutionError, match="unterminated quote"):
        split_words("'open")


# --------------------------------------------------------------------------- $(find-exec)


def test_find_exec_gives_the_executables_path(tmp_path: Path) -> None:
    assert SH is not None
    assert value_of(tmp_path, "$(find-exec sh)") == SH
    assert value_of(tmp_path, "$(command '$(find-exec printf) %s found')") == "found"


def test_find_exec_of_a_missing_executable_is_an_error(tmp_path: Path) -> None:
    error = error_of(
        tmp_path, '<launch>\n\n<node pkg="p" exec="e" name="n" args="$(find-exec nope-x)"/>'
                  "\n</launch>")
    assert error.line == 3
    assert "$(find-exec nope-x): executable 'nope-x' not found on the PATH" in error.message


def test_find_exec_also_looks_among_this_pythons_scripts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scripts = tmp_path / "bin"
    scripts.mkdir()
    tool = scripts / "rtcf-test-tool"
    tool.write_text("#!/bin/sh\necho tool says $1\n")
    tool.chmod(0o755)
    monkeypatch.setattr(_commands, "scripts_directory", lambda: str(scripts))
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    assert _commands.find_executable("rtcf-test-tool") == str(tool)
    assert value_of(tmp_path, "$(command 'rtcf-test-tool hi')") == "tool says hi\n"
    assert _commands.find_executable("rtcf-other-tool") is None


# --------------------------------------------------------------------------- ROS 1 <param>


def test_ros1_param_command_textfile_and_binfile(tmp_path: Path) -> None:
    (tmp_path / "robot.urdf").write_text('<robot name="r"/>\n')
    (tmp_path / "blob.bin").write_bytes(b"\x00\xffrtcf")
    description = load(
        tmp_path,
        """
        <launch>
          <param name="robot_description" command="cat $(dirname)/robot.urdf"/>
          <node name="n" pkg="p" type="t">
            <param name="text" textfile="robot.urdf"/>
            <param name="blob" binfile="blob.bin"/>
            <param name="words" command="echo 'one  two'"/>
          </node>
        </launch>
        """,
    )
    values = dict(description.parameters.items())
    assert values["/robot_description"] == '<robot name="r"/>\n'
    assert values["/n/text"] == '<robot name="r"/>\n'
    assert values["/n/blob"] == b"\x00\xffrtcf"
    assert values["/n/words"] == "one  two\n"  # shlex, no shell: the quotes keep the spaces
    assert description.warnings == []


def test_ros1_param_command_failure_and_stderr(tmp_path: Path) -> None:
    error = error_of(
        tmp_path,
        """
        <launch>
          <param name="robot_description" command="sh -c 'echo no xacro here >&amp;2; exit 2'"/>
        </launch>
        """,
    )
    assert error.line == 2
    assert "\n" not in str(error)
    assert error.message == (
        "<param name='robot_description'>: cannot load command parameter: command "
        "\"sh -c 'echo no xacro here >&2; exit 2'\" failed: exited with code 2; "
        "stderr: no xacro here")
    # stderr of a command that succeeds: roslaunch lets it through; here a warning
    description = load(
        tmp_path,
        """
        <launch>
          <param name="p" command="sh -c 'echo deprecated >&amp;2; echo 5'"/>
        </launch>
        """,
    )
    assert description.parameters.get("/p") == "5\n"
    assert len(description.warnings) == 1
    assert description.warnings[0].endswith("wrote to stderr: deprecated")


def test_command_line_of_a_long_stderr_is_cut(tmp_path: Path) -> None:
    with pytest.raises(_commands.CommandFailed) as info:
        _commands.run("sh -c 'for i in 1 2 3 4 5; do echo line$i >&2; done; exit 1'")
    assert str(info.value) == (
        "exited with code 1; stderr: line1 | line2 | line3 (and 2 more lines)")
    assert os.sep in (_commands.find_executable("sh") or "")
