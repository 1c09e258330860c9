"""ROSCONSOLE_CONFIG_FILE: log4cxx properties read as rosconsole applies them."""

import pytest

from rtcf._core._log import LogLevel
from rtcf._launch._rosconsole import ENV, RosconsoleConfig, from_environment

DBG, INF, WRN, ERR, FTL = (int(x) for x in LogLevel)


def config(text, environ=None):
    c = RosconsoleConfig()
    c.read_text(text, "test.conf", environ or {})
    return c


def test_the_examples_file_sets_one_component_to_debug():
    from pathlib import Path

    import rtcf_examples

    path = Path(rtcf_examples.__file__).parent / "rosconsole_settings.conf"
    c = RosconsoleConfig()
    assert c.read_file(path, {})
    assert c.component_level("/loggin_test", WRN) == DBG
    assert c.component_level("/other", WRN) == INF  # log4j.logger.ros=INFO over the default
    assert c.warnings == []


@pytest.mark.parametrize(
    ("line", "component", "level"),
    [
        ("log4j.logger.ros.rtcf.arm.sum1=DEBUG", "/arm/sum1", DBG),  # rtcf's name
        ("log4j.logger.ros.rtcf./arm/sum1=DEBUG", "/arm/sum1", DBG),  # the original's
        ("log4j.logger.ros.rtcf.arm=ERROR", "/arm/sum1", ERR),  # its namespace
        ("log4j.logger.ros.rtcf.arm=ERROR", "/leg/sum1", INF),  # another namespace
        ("log4j.logger.ros.rtcf=WARN", "/arm/sum1", WRN),
        ("log4j.logger.ros=FATAL", "/sum1", FTL),
        ("log4j.logger.ros.rtcf.arm.sum10=DEBUG", "/arm/sum1", INF),  # no prefix matching
        ("log4j.logger.ros.rtcf.sum1=DEBUG", "/arm/sum1", INF),  # not its full name
        ("log4j.category.ros.rtcf.sum1=debug", "/sum1", DBG),  # category, lower case
        ("log4j.logger.ros.rtcf.sum1 = WARN, A1, A2", "/sum1", WRN),  # appenders ignored
        ("log4j.logger.ros.rtcf.sum1:ERROR", "/sum1", ERR),  # ':' separates too
        ("log4j.logger.ros.rtcf.sum1 TRACE", "/sum1", DBG),  # and whitespace
        ("log4j.logger.ros.rtcf.sum1=OFF", "/sum1", FTL),
        ("log4j.rootLogger=DEBUG", "/sum1", INF),  # rosconsole sets ros itself
        ("log4j.logger.ros.rtcf.sum1=, A1", "/sum1", INF),  # appenders only: no level
    ],
)
def test_which_logger_gives_a_components_level(line, component, level):
    assert config(line).component_level(component, INF) == level


def test_the_most_specific_logger_wins_whatever_the_order():
    c = config("log4j.logger.ros.rtcf.arm.sum1=DEBUG\nlog4j.logger.ros.rtcf=ERROR\n"
               "log4j.logger.ros=FATAL\n")
    assert c.component_level("/arm/sum1", INF) == DBG
    assert c.component_level("/arm/sum2", INF) == ERR


def test_a_later_line_for_the_same_logger_wins_and_both_spellings_are_one_logger():
    c = config("log4j.logger.ros.rtcf.a=DEBUG\nlog4j.logger.ros.rtcf.a=ERROR\n")
    assert c.component_level("/a", INF) == ERR
    c = config("log4j.logger.ros.rtcf./a=DEBUG\nlog4j.logger.ros.rtcf.a=ERROR\n")
    assert c.component_level("/a", INF) == ERR
    c = config("log4j.logger.ros.rtcf.a=ERROR\nlog4j.logger.ros.rtcf./a=DEBUG\n")
    assert c.component_level("/a", INF) == DBG


def test_inherited_unsets_and_a_later_file_goes_over_an_earlier_one():
    c = config("log4j.logger.ros.rtcf.a=DEBUG\nlog4j.logger.ros.rtcf=WARN\n")
    c.read_text("log4j.logger.ros.rtcf.a=INHERITED\nlog4j.logger.ros.rtcf=ERROR\n", "2", {})
    assert c.component_level("/a", INF) == ERR
    assert c.sources == ["test.conf", "2"]


def test_threshold_raises_every_level():
    c = config("log4j.threshold=WARN\nlog4j.logger.ros.rtcf.a=DEBUG\n")
    assert c.component_level("/a", INF) == WRN
    assert c.component_level("/b", DBG) == WRN


def test_comments_continuations_and_variables():
    text = (
        "# log4j.logger.ros.rtcf.a=ERROR\n"
        "! log4j.logger.ros.rtcf.b=ERROR\n"
        "   \n"
        "level=WARN\n"
        "log4j.logger.ros.rtcf.c=${level}\n"
        "log4j.logger.ros.rtcf.d=${RTCF_TEST_LEVEL}\n"
        "log4j.logger.ros.rtcf.\\\n"
        "    e=ERROR\n"
    )
    c = config(text, {"RTCF_TEST_LEVEL": "debug"})
    assert [c.component_level(f"/{n}", INF) for n in "abcde"] == [INF, INF, WRN, DBG, ERR]


def test_an_unknown_level_is_reported_and_ignored():
    c = config("log4j.logger.ros.rtcf.a=DEBGU\n")
    assert c.component_level("/a", INF) == INF
    assert len(c.warnings) == 1 and "test.conf:1" in c.warnings[0] and "DEBGU" in c.warnings[0]


def test_from_environment_reads_ros_root_first_then_the_variable(tmp_path):
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "rosconsole.config").write_text(
        "log4j.logger.ros.rtcf.a=DEBUG\nlog4j.logger.ros.rtcf.b=DEBUG\n"
    )
    mine = tmp_path / "mine.conf"
    mine.write_text("log4j.logger.ros.rtcf.b=ERROR\n")
    assert from_environment({}) is None
    c = from_environment({"ROS_ROOT": str(tmp_path), ENV: str(mine)})
    assert c is not None
    assert (c.component_level("/a", INF), c.component_level("/b", INF)) == (DBG, ERR)


def test_an_unreadable_file_is_a_warning_not_an_error(tmp_path):
    c = from_environment({ENV: str(tmp_path / "missing.conf")})
    assert c is not None and c.sources == []
    assert "cannot read" in c.warnings[0] and "missing.conf" in c.warnings[0]
