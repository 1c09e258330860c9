"""diff_drive_controller's parts that need no ROS: the speed limiter (control_toolbox's
RateLimiter, as ros2_controllers' SpeedLimiter uses it) and the odometry."""

import math

import pytest

from rtcf_controllers._odometry import Odometry
from rtcf_controllers._speed_limiter import SpeedLimiter


def test_no_limits_leave_the_velocity_as_it_is():
    assert SpeedLimiter().limit(7.5, -3.0, 2.0, 0.01) == 7.5


def test_velocity_is_clamped_and_an_unset_minimum_is_minus_the_maximum():
    limiter = SpeedLimiter(max_velocity=1.0)
    assert limiter.limit(2.0, 0.0, 0.0, 0.01) == 1.0
    assert limiter.limit(-2.0, 0.0, 0.0, 0.01) == -1.0
    assert SpeedLimiter(min_velocity=-0.2, max_velocity=1.0).limit(-2.0, 0.0, 0.0, 0.01) == -0.2


def test_acceleration_bounds_follow_the_direction_of_the_last_velocity():
    limiter = SpeedLimiter(max_acceleration=1.0, max_deceleration=-2.0)
    assert limiter.limit(1.0, 0.5, 0.5, 0.1) == pytest.approx(0.6)  # forward, speeding up
    assert limiter.limit(0.0, 0.5, 0.5, 0.1) == pytest.approx(0.3)  # forward, braking
    # reverse: max_acceleration_reverse defaults to -max_acceleration, and
    # max_deceleration_reverse to max_acceleration
    assert limiter.limit(-1.0, -0.5, -0.5, 0.1) == pytest.approx(-0.6)
    assert limiter.limit(0.0, -0.5, -0.5, 0.1) == pytest.approx(-0.4)
    assert limiter.limit(-1.0, 0.0, 0.0, 0.1) == pytest.approx(-0.1)  # from standstill


def test_jerk_is_limited_only_while_the_change_grows():
    limiter = SpeedLimiter(max_jerk=10.0)
    # dv0 = 0.1, dv = 0.9: the change of acceleration is held to 10 * 0.1**2
    assert limiter.limit(1.0, 0.1, 0.0, 0.1) == pytest.approx(0.3)
    # dv0 = 0.2, dv = 0.1: the acceleration falls, towards zero: not limited
    assert limiter.limit(0.6, 0.5, 0.3, 0.1) == 0.6


@pytest.mark.parametrize(
    "limits",
    [
        {"min_velocity": 1.0, "max_velocity": 0.5},
        {"max_acceleration": 1.0, "max_acceleration_reverse": 2.0},
        {"max_acceleration": 1.0, "max_deceleration": 3.0},
        {"min_jerk": 1.0, "max_jerk": 0.5},
    ],
)
def test_inconsistent_limits_are_refused(limits):
    with pytest.raises(ValueError):
        SpeedLimiter(**limits)


def test_odometry_integrates_wheel_positions_along_the_arc():
    separation, radius = 0.3, 0.05
    odometry = Odometry(separation, radius, radius, window=10)
    assert not odometry.update(4.0, 4.0, 0.0)  # the first positions are the reference
    # a quarter turn about the left wheel: it stands still, the right one rolls
    # the quarter circle of radius `separation`
    right = 4.0 + (math.pi / 2 * separation) / radius
    steps = 100
    for k in range(1, steps + 1):
        assert odometry.update(4.0, 4.0 + (right - 4.0) * k / steps, 0.01 * k)
    # the base's centre, half a separation off the left wheel, ends a quarter turn on
    assert odometry.heading == pytest.approx(math.pi / 2)
    assert (odometry.x, odometry.y) == pytest.approx((separation / 2, separation / 2))
    assert odometry.angular == pytest.approx(math.pi / 2)  # rad per second
    assert odometry.linear == pytest.approx(math.pi / 2 * separation / 2)


def test_odometry_skips_intervals_too_short_and_averages_its_twist():
    odometry = Odometry(0.3, 0.05, 0.05, window=2)
    odometry.update_from_travel(0.0, 0.0, 0.0)
    assert not odometry.update_from_travel(0.1, 0.1, 0.00005)
    odometry.update_from_travel(0.01, 0.01, 0.01)  # 1 m/s
    odometry.update_from_travel(0.03, 0.03, 0.02)  # 3 m/s
    odometry.update_from_travel(0.05, 0.05, 0.03)  # 5 m/s: the window holds 3 and 5
    assert odometry.linear == pytest.approx(4.0)
    assert odometry.x == pytest.approx(0.09)


def test_open_loop_odometry_integrates_the_commands():
    odometry = Odometry(0.3, 0.05, 0.05, window=10)
    for k in range(101):
        odometry.update_open_loop(0.5, 0.0, 0.01 * k)
    assert (odometry.x, odometry.y, odometry.linear) == pytest.approx((0.5, 0.0, 0.5))
