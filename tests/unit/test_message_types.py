"""Message classes by type name, one lookup for both ROS versions and the recordings."""

import sys

import pytest

from rtcf._core._message_types import STD_MESSAGES, message_class, std_type_name


@pytest.fixture
def fake_msgs(tmp_path, monkeypatch):
    pkg = tmp_path / "fake_msgs" / "msg"
    pkg.mkdir(parents=True)
    (tmp_path / "fake_msgs" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("class Thing:\n    pass\n\nnot_a_class = 3\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield
    for name in ("fake_msgs", "fake_msgs.msg"):
        sys.modules.pop(name, None)


def test_both_name_forms_find_the_generated_class(fake_msgs):
    ros2 = message_class("fake_msgs/msg/Thing")
    assert ros2.__name__ == "Thing" and ros2.__module__ == "fake_msgs.msg"
    assert message_class("fake_msgs/Thing") is ros2  # ROS 1's form, the same module


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("fake_msgs/msg/Nope", "message type fake_msgs.msg.Nope is not available (module "),
        ("nowhere_msgs/msg/X", "message type nowhere_msgs.msg.X is not available (No module"),
        ("fake_msgs/msg/not_a_class", "message type fake_msgs.msg.not_a_class is not a class"),
        ("Float64", "message type 'Float64' is not pkg/msg/Type (ROS 2) or pkg/Type (ROS 1)"),
        ("a/b/c/d", "message type 'a/b/c/d' is not pkg/msg/Type"),
    ],
)
def test_a_missing_or_malformed_type_is_one_lookup_error(fake_msgs, name, message):
    with pytest.raises(LookupError) as info:
        message_class(name)
    assert str(info.value).startswith(message)


def test_primitive_kinds_travel_as_std_msgs_on_both_versions():
    assert std_type_name("float") == "std_msgs/msg/Float64"
    assert std_type_name("float_array", ros2=False) == "std_msgs/Float64MultiArray"
    assert sorted(STD_MESSAGES) == ["bool", "float", "float_array", "int", "str"]
