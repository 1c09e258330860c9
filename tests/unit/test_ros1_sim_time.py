"""Which use_sim_time a ROS 1 runner takes: its own ~use_sim_time, else the global one."""

import pytest

from rtcf._core._errors import RtcfError
from rtcf._core._params import ParameterStore
from rtcf._ros1._bridge import global_sim_time


@pytest.mark.parametrize(
    ("tree", "expected"),
    [
        ({}, None),  # nothing set: the runner's default
        ({"/use_sim_time": True}, True),
        ({"/use_sim_time": "true"}, True),  # a string from <param value="true" type="str">
        ({"/use_sim_time": 0}, False),
        ({"/use_sim_time": True, "/rt_runner/use_sim_time": False}, None),  # ~ rules
        ({"/use_sim_time": False, "/rt_runner/use_sim_time": True}, None),
        ({"/use_sim_time": True, "/other/use_sim_time": False}, True),  # not this runner's
    ],
)
def test_global_use_sim_time_where_the_runner_sets_none(tree, expected):
    assert global_sim_time(ParameterStore(tree), "/rt_runner") == expected


def test_a_namespaced_runner_looks_at_its_own_private_name():
    store = ParameterStore({"/use_sim_time": True, "/arm/rt_runner/use_sim_time": False})
    assert global_sim_time(store, "/arm/rt_runner") is None
    assert global_sim_time(store, "/rt_runner") is True


def test_a_global_use_sim_time_that_is_no_bool_is_an_error():
    with pytest.raises(RtcfError, match="/use_sim_time is 'maybe'"):
        global_sim_time(ParameterStore({"/use_sim_time": "maybe"}), "/rt_runner")
