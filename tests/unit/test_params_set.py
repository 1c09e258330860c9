"""params.set(): written back where parameters live, never from update()."""

from __future__ import annotations

import pytest

import rtcf


class Writer(rtcf.Component):
    def configure(self) -> None:
        self.params.set("~offset", 0.25)
        self.params.set("relative/name", 3)
        self.out = self.add_output("x", float)

    def update(self) -> None:
        if self.iteration == 2:
            self.params.set("~late", True)
        self.out.write(self.params.get("~offset"))


def test_set_writes_the_launch_level_store_and_tells_the_observer() -> None:
    store = rtcf.ParameterStore()
    seen: list[tuple[str, object]] = []
    store.observer = lambda name, value: seen.append((name, value))
    runner = rtcf.Runner(rtcf.RunnerSettings(frequency=10.0), clock=rtcf.SimClock(),
                         parameters=store)
    runner.load(rtcf.ComponentSpec("w", Writer, namespace="/ns"))
    assert store.get("/ns/w/offset") == 0.25 and store.get("/ns/relative/name") == 3
    assert seen == [("/ns/w/offset", 0.25), ("/ns/relative/name", 3)]
    with pytest.raises(rtcf.ComponentError, match=r"params.set\('~late'\) in update\(\): "
                       "setting a parameter is not real-time safe"):
        runner.run(5)
    assert not store.has("/ns/w/late")
    runner.shutdown()
