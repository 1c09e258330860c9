"""The --ros-args remap rules an rt_launcher hands to its runner (no ROS needed)."""

from rtcf._ros2._nodes import _ros_remaps, _spec, params_files


def test_remap_rules_for_all_nodes_and_for_this_node_only() -> None:
    argv = ["rt_launcher", "m", "C", "--ros-args", "-r", "__node:=tuned", "-r", "a:=/x",
            "--remap", "tuned:b:=/y", "-r", "other:c:=/z", "-r", "tuned:__ns:=/q",
            "-r", "rostopic://d:=/w", "--", "-r", "e:=/v"]
    assert _ros_remaps(argv, "tuned") == [("a", "/x"), ("b", "/y")]
    assert _ros_remaps(argv, "other") == [("a", "/x"), ("c", "/z")]


def test_nested_parameter_names_become_a_tree() -> None:
    spec, _ = _spec({"module": "m", "class": "C", "name": "n", "param.gains.kp": 1.5,
                     "param.gain": 2.0})
    assert dict(spec.params) == {"gains/kp": 1.5, "gain": 2.0}


def test_params_files_of_ros_args() -> None:
    # another option's value is never taken for one (-p's, here), nor what is outside
    argv = ["rt_runner", "--params-file", "no.yaml", "--ros-args", "-r", "__node:=r",
            "--params-file", "a.yaml", "-p", "--params-file", "--params-file", "b.yaml",
            "--", "--params-file", "c.yaml"]
    assert params_files(argv) == ["a.yaml", "b.yaml"]
