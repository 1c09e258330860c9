"""rtcf launch's other nodes as processes (_cli._other_nodes, no ROS needed): a node
that ignores SIGINT gets SIGTERM after the grace period, one that ignores both gets
SIGKILL; an early exit is one line, and calls for the loop's end only with
on_exit="shutdown"; output="screen" lines come prefixed as ros2 launch prefixes them."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from rtcf._cli._other_nodes import OtherNodes
from rtcf._core._errors import Location
from rtcf._core._params import ParameterStore
from rtcf._launch._description import NodeDescription

SCRIPT = """#!/bin/sh
trap '{on_int}' INT
trap '{on_term}' TERM
echo "up $*"
{body}
"""


def prefix(root: Path, scripts: dict[str, str]) -> dict[str, str]:
    index = root / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "shells").write_text("")
    (root / "lib" / "shells").mkdir(parents=True)
    for name, text in scripts.items():
        path = root / "lib" / "shells" / name
        path.write_text(text)
        path.chmod(0o755)
    return {"AMENT_PREFIX_PATH": str(root), "PATH": "/usr/bin:/bin"}


def node(name: str, exe: str, line: int, **kw) -> NodeDescription:
    return NodeDescription("shells", exe, name, "/", Location("b.launch.xml", line), "ros2", **kw)


# a loop of short sleeps, so that a trap runs at once
LOOP = "while true; do sleep 0.05; done"


def test_sigint_then_sigterm_then_sigkill_as_launch_does(tmp_path: Path) -> None:
    env = prefix(tmp_path, {
        "polite": SCRIPT.format(on_int="echo bye; exit 0", on_term="exit 9", body=LOOP),
        "stubborn": SCRIPT.format(on_int="echo no", on_term="echo bye; exit 7", body=LOOP),
        "deaf": SCRIPT.format(on_int="", on_term="", body=LOOP),
    })
    said: list[str] = []
    written: list[tuple[str, bool]] = []
    nodes = OtherNodes([node("a", "polite", 2, output="screen"),
                        node("b", "stubborn", 3, output="screen"),
                        node("c", "deaf", 4)],
                       ParameterStore(), say=said.append,
                       write=lambda text, err: written.append((text, err)),
                       environ=env, timeouts=(0.5, 0.5))
    nodes.start()
    time.sleep(0.3)
    started = time.monotonic()
    nodes.stop()
    assert time.monotonic() - started < 3.0
    assert said[-3:] == [
        "node /a: stopped (sent SIGINT), exited with code 0",
        "node /b: stopped (sent SIGINT, SIGTERM), exited with code 7",
        "node /c: stopped (sent SIGINT, SIGTERM, SIGKILL), was ended by SIGKILL (exit code -9)",
    ]
    # output="screen": stdout on the screen, prefixed [<exec>-<N>]; args before --ros-args
    assert ("[polite-1] up --ros-args -r __node:=a -r __ns:=/", False) in written
    assert ("[polite-1] bye", False) in written and ("[stubborn-2] no", False) in written
    assert not any(text.startswith("[deaf-3]") for text, _ in written)  # output="log"


def test_an_early_exit_is_one_line_and_ends_the_loop_only_when_required(
    tmp_path: Path,
) -> None:
    env = prefix(tmp_path, {
        "quits": "#!/bin/sh\nexit 3\n",
        "runs": SCRIPT.format(on_int="exit 0", on_term="exit 0", body=LOOP),
    })
    shutdown = threading.Event()
    said: list[str] = []
    nodes = OtherNodes([node("q", "quits", 5), node("r", "runs", 6)], ParameterStore(),
                       say=said.append, environ=env, on_shutdown=shutdown.set)
    nodes.start()

    def reported() -> bool:
        return any(line.startswith("b.launch.xml:5: node /q (shells/quits, pid ")
                   and "exited with code 3" in line and line.endswith("; the loop goes on")
                   for line in said)

    deadline = time.monotonic() + 10.0  # its exit is noticed, however loaded the machine
    while not reported() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert reported(), said
    assert not shutdown.is_set()  # not required: the loop goes on
    nodes.stop()
    assert nodes.shutdown_by is None

    said.clear()
    written: list[str] = []
    nodes = OtherNodes([node("q", "quits", 5, on_exit="shutdown"),
                        node("r", "runs", 6, output="screen")],
                       ParameterStore(), say=said.append, environ=env,
                       write=lambda text, err: written.append(text), on_shutdown=shutdown.set)
    nodes.start()
    assert shutdown.wait(5.0)
    # /r's trap is set before it says "up": a SIGINT before that would end the shell
    # itself (exit code -2), which is the shell's doing, not the stop's
    deadline = time.monotonic() + 10.0
    while not any(t.startswith("[runs-") and " up " in t for t in written):
        assert time.monotonic() < deadline, written
        time.sleep(0.02)
    nodes.stop()
    assert nodes.shutdown_by == "/q"
    assert any("exited with code 3" in line and line.endswith("stopping the loop")
               for line in said), said
    assert "node /r: stopped (sent SIGINT), exited with code 0" in said


def test_a_missing_package_and_a_ros1_node_are_one_line_each(tmp_path: Path) -> None:
    env = prefix(tmp_path, {})
    said: list[str] = []
    ros1 = NodeDescription("rospy_tutorials", "talker.py", "talker", "/",
                           Location("b.launch", 7), "ros1")
    nodes = OtherNodes([NodeDescription("nothere", "x", "n", "/", Location("b.launch.xml", 8),
                                        "ros2"), ros1],
                       ParameterStore(), say=said.append, environ=env)
    nodes.start()
    nodes.stop()
    assert len(said) == 2
    assert said[0].startswith("warning: b.launch.xml:8: node /n not started: package "
                              "'nothere' is not installed")
    assert said[1] == (
        "note: b.launch:7: node /talker (rospy_tutorials/talker.py) not started: rtcf launch "
        "starts the nodes of ROS 2 launch files; under ROS 1, roslaunch runs this file and "
        "starts it")
