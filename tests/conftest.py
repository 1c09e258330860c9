"""Checks that hold for the whole test session."""

import pytest

from ._proc import rtcf_shm_names


@pytest.fixture(scope="session", autouse=True)
def _no_name_in_dev_shm():
    """rtcf's shared memory is anonymous: no test may leave, or find, a name in /dev/shm."""
    assert rtcf_shm_names() == [], "rtcf segments in /dev/shm before the tests started"
    yield
    assert rtcf_shm_names() == [], "the test session left rtcf segments in /dev/shm"
