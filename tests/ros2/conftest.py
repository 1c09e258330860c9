"""ROS 2 tests: a real rclpy graph (the Jazzy wheels), rtcf started as separate processes.

These run in .venv-ros2 (bash scripts/test sets it up). Without rclpy they fail at
import: missing ROS in CI is a failure, not a skip.
"""

import itertools
import os
import random
from pathlib import Path

import pytest
import rclpy  # fails loudly where ROS 2 is missing

from .. import _proc
from .._proc import env_with

FIXTURES = Path(__file__).parent / "fixtures"
# the middleware-free components, some of which both middlewares' tests load
COMMON = Path(__file__).parents[1] / "integration" / "fixtures"

# a domain of its own, so parallel runs on one machine do not see each other's topics
DOMAIN = str(random.randint(1, 200))
_COUNT = itertools.count()
os.environ["ROS_DOMAIN_ID"] = DOMAIN


def rtcf_env():
    env = env_with(FIXTURES, COMMON)
    env["ROS_DOMAIN_ID"] = DOMAIN
    return env


def start_rtcf(*args):
    return _proc.start_rtcf(rtcf_env(), *args)


@pytest.fixture
def ros_node():
    """A node of the test's own, in a context of its own."""
    from rclpy.node import Node

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node(f"rtcf_test_{os.getpid()}_{next(_COUNT)}", context=context)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
