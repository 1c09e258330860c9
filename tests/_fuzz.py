"""What the fuzz tests share; no middleware here.

Of the ROS 1 and ROS 2 fuzz tests of a runner's services: the generated text and names,
hypothesis's settings, the loads each runner must refuse without stopping its loop, and
the tally of what was sent and how it was answered. How a request is made and sent is
each middleware's own (tests/ros*/test_fuzz_services.py).

Of the fuzz tests of the controllers' topics and actions
(tests/ros2/controllers/test_fuzz_controllers.py): the extreme numbers, and the reading
of a runner's log lines for the refusals a controller names (one record per refused
message, or a record that counts those it left out within its throttling interval).
"""

import math
import re
import string
import sys
import time

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

SHORT_TEXT = st.text(max_size=40)
LONG_TEXT = st.text(string.printable, min_size=200, max_size=6000)
NAMES = st.text(string.ascii_letters + "_", min_size=1, max_size=12)
# of rtcf_examples: a well-formed load of one now and then must load, run and unload
CLASSES = ("Mimo", "Identity", "Pid")
GOOD_CLASSES = st.sampled_from(CLASSES)
GOOD_NAMES = NAMES.map(lambda n: f"f_{n}")

# a thousand requests in a fixed order (derandomized), one runner for them all
THOUSAND = settings(max_examples=1000, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow, HealthCheck.data_too_large])

# a load the runner accepts (and holds through the fuzz), in a middleware's neutral fields
GOOD = {"module": "rtcf_examples", "class": "Mimo", "name": "held"}
# each refused by the service itself, with what its answer says
REFUSALS = {
    "no such module": (dict(GOOD, module="no_such_module", name="a"),
                       "module 'no_such_module' is not found"),
    "no such submodule": (dict(GOOD, module="rtcf_examples.nope", name="b"),
                          "module 'rtcf_examples.nope' is not found"),
    "no such class": (dict(GOOD, **{"class": "NoSuchClass", "name": "c"}),
                      "has no class 'NoSuchClass'"),
    "a doubled name": (GOOD, "is already loaded"),
    "a malformed remap": (dict(GOOD, name="d", remaps=["x"]), "remap"),
}


# numbers a controller meets from a careless or hostile client: each not finite one
# must be refused; the huge ones are finite but beyond any joint's limit or any speed;
# the tiny ones (subnormal, the smallest normal) are ordinary values near zero
NON_FINITE = (math.nan, math.inf, -math.inf)
HUGE = (1e300, -1e300, sys.float_info.max, -sys.float_info.max, 1e20, -1e20)
TINY = (5e-324, -5e-324, 2.5e-320, sys.float_info.min, -sys.float_info.min)
EXTREME = st.sampled_from(NON_FINITE + HUGE + TINY)
NOT_FINITE = st.sampled_from(NON_FINITE)

# a line of `rtcf launch`'s console: [LEVEL] #iteration [/component]: message
LOG_LINE = re.compile(r"^\[(?P<level>[A-Z]+)\](?: #\d+)? \[(?P<component>[^\]]+)\]: (?P<text>.*)$")
# what the controllers' throttled records add: those left out since the last one
MORE_LIKE_IT = re.compile(r"\((\d+) more like it\b")


def component_lines(lines, component):
    """The messages of ``component``'s log records among a console's ``lines``."""
    return [m["text"] for m in map(LOG_LINE.match, lines) if m and m["component"] == component]


def refused_count(texts):
    """How many refusals ``texts`` (records, each naming one) stand for: one each, plus
    the count a throttled record carries of those it left out."""
    return sum(1 + sum(int(n) for n in MORE_LIKE_IT.findall(t)) for t in texts)


class Tally:
    """One runner under fuzz: its process, what it answered, and its "loop starts" as
    its /diagnostics say them (``seen`` is the subscriber's callback)."""

    def __init__(self, proc, runner):
        self.proc = proc
        self.runner = runner  # its full name, /fuzzed
        self.answered = 0
        self.accepted = 0  # may each have stopped the loop and started it again
        self.refused = 0
        self.loaded = set()
        self.first = None  # the loop starts when the fuzz began
        self.starts = []  # (when, loop starts)

    def seen(self, msg):
        """A diagnostic_msgs/DiagnosticArray (of either middleware)."""
        self.starts.extend((time.monotonic(), int(kv.value)) for s in msg.status
                           if s.name == f"rtcf: {self.runner}" for kv in s.values
                           if kv.key == "loop starts")

    def loop_starts(self, wait_until):
        """The runner's "loop starts", as its /diagnostics say it after this moment;
        ``wait_until(predicate, timeout)`` waits as the middleware's test can."""
        asked = time.monotonic()
        assert wait_until(lambda: any(t > asked for t, _ in self.starts), 30), (
            "no /diagnostics from the runner")
        return self.starts[-1][1]

    def load_answered(self, name, ok, message, *, one_line_within=None):
        """A load's answer: in one line (in its first ``one_line_within`` characters, if
        given) without a traceback; counted as loaded or refused."""
        assert "Traceback" not in message, message
        assert "\n" not in message[:one_line_within], message
        if ok:
            self.loaded.add(name)
        else:
            self.refused += 1

    def check_both_kinds_came(self):
        assert self.answered >= 1000
        # loads that ran, and many refused (malformed, unknown, doubled)
        assert len(self.loaded) >= 10 and self.refused >= 100, (len(self.loaded), self.refused)

    def check_restarted_only_when_accepted(self, wait_until):
        """Stopped and started again only for what was accepted, not for the many refusals."""
        now = self.loop_starts(wait_until)
        assert now - self.first <= self.accepted + 1, (
            self.first, self.starts[-1], self.accepted, self.refused)

    def unload_all(self, unload):
        """Each accepted load unloads (``unload(name)`` gives ok and the message), or was
        unloaded by the fuzz already."""
        for name in sorted(self.loaded):
            ok, message = unload(name)
            assert ok or "is not loaded" in message, (name, message)
