"""rt_launcher's search for its runner (rtcf._ros1._nodes), without ROS."""

from rtcf._ros1._nodes import runner_candidates


def test_a_launcher_looks_for_its_runner_from_its_namespace_up_to_the_root() -> None:
    assert runner_candidates("/") == ["/rt_runner"]
    # the original's <group ns="rtcf">: the runner beside its launchers comes first
    assert runner_candidates("/rtcf/") == ["/rtcf/rt_runner", "/rt_runner"]
    # arm.launch: launchers in <group ns="arm">, the runner at the top
    assert runner_candidates("/robot/arm") == [
        "/robot/arm/rt_runner", "/robot/rt_runner", "/rt_runner"]
    assert runner_candidates("/a/", "runner") == ["/a/runner", "/runner"]
