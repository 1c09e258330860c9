"""Tests of the ROS 1 / ROS 2 launch XML reader."""

from __future__ import annotations

import os
import textwrap
from importlib import resources
from pathlib import Path

import pytest
import yaml

from rtcf._core._errors import LaunchError, Location
from rtcf._launch._description import LaunchDescription, NodeDescription
from rtcf._launch._xml import parse_launch_file, parse_launch_string

# Listing 2 of the paper, as rtcf_examples ships it
PAPER = Path(str(resources.files("rtcf_examples") / "launch" / "paper_example.launch"))


def write(directory: Path, name: str, text: str) -> Path:
    path = directory / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip("\n"), encoding="utf-8")
    return path


def load(tmp_path: Path, text: str, args: dict[str, str] | None = None) -> LaunchDescription:
    return parse_launch_file(write(tmp_path, "main.launch", text), args)


def launch_error(tmp_path: Path, text: str, args: dict[str, str] | None = None) -> LaunchError:
    with pytest.raises(LaunchError) as info:
        load(tmp_path, text, args)
    return info.value


def node(description: LaunchDescription, full_name: str) -> NodeDescription:
    matches = [n for n in description.nodes if n.full_name == full_name]
    assert len(matches) == 1, [n.full_name for n in description.nodes]
    return matches[0]


def params(description: LaunchDescription) -> dict[str, object]:
    return description.parameters.as_dict()


# --------------------------------------------------------------------------- paper listing


def test_paper_listing() -> None:
    description = parse_launch_file(PAPER)

    assert description.source == str(PAPER)
    assert [n.full_name for n in description.nodes] == ["/rt_runner", "/example1", "/example2"]
    runner, example1, example2 = description.nodes
    assert (runner.package, runner.executable, runner.dialect) == ("rtcf", "rt_runner", "ros1")
    assert runner.output == "screen"
    assert runner.location == Location(str(PAPER), 5)
    assert (example1.executable, example1.args) == ("rt_launcher", "rtcf_examples PaperExample")
    assert example1.remaps == [("out_port", "/tmp"), ("in_port", "/ros/in")]
    assert example2.remaps == [("out_port", "/ros/out"), ("in_port", "/tmp")]
    assert (example1.location.line, example2.location.line) == (12, 18)
    assert params(description) == {
        "/rt_runner/mode": "wait_for_components",
        "/rt_runner/ros_mapping_whitelist": ".*ros.*",
        "/rt_runner/num_components_expected": 2,
        "/rt_runner/frequency": 1000.0,
        "/example1/is_first": True,
    }
    value = description.parameters.get("/rt_runner/num_components_expected")
    assert type(value) is int
    assert description.warnings == []


def test_rosparam_scalars_from_the_spec(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <node name="n" pkg="p" type="t">
            <rosparam param="cpu_affinity_mask">02</rosparam>
            <rosparam param="frequency">2000.0</rosparam>
            <rosparam param="ros_mapping_whitelist">".*R3_G2H1|.*R1_H1R2|.*G2_R2"</rosparam>
            <rosparam param="is_first">True</rosparam>
          </node>
        </launch>
        """,
    )
    assert params(description) == {
        "/n/cpu_affinity_mask": 2,
        "/n/frequency": 2000.0,
        "/n/ros_mapping_whitelist": ".*R3_G2H1|.*R1_H1R2|.*G2_R2",
        "/n/is_first": True,
    }
    assert type(params(description)["/n/frequency"]) is float


# --------------------------------------------------------------------------- XML level errors


def test_malformed_xml_reports_file_and_line(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path,
        """
        <launch>
          <node name="a" pkg="p" type="t">
          </nod>
        </launch>
        """,
    )
    assert error.file == str(tmp_path / "main.launch")
    assert error.line == 3
    assert "malformed XML" in error.message


def test_root_must_be_launch(tmp_path: Path) -> None:
    error = launch_error(tmp_path, "<?xml version='1.0'?>\n<robot/>\n")
    assert error.line == 2
    assert "<launch>" in error.message and "<robot>" in error.message


def test_unknown_element_names_element_file_and_line(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path,
        """
        <launch>
          <group>
            <frobnicate/>
          </group>
        </launch>
        """,
    )
    assert (error.file, error.line) == (str(tmp_path / "main.launch"), 3)
    assert "<frobnicate>" in error.message
    assert str(error).startswith(f"{tmp_path / 'main.launch'}:3: ")


def test_unknown_child_of_node_is_an_error(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path,
        """
        <launch>
          <node name="a" pkg="p" type="t">

            <group/>
          </node>
        </launch>
        """,
    )
    assert error.line == 4
    assert "<group>" in error.message


def test_parse_launch_string_uses_source_in_errors() -> None:
    with pytest.raises(LaunchError) as info:
        parse_launch_string("<launch>\n<bogus/>\n</launch>", source="inline.launch")
    assert (info.value.file, info.value.line) == ("inline.launch", 2)
    description = parse_launch_string('<launch><node name="a" pkg="p" exec="e"/></launch>')
    assert description.source == "<string>"
    assert description.nodes[0].location == Location("<string>", 1)


def test_machine_and_test_are_ignored_with_warnings(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <machine name="m" address="localhost"/>
          <test test-name="t" pkg="p" type="t"/>
          <node name="a" pkg="p" type="t"/>
        </launch>
        """,
    )
    assert len(description.nodes) == 1
    assert len(description.warnings) == 2
    assert "main.launch:1" not in description.warnings[0]
    assert "main.launch:2" in description.warnings[0] and "<machine>" in description.warnings[0]
    assert "main.launch:3" in description.warnings[1] and "<test>" in description.warnings[1]


def test_set_parameter_is_not_supported(tmp_path: Path) -> None:
    error = launch_error(tmp_path, '<launch>\n  <set_parameter name="a" value="1"/>\n</launch>')
    assert error.line == 2 and "not supported" in error.message
    error = launch_error(tmp_path, '<launch>\n\n  <set-parameter name="a" value="1"/>\n</launch>')
    assert error.line == 3 and "not supported" in error.message


# --------------------------------------------------------------------------- nodes


def test_node_dialect_and_executable(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <node name="one" pkg="p" type="t1"/>
          <node name="two" pkg="p" exec="e2" namespace="ns" args="a b" ros_args="-p x:=1"/>
        </launch>
        """,
    )
    one, two = description.nodes
    assert (one.dialect, one.executable, one.full_name) == ("ros1", "t1", "/one")
    assert (two.dialect, two.executable, two.full_name) == ("ros2", "e2", "/ns/two")
    assert two.args == "a b --ros-args -p x:=1"


@pytest.mark.parametrize("attrs", ['type="t" exec="e"', ""])
def test_node_needs_exactly_one_of_exec_and_type(tmp_path: Path, attrs: str) -> None:
    error = launch_error(tmp_path, f'<launch>\n\n<node name="a" pkg="p" {attrs}/>\n</launch>')
    assert error.line == 3
    assert "exec" in error.message and "type" in error.message


def test_node_without_name_uses_executable_and_warns(tmp_path: Path) -> None:
    description = load(tmp_path, '<launch>\n  <node pkg="p" exec="talker"/>\n</launch>')
    assert description.nodes[0].full_name == "/talker"
    assert len(description.warnings) == 1 and "main.launch:2" in description.warnings[0]


def test_node_name_with_namespace_is_rejected(tmp_path: Path) -> None:
    error = launch_error(tmp_path, '<launch>\n  <node name="a/b" pkg="p" type="t"/>\n</launch>')
    assert error.line == 2 and "a/b" in error.message


def test_duplicate_node_names_report_both_lines(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "paper.launch",
        """
        <launch>
          <node name="example1" pkg="p" type="t"/>
          <group ns="/">
            <node name="example1" pkg="p" type="t"/>
          </group>
        </launch>
        """,
    )
    with pytest.raises(LaunchError) as info:
        parse_launch_file(path)
    assert info.value.message == (
        f"node '/example1' is defined twice: {path}:2 and {path}:4; give each node a unique name"
    )
    assert info.value.line == 4


def test_same_name_in_different_namespaces_is_fine(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <node name="a" pkg="p" type="t"/>
          <node name="a" pkg="p" type="t" ns="x"/>
        </launch>
        """,
    )
    assert [n.full_name for n in description.nodes] == ["/a", "/x/a"]


def test_env_scoping(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <env name="A" value="1"/>
          <node name="first" pkg="p" type="t"/>
          <group>
            <env name="B" value="2"/>
            <node name="second" pkg="p" type="t">
              <env name="C" value="3"/>
            </node>
          </group>
          <node name="third" pkg="p" type="t"/>
        </launch>
        """,
    )
    assert node(description, "/first").env == {"A": "1"}
    assert node(description, "/second").env == {"A": "1", "B": "2", "C": "3"}
    assert node(description, "/third").env == {"A": "1"}


# --------------------------------------------------------------------------- namespaces, remaps


def test_nested_groups_relative_and_absolute_namespaces(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <group ns="robot">
            <node name="a" pkg="p" type="t"/>
            <group ns="arm">
              <node name="b" pkg="p" type="t"/>
              <node name="c" pkg="p" type="t" ns="sub"/>
              <node name="d" pkg="p" type="t" ns="/abs"/>
            </group>
            <group ns="/top">
              <node name="e" pkg="p" type="t"/>
            </group>
            <node name="f" pkg="p" type="t"/>
          </group>
          <node name="g" pkg="p" type="t"/>
        </launch>
        """,
    )
    assert [n.full_name for n in description.nodes] == [
        "/robot/a",
        "/robot/arm/b",
        "/robot/arm/sub/c",
        "/abs/d",
        "/top/e",
        "/robot/f",
        "/g",
    ]
    assert node(description, "/robot/arm/b").namespace == "/robot/arm"


def test_remap_scoping(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <node name="before" pkg="p" type="t"/>
          <remap from="a" to="b"/>
          <group ns="g">
            <remap from="c" to="d"/>
            <node name="inner" pkg="p" type="t">
              <remap from="a" to="z"/>
            </node>
          </group>
          <node name="after" pkg="p" type="t"/>
        </launch>
        """,
    )
    assert node(description, "/before").remaps == []
    assert node(description, "/g/inner").remaps == [("a", "b"), ("c", "d"), ("a", "z")]
    assert node(description, "/after").remaps == [("a", "b")]


# --------------------------------------------------------------------------- if / unless


def test_if_and_unless(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="sim" default="true"/>
          <node name="a" pkg="p" type="t" if="$(arg sim)"/>
          <node name="b" pkg="p" type="t" unless="$(arg sim)"/>
          <node name="c" pkg="p" type="t" if="1"/>
          <node name="d" pkg="p" type="t" if="FALSE"/>
          <node name="e" pkg="p" type="t" unless="0"/>
          <group if="false">
            <node name="f" pkg="p" type="t"/>
          </group>
          <node name="g" pkg="p" type="t">
            <remap from="x" to="y" if="True"/>
            <remap from="q" to="r" unless="true"/>
            <param name="kept" value="1" unless="false"/>
            <param name="dropped" value="1" if="0"/>
          </node>
        </launch>
        """,
    )
    assert [n.name for n in description.nodes] == ["a", "c", "e", "g"]
    assert node(description, "/g").remaps == [("x", "y")]
    assert params(description) == {"/g/kept": 1}


def test_if_with_a_bad_value_is_an_error(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path, '<launch>\n  <node name="a" pkg="p" type="t"\n        if="yes"/>\n</launch>'
    )
    assert error.line == 2
    assert "'yes'" in error.message and "if" in error.message


def test_skipped_elements_are_not_substituted(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        '<launch><node name="a" pkg="$(arg missing)" type="t" if="false"/></launch>',
    )
    assert description.nodes == []


# --------------------------------------------------------------------------- args


ARGS_FILE = """
<launch>
  <arg name="rate" default="10"/>
  <arg name="fixed" value="const"/>
  <arg name="needed"/>
  <node name="n" pkg="p" type="t" args="$(arg rate) $(arg fixed)"/>
</launch>
"""


def test_arg_defaults_and_overrides(tmp_path: Path) -> None:
    description = load(tmp_path, ARGS_FILE)
    assert description.nodes[0].args == "10 const"
    assert description.args == {"rate": "10", "fixed": "const"}

    description = load(tmp_path, ARGS_FILE, {"rate": "20", "needed": "x"})
    assert description.nodes[0].args == "20 const"
    assert description.args == {"rate": "20", "fixed": "const", "needed": "x"}


def test_constant_arg_cannot_be_overridden(tmp_path: Path) -> None:
    error = launch_error(tmp_path, ARGS_FILE, {"fixed": "other"})
    assert error.line == 3 and "fixed" in error.message


def test_passing_an_undeclared_arg_is_an_error(tmp_path: Path) -> None:
    error = launch_error(tmp_path, ARGS_FILE, {"bogus": "1"})
    assert error.file == str(tmp_path / "main.launch")
    assert "'bogus'" in error.message


def test_required_arg_without_value_is_an_error_when_used(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path,
        """
        <launch>
          <arg name="robot"/>
          <node name="n" pkg="p" type="t"
                args="$(arg robot)"/>
        </launch>
        """,
    )
    assert error.line == 3
    assert "'robot'" in error.message and "robot:=value" in error.message


def test_undefined_arg_message(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path, '<launch>\n\n  <node name="n" pkg="p" type="t" args="$(arg x)"/>\n</launch>'
    )
    assert error.line == 3
    assert error.message == (
        "arg 'x' is not defined; declare it with <arg name=\"x\" .../> or pass x:=value"
    )


def test_arg_with_both_value_and_default_is_an_error(tmp_path: Path) -> None:
    error = launch_error(tmp_path, '<launch>\n<arg name="a" value="1" default="2"/>\n</launch>')
    assert error.line == 2


def test_arg_declared_twice_is_an_error(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path, '<launch>\n<arg name="a" default="1"/>\n<arg name="a" default="2"/>\n</launch>'
    )
    assert error.line == 3 and "line 2" in error.message


def test_args_in_groups_are_scoped(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path,
        """
        <launch>
          <group>
            <arg name="inner" default="1"/>
          </group>
          <node name="n" pkg="p" type="t" args="$(arg inner)"/>
        </launch>
        """,
    )
    assert error.line == 5 and "'inner'" in error.message


# --------------------------------------------------------------------------- parameters


def test_param_auto_typing(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <node name="n" pkg="p" type="t">
            <param name="t" value="true"/>
            <param name="f" value="FALSE"/>
            <param name="i" value="42"/>
            <param name="ws" value=" 7 "/>
            <param name="neg" value="-3"/>
            <param name="x" value="1.5"/>
            <param name="e" value="1e3"/>
            <param name="s" value="hello"/>
            <param name="one" value="1"/>
            <param name="a" value="2" type="auto"/>
          </node>
        </launch>
        """,
    )
    values = params(description)
    assert values == {
        "/n/t": True,
        "/n/f": False,
        "/n/i": 42,
        "/n/ws": 7,
        "/n/neg": -3,
        "/n/x": 1.5,
        "/n/e": 1000.0,
        "/n/s": "hello",
        "/n/one": 1,
        "/n/a": 2,
    }
    assert type(values["/n/one"]) is int
    assert type(values["/n/e"]) is float


def test_param_explicit_types(tmp_path: Path) -> None:
    write(tmp_path, "data/notes.txt", "line one\nline two\n")
    description = load(
        tmp_path,
        """
        <launch>
          <node name="n" pkg="p" type="t">
            <param name="s" value="3" type="str"/>
            <param name="b" value="true" type="str"/>
            <param name="i" value=" 12 " type="int"/>
            <param name="d" value="3" type="double"/>
            <param name="yes" value="True" type="bool"/>
            <param name="no" value="0" type="bool"/>
            <param name="y" type="yaml" value="{gains: [1, 2.5], name: arm}"/>
            <param name="text" textfile="data/notes.txt"/>
          </node>
        </launch>
        """,
    )
    values = params(description)
    assert values == {
        "/n/s": "3",
        "/n/b": "true",
        "/n/i": 12,
        "/n/d": 3.0,
        "/n/yes": True,
        "/n/no": False,
        "/n/y/gains": [1, 2.5],
        "/n/y/name": "arm",
        "/n/text": "line one\nline two\n",
    }
    assert type(values["/n/d"]) is float
    assert description.parameters.get("/n/y") == {"gains": [1, 2.5], "name": "arm"}


@pytest.mark.parametrize(
    ("attrs", "words"),
    [
        ('value="abc" type="int"', ["'abc'", "int"]),
        ('value="1.5" type="int"', ["'1.5'", "int"]),
        ('value="x" type="double"', ["'x'", "double"]),
        ('value="maybe" type="bool"', ["'maybe'"]),
        ('value="1" type="complex"', ["'complex'", "yaml"]),
        ('value="[1, 2" type="yaml"', ["YAML"]),
        ('command="cat foo"', ["command 'cat foo'", "exited with code 1", "stderr: cat: foo"]),
        ('command="no-such-program-here x"', ["'no-such-program-here' is not on PATH"]),
        ('command="cat \'unbalanced"', ["cannot be split"]),
        ('value="1" command="echo 1"', ["value and command=", "only one"]),
        ("", ["value="]),
        ('textfile="missing.txt"', ["missing.txt"]),
        ('binfile="missing.bin"', ["missing.bin"]),
    ],
)
def test_param_errors(tmp_path: Path, attrs: str, words: list[str]) -> None:
    error = launch_error(
        tmp_path,
        f'<launch>\n  <node name="n" pkg="p" type="t">\n    <param name="p" {attrs}/>'
        "\n  </node>\n</launch>",
    )
    assert error.line == 3
    for word in words:
        assert word in error.message


def test_param_names_inside_and_outside_nodes(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <param name="top" value="1"/>
          <param name="/abs/x" value="2"/>
          <group ns="g">
            <param name="rel" value="3"/>
            <param name="sub/deep" value="4"/>
            <node name="n" pkg="p" type="t">
              <param name="priv" value="5"/>
              <param name="~tilde" value="6"/>
              <param name="/global" value="7"/>
            </node>
          </group>
        </launch>
        """,
    )
    assert params(description) == {
        "/top": 1,
        "/abs/x": 2,
        "/g/rel": 3,
        "/g/sub/deep": 4,
        "/g/n/priv": 5,
        "/g/n/tilde": 6,
        "/global": 7,
    }


def test_private_param_outside_node_is_an_error(tmp_path: Path) -> None:
    error = launch_error(tmp_path, '<launch>\n  <param name="~x" value="1"/>\n</launch>')
    assert error.line == 2 and "'~x'" in error.message


def test_later_param_overrides_earlier(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        '<launch><param name="a" value="1"/><param name="a" value="2" type="str"/></launch>',
    )
    assert params(description) == {"/a": "2"}


# --------------------------------------------------------------------------- rosparam


def test_rosparam_dict_without_param(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <group ns="robot">
            <rosparam>
              gains: {p: 1.0, i: 0}
              name: arm
            </rosparam>
            <node name="n" pkg="p" type="t">
              <rosparam>
                rate: 100
                limits:
                  max: 2
              </rosparam>
              <rosparam ns="extra">{a: true}</rosparam>
            </node>
          </group>
          <rosparam ns="/other" param="list">[1, 2, 3]</rosparam>
        </launch>
        """,
    )
    assert params(description) == {
        "/robot/gains/p": 1.0,
        "/robot/gains/i": 0,
        "/robot/name": "arm",
        "/robot/n/rate": 100,
        "/robot/n/limits/max": 2,
        "/robot/n/extra/a": True,
        "/other/list": [1, 2, 3],
    }


def test_rosparam_merges_dicts(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <rosparam param="cfg">{a: 1, b: 2}</rosparam>
          <rosparam param="cfg">{b: 3, c: 4}</rosparam>
        </launch>
        """,
    )
    assert params(description) == {"/cfg/a": 1, "/cfg/b": 3, "/cfg/c": 4}


def test_rosparam_non_dict_without_param_is_an_error(tmp_path: Path) -> None:
    error = launch_error(tmp_path, "<launch>\n\n  <rosparam>[1, 2]</rosparam>\n</launch>")
    assert error.line == 3 and "dictionary" in error.message


def test_rosparam_bad_yaml_reports_line(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path, '<launch>\n  <rosparam param="x">\n    a: [1, 2\n  </rosparam>\n</launch>'
    )
    assert error.file == str(tmp_path / "main.launch")
    assert error.line is not None and 2 <= error.line <= 4
    assert "YAML" in error.message


def test_rosparam_delete_and_dump(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <rosparam param="cfg">{a: 1, b: 2}</rosparam>
          <rosparam command="delete" param="cfg/a"/>
          <rosparam command="dump" file="out.yaml"/>
        </launch>
        """,
    )
    assert params(description) == {"/cfg/b": 2}
    assert len(description.warnings) == 1 and "main.launch:4" in description.warnings[0]


def test_rosparam_subst_value(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="rate" default="250"/>
          <rosparam param="with" subst_value="true">$(arg rate)</rosparam>
          <rosparam param="without">"$(arg rate)"</rosparam>
        </launch>
        """,
    )
    assert params(description) == {"/with": 250, "/without": "$(arg rate)"}


def test_rosparam_file(tmp_path: Path) -> None:
    write(tmp_path, "config/gains.yaml", "p: 2.0\nlist: [a, b]\n")
    description = load(
        tmp_path,
        """
        <launch>
          <node name="n" pkg="p" type="t">
            <rosparam file="$(dirname)/config/gains.yaml" command="load"/>
          </node>
          <rosparam file="config/gains.yaml" param="copy"/>
        </launch>
        """,
    )
    assert params(description) == {
        "/n/p": 2.0,
        "/n/list": ["a", "b"],
        "/copy/p": 2.0,
        "/copy/list": ["a", "b"],
    }


def test_rosparam_bad_yaml_file_reports_that_file(tmp_path: Path) -> None:
    bad = write(tmp_path, "bad.yaml", "a: 1\nb: [1,\n")
    error = launch_error(tmp_path, '<launch>\n  <rosparam file="bad.yaml"/>\n</launch>')
    assert error.file == str(bad)
    assert error.line == 3


# --------------------------------------------------------------------------- ROS 2


def test_ros2_file(tmp_path: Path) -> None:
    write(
        tmp_path,
        "params.yaml",
        """
        /**:
          ros__parameters:
            use_sim_time: true
            shared: 0
        controller:
          ros__parameters:
            gains: {p: 1.5}
            shared: 1
        /robot/controller:
          ros__parameters:
            full: yes
        other:
          ros__parameters:
            foreign: 1
        """,
    )
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="robot" default="robot"/>
          <let name="rate" value="500"/>
          <group>
            <push-ros-namespace namespace="$(var robot)"/>
            <node pkg="ctrl" exec="controller_node" name="controller" output="screen">
              <param name="rate" value="$(var rate)"/>
              <param name="mode" value="fast"/>
              <param name="flag" value="True"/>
              <param name="ratio" value="0.25"/>
              <param name="joints" value="a,b,c" value-sep=","/>
              <param name="numbers" value="1;2.5;x" value-sep=";"/>
              <param name="limits">
                <param name="max" value="3"/>
                <param name="inner">
                  <param name="deep" value="x"/>
                </param>
              </param>
              <param from="params.yaml"/>
              <remap from="cmd" to="/cmd_vel"/>
            </node>
          </group>
          <node pkg="ctrl" exec="other" name="outside"/>
        </launch>
        """,
    )
    controller = node(description, "/robot/controller")
    assert controller.dialect == "ros2"
    assert (controller.executable, controller.namespace) == ("controller_node", "/robot")
    assert controller.remaps == [("cmd", "/cmd_vel")]
    assert node(description, "/outside").namespace == "/"
    assert params(description) == {
        "/robot/controller/rate": 500,
        "/robot/controller/mode": "fast",
        "/robot/controller/flag": True,
        "/robot/controller/ratio": 0.25,
        "/robot/controller/joints": ["a", "b", "c"],
        "/robot/controller/numbers": [1, 2.5, "x"],
        "/robot/controller/limits/max": 3,
        "/robot/controller/limits/inner/deep": "x",
        "/robot/controller/use_sim_time": True,
        "/robot/controller/shared": 1,
        "/robot/controller/gains/p": 1.5,
        "/robot/controller/full": True,
    }


def test_ros2_params_file_wildcards_and_mismatch(tmp_path: Path) -> None:
    write(
        tmp_path,
        "p.yaml",
        """
        "**":
          ros__parameters: {everywhere: 1}
        /a/*:
          ros__parameters: {star: 2}
        /**/n:
          ros__parameters: {suffix: 3}
        a/n:
          ros__parameters: {relative: 4}
        /b/n:
          ros__parameters: {wrong_ns: 5}
        """,
    )
    description = load(
        tmp_path,
        """
        <launch>
          <node pkg="p" exec="e" name="n" namespace="a"><param from="p.yaml"/></node>
        </launch>
        """,
    )
    assert params(description) == {
        "/a/n/everywhere": 1,
        "/a/n/star": 2,
        "/a/n/suffix": 3,
        "/a/n/relative": 4,
    }


def test_ros2_params_file_without_ros__parameters_is_an_error(tmp_path: Path) -> None:
    bad = write(tmp_path, "p.yaml", "n:\n  rate: 1\n")
    error = launch_error(
        tmp_path, '<launch><node pkg="p" exec="e" name="n"><param from="p.yaml"/></node></launch>'
    )
    assert error.file == str(bad) and "ros__parameters" in error.message


def test_let_and_push_namespace_scoping(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <let name="x" value="outer"/>
          <group>
            <let name="x" value="inner"/>
            <push_ros_namespace namespace="ns1"/>
            <node pkg="p" exec="e" name="a" args="$(var x)"/>
          </group>
          <node pkg="p" exec="e" name="b" args="$(var x)"/>
          <group scoped="false">
            <let name="x" value="leaked"/>
            <push-ros-namespace namespace="ns2"/>
          </group>
          <node pkg="p" exec="e" name="c" args="$(var x)"/>
          <node pkg="p" exec="e" name="d" namespace="/abs"/>
        </launch>
        """,
    )
    assert [(n.full_name, n.args) for n in description.nodes] == [
        ("/ns1/a", "inner"),
        ("/b", "outer"),
        ("/ns2/c", "leaked"),
        ("/abs/d", ""),
    ]


def test_mixed_dialects_in_one_file(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="ns" default="mix"/>
          <group ns="$(arg ns)">
            <node name="r1" pkg="p" type="t"><param name="v" value="1.0"/></node>
            <node name="r2" pkg="p" exec="e"><param name="v" value="$(var ns)"/></node>
          </group>
        </launch>
        """,
    )
    assert [(n.full_name, n.dialect) for n in description.nodes] == [
        ("/mix/r1", "ros1"),
        ("/mix/r2", "ros2"),
    ]
    assert params(description) == {"/mix/r1/v": 1.0, "/mix/r2/v": "mix"}


# --------------------------------------------------------------------------- substitutions


def test_env_and_optenv(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RTCF_TEST_SET", "abc")
    monkeypatch.delenv("RTCF_TEST_UNSET", raising=False)
    description = load(
        tmp_path,
        """
        <launch>
          <node name="a" pkg="p" type="t" args="$(env RTCF_TEST_SET)"/>
          <node name="b" pkg="p" type="t" args="$(optenv RTCF_TEST_UNSET two words)"/>
          <node name="c" pkg="p" type="t" args="$(optenv RTCF_TEST_SET fallback)"/>
          <node name="d" pkg="p" type="t" args="[$(optenv RTCF_TEST_UNSET)]"/>
          <node name="e" pkg="p" exec="t" args="$(env RTCF_TEST_UNSET dflt)"/>
        </launch>
        """,
    )
    assert [n.args for n in description.nodes] == ["abc", "two words", "abc", "[]", "dflt"]


def test_unset_env_is_an_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("RTCF_TEST_UNSET", raising=False)
    error = launch_error(
        tmp_path,
        '<launch>\n<node name="a" pkg="p" type="t" args="$(env RTCF_TEST_UNSET)"/>\n</launch>',
    )
    assert error.line == 2 and "RTCF_TEST_UNSET" in error.message


def test_find_uses_ros_package_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pkg_dir = tmp_path / "ws" / "src" / "my_pkg_dir"
    write(pkg_dir, "package.xml", "<package><name>my_pkg</name></package>")
    write(tmp_path / "ws", "other/package.xml", "<package><name>other</name></package>")
    monkeypatch.setenv(
        "ROS_PACKAGE_PATH", os.pathsep.join([str(tmp_path / "nowhere"), str(tmp_path / "ws")])
    )
    description = load(
        tmp_path,
        """
        <launch>
          <node name="a" pkg="p" type="t" args="$(find my_pkg)/launch"/>
          <node name="b" pkg="p" exec="t" args="$(find-pkg-share my_pkg)"/>
        </launch>
        """,
    )
    assert [n.args for n in description.nodes] == [f"{pkg_dir}/launch", str(pkg_dir)]


def test_find_falls_back_to_python_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_PACKAGE_PATH", "")
    text = '<launch><node name="a" pkg="p" type="t" args="$(find yaml)"/></launch>'
    description = load(tmp_path, text)
    assert description.nodes[0].args == os.path.dirname(yaml.__file__)


def test_find_unknown_package_is_an_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    error = launch_error(
        tmp_path, '<launch>\n\n<include file="$(find no_such_pkg_xyz)/x.launch"/>\n</launch>'
    )
    assert error.line == 3 and "'no_such_pkg_xyz'" in error.message


def test_dirname_and_nested_substitution(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <let name="which" value="rate"/>
          <let name="rate" value="7"/>
          <node name="a" pkg="p" type="t" args="$(dirname) $(var $(var which))"/>
        </launch>
        """,
    )
    assert description.nodes[0].args == f"{tmp_path} 7"


def test_anon_is_stable_within_one_parse(tmp_path: Path) -> None:
    text = """
        <launch>
          <node name="$(anon viewer)" pkg="p" type="t" args="$(anon viewer)"/>
          <node name="$(anon other)" pkg="p" type="t"/>
        </launch>
        """
    first = load(tmp_path, text)
    a, b = first.nodes
    assert a.name == a.args and a.name.startswith("viewer_") and len(a.name) > len("viewer_")
    assert b.name.startswith("other_") and b.name[len("other_") :] != a.name[len("viewer_") :]
    second = load(tmp_path, text)
    assert second.nodes[0].name != a.name


def test_eval_ros1_and_ros2(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="mode" default="sim"/>
          <arg name="n" default="3"/>
          <node name="a" pkg="p" type="t" if="$(eval mode == 'sim')"/>
          <node name="b" pkg="p" type="t" if="$(eval arg('mode') != 'sim')"/>
          <node name="c" pkg="p" type="t" args="$(eval int(n) * 2)"/>
          <node name="d" pkg="p" exec="t" if="$(eval &quot;'$(var mode)' == 'sim'&quot;)"/>
          <node name="e" pkg="p" exec="t" args="x$(eval $(var n) + 1)"/>
        </launch>
        """,
    )
    assert [(n.name, n.args) for n in description.nodes] == [
        ("a", ""),
        ("c", "6"),
        ("d", ""),
        ("e", "x4"),
    ]


def test_eval_sees_args_as_roslaunch_does(tmp_path: Path) -> None:
    """roslaunch's $(eval) converts each arg as type="auto" would: true/false are bools
    (so comparing one with the string 'true' is false there, and here), numbers are
    numbers; ROS 2's eval compares the text its $(var) substituted."""
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="on" default="true"/>
          <arg name="gain" default="2.5"/>
          <arg name="n" default="3"/>
          <arg name="word" default="True story"/>
          <node name="a" pkg="p" type="t" args="$(eval 5 if on else 4)"/>
          <node name="b" pkg="p" type="t" args="$(eval on == 'true')"/>
          <node name="c" pkg="p" type="t" args="$(eval gain * n)"/>
          <node name="d" pkg="p" type="t" args="$(eval arg('n') + 1)"/>
          <node name="e" pkg="p" type="t" args="$(eval word.split()[0])"/>
          <node name="f" pkg="p" exec="t" args="$(eval &quot;'$(var on)' == 'true'&quot;)"/>
        </launch>
        """,
    )
    assert [(n.name, n.args) for n in description.nodes] == [
        ("a", "5"),
        ("b", "False"),
        ("c", "7.5"),
        ("d", "4"),
        ("e", "True"),
        ("f", "True"),
    ]


def test_eval_errors(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path, '<launch>\n<node name="a" pkg="p" type="t" args="$(eval nope + 1)"/>\n</launch>'
    )
    assert error.line == 2 and "nope" in error.message
    error = launch_error(
        tmp_path,
        '<launch>\n<node name="a" pkg="p" type="t" args="$(eval ().__class__)"/>\n</launch>',
    )
    assert error.line == 2 and "__" in error.message


def test_unknown_substitution_is_an_error(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path, '<launch>\n\n<node name="a" pkg="p" type="t" args="$(exec ls)"/>\n</launch>'
    )
    assert (error.file, error.line) == (str(tmp_path / "main.launch"), 3)
    assert "$(exec" in error.message and "command, dirname" in error.message


def test_unterminated_substitution_is_an_error(tmp_path: Path) -> None:
    text = '<launch>\n<node name="a" pkg="p" type="t" args="$(arg x"/>\n</launch>'
    error = launch_error(tmp_path, text)
    assert error.line == 2 and "unterminated" in error.message


# --------------------------------------------------------------------------- includes


def test_include_with_args_and_ns(tmp_path: Path) -> None:
    write(
        tmp_path,
        "sub/child.launch",
        """
        <launch>
          <arg name="robot"/>
          <arg name="rate" default="10"/>
          <node name="$(arg robot)_ctrl" pkg="p" type="t" args="$(arg rate)"/>
          <param name="rate" value="$(arg rate)"/>
          <include file="grandchild.launch">
            <arg name="label" value="from_child"/>
          </include>
        </launch>
        """,
    )
    write(
        tmp_path,
        "sub/grandchild.launch",
        """
        <launch>
          <arg name="label"/>
          <node name="leaf" pkg="p" type="t" args="$(arg label)"/>
        </launch>
        """,
    )
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="who" default="r2"/>
          <group ns="outer">
            <include file="sub/child.launch" ns="inner">
              <arg name="robot" value="$(arg who)"/>
            </include>
          </group>
          <include file="$(dirname)/sub/child.launch" ns="second">
            <arg name="robot" value="x"/>
            <arg name="rate" value="99"/>
          </include>
        </launch>
        """,
    )
    assert [(n.full_name, n.args) for n in description.nodes] == [
        ("/outer/inner/r2_ctrl", "10"),
        ("/outer/inner/leaf", "from_child"),
        ("/second/x_ctrl", "99"),
        ("/second/leaf", "from_child"),
    ]
    assert params(description) == {"/outer/inner/rate": 10, "/second/rate": 99}
    ctrl = description.nodes[0]
    assert ctrl.location == Location(str(tmp_path / "sub" / "child.launch"), 4)
    assert description.args == {"who": "r2"}


def test_included_file_sees_only_passed_args(tmp_path: Path) -> None:
    child = write(
        tmp_path,
        "child.launch",
        """
        <launch>

          <node name="n" pkg="p" type="t" args="$(arg secret)"/>
        </launch>
        """,
    )
    with pytest.raises(LaunchError) as info:
        load(
            tmp_path,
            """
            <launch>
              <arg name="secret" default="s"/>
              <include file="child.launch"/>
            </launch>
            """,
        )
    assert (info.value.file, info.value.line) == (str(child), 3)
    assert "'secret'" in info.value.message


def test_pass_all_args(tmp_path: Path) -> None:
    write(
        tmp_path,
        "child.launch",
        """
        <launch>
          <arg name="a" default="child_default"/>
          <node name="n" pkg="p" type="t" args="$(arg a) $(arg b)"/>
        </launch>
        """,
    )
    description = load(
        tmp_path,
        """
        <launch>
          <arg name="a" default="from_parent"/>
          <arg name="b" default="also"/>
          <include file="child.launch" pass_all_args="true"/>
        </launch>
        """,
    )
    assert description.nodes[0].args == "from_parent also"
    assert description.warnings == []


def test_ros2_include_sees_includer_configurations(tmp_path: Path) -> None:
    write(
        tmp_path,
        "child.xml",
        """
        <launch>
          <arg name="own" default="d"/>
          <node pkg="p" exec="e" name="n" args="$(var shared) $(var own)"/>
        </launch>
        """,
    )
    description = load(
        tmp_path,
        """
        <launch>
          <let name="shared" value="visible"/>
          <include file="child.xml"><arg name="own" value="passed"/></include>
          <node pkg="p" exec="e" name="m" args="$(var shared)"/>
        </launch>
        """,
    )
    assert [n.args for n in description.nodes] == ["visible passed", "visible"]


def test_include_scope_does_not_leak_back(tmp_path: Path) -> None:
    write(tmp_path, "child.xml", '<launch><let name="x" value="child"/></launch>')
    description = load(
        tmp_path,
        """
        <launch>
          <let name="x" value="parent"/>
          <include file="child.xml"/>
          <node pkg="p" exec="e" name="m" args="$(var x)"/>
        </launch>
        """,
    )
    assert description.nodes[0].args == "parent"


def test_include_inherits_remaps_and_env(tmp_path: Path) -> None:
    write(tmp_path, "child.launch", '<launch><node name="n" pkg="p" type="t"/></launch>')
    description = load(
        tmp_path,
        """
        <launch>
          <remap from="a" to="b"/>
          <env name="E" value="1"/>
          <include file="child.launch"><env name="F" value="2"/></include>
        </launch>
        """,
    )
    assert description.nodes[0].remaps == [("a", "b")]
    assert description.nodes[0].env == {"E": "1", "F": "2"}


def test_include_undeclared_arg_warns(tmp_path: Path) -> None:
    write(tmp_path, "child.launch", "<launch/>")
    description = load(
        tmp_path,
        '<launch>\n<include file="child.launch">\n<arg name="extra" value="1"/>\n'
        "</include>\n</launch>",
    )
    assert len(description.warnings) == 1
    assert "'extra'" in description.warnings[0] and "main.launch:2" in description.warnings[0]


def test_missing_include_is_an_error_at_the_include_line(tmp_path: Path) -> None:
    error = launch_error(
        tmp_path,
        """
        <launch>
          <node name="a" pkg="p" type="t"/>
          <include file="nothere.launch"/>
        </launch>
        """,
    )
    assert (error.file, error.line) == (str(tmp_path / "main.launch"), 3)
    assert "nothere.launch" in error.message and "not found" in error.message


def test_include_cycle_is_an_error(tmp_path: Path) -> None:
    write(tmp_path, "a.launch", '<launch>\n  <include file="b.launch"/>\n</launch>')
    b = write(tmp_path, "b.launch", '<launch>\n\n  <include file="a.launch"/>\n</launch>')
    with pytest.raises(LaunchError) as info:
        parse_launch_file(tmp_path / "a.launch")
    assert (info.value.file, info.value.line) == (str(b), 3)
    assert "cycle" in info.value.message


def test_error_in_included_file_reports_that_file(tmp_path: Path) -> None:
    child = write(tmp_path, "child.launch", "<launch>\n  <node name='x'\n</launch>")
    error = launch_error(tmp_path, '<launch><include file="child.launch"/></launch>')
    assert error.file == str(child) and error.line == 3


def test_duplicate_node_across_include(tmp_path: Path) -> None:
    text = '<launch>\n<node name="a" pkg="p" type="t"/>\n</launch>'
    child = write(tmp_path, "child.launch", text)
    error = launch_error(
        tmp_path,
        '<launch>\n<node name="a" pkg="p" type="t"/>\n<include file="child.launch"/>\n</launch>',
    )
    main = tmp_path / "main.launch"
    assert error.message == (
        f"node '/a' is defined twice: {main}:2 and {child}:2; give each node a unique name"
    )


def test_rosparam_delete_needs_a_target(tmp_path: Path) -> None:
    error = launch_error(tmp_path, '<launch>\n  <rosparam command="delete"/>\n</launch>')
    assert error.line == 2 and "param=" in error.message


def test_rosparam_private_name_inside_node(tmp_path: Path) -> None:
    description = load(
        tmp_path,
        """
        <launch>
          <group ns="g">
            <node name="n" pkg="p" type="t">
              <rosparam param="~a">1</rosparam>
              <rosparam param="/abs">2</rosparam>
            </node>
          </group>
        </launch>
        """,
    )
    assert params(description) == {"/g/n/a": 1, "/abs": 2}
