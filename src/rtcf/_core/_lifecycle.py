"""A component's lifecycle: the states and transitions of a ROS 2 managed node.

Every component has the state machine of a ROS 2 lifecycle node (the one of
``rcl_lifecycle``, which ros2_control's controllers have too), with its numbers and
labels, so that the ROS 2 bridge can answer the standard ``lifecycle_msgs`` services
without translating, and the core still imports no middleware:

::

                      configure                 activate
    unconfigured ───────────────▶ inactive ───────────────▶ active
         ▲        ◀─────────────            ◀───────────────   │
         │            cleanup                  deactivate       │
         │                                                      │
         │  error processing:   (any primary state) ── shutdown ──▶ finalized
         └──── cleanup succeeded         a hook raised ─▶ errorprocessing ─▶ finalized
                                                           (cleanup failed too)

What each transition runs (in the runner, between two iterations while the loop
runs, or at once between runs):

* ``configure`` (unconfigured → inactive): the ``configure`` hook, again. It must
  declare the same ports and tunable parameters as the first time: the wiring, the
  middleware mapping and the tools' view of the parameters were made for them.
  It gets the same port and tunable objects back (values kept). A component loaded
  unconfigured (``ComponentSpec.unconfigured``) runs its first ``configure`` here:
  its ports and tunables are declared then, and the graph is resolved again.
* ``cleanup`` (inactive → unconfigured): ``cleanup``.
* ``activate`` (inactive → active): ``start``; then the component's ``update`` is
  in the schedule from the next iteration on.
* ``deactivate`` (active → inactive): the component leaves the schedule, then
  ``stop`` runs. Its outputs are no longer written; readers see ``OLD_DATA``.
* ``shutdown`` (any primary state → finalized): ``stop`` if active, ``cleanup`` if
  configured. A finalized component stays loaded, and never runs again.

Results follow ROS 2's design: a hook that returns nothing or True succeeds; one
that returns False fails and the component goes back to the state it started from
(a failed ``shutdown`` still ends in finalized, as in rcl); one that raises is an
error, and error processing follows. rtcf has no ``on_error`` hook: error
processing takes the component out of the schedule and runs ``cleanup`` (unless
``cleanup`` was what raised); if that succeeds the component is unconfigured and
may be configured again, otherwise it is finalized.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

# primary states and transition states (lifecycle_msgs/msg/State)
UNKNOWN = 0
UNCONFIGURED = 1
INACTIVE = 2
ACTIVE = 3
FINALIZED = 4
CONFIGURING = 10
CLEANINGUP = 11
SHUTTINGDOWN = 12
ACTIVATING = 13
DEACTIVATING = 14
ERRORPROCESSING = 15

STATE_LABELS = {
    UNKNOWN: "unknown",
    UNCONFIGURED: "unconfigured",
    INACTIVE: "inactive",
    ACTIVE: "active",
    FINALIZED: "finalized",
    CONFIGURING: "configuring",
    CLEANINGUP: "cleaningup",
    SHUTTINGDOWN: "shuttingdown",
    ACTIVATING: "activating",
    DEACTIVATING: "deactivating",
    ERRORPROCESSING: "errorprocessing",
}

# the transitions one asks for (lifecycle_msgs/msg/Transition): id -> (label, from, via)
CONFIGURE = 1
CLEANUP = 2
ACTIVATE = 3
DEACTIVATE = 4
UNCONFIGURED_SHUTDOWN = 5
INACTIVE_SHUTDOWN = 6
ACTIVE_SHUTDOWN = 7

REQUESTS: dict[int, tuple[str, int, int]] = {
    CONFIGURE: ("configure", UNCONFIGURED, CONFIGURING),
    CLEANUP: ("cleanup", INACTIVE, CLEANINGUP),
    ACTIVATE: ("activate", INACTIVE, ACTIVATING),
    DEACTIVATE: ("deactivate", ACTIVE, DEACTIVATING),
    UNCONFIGURED_SHUTDOWN: ("shutdown", UNCONFIGURED, SHUTTINGDOWN),
    INACTIVE_SHUTDOWN: ("shutdown", INACTIVE, SHUTTINGDOWN),
    ACTIVE_SHUTDOWN: ("shutdown", ACTIVE, SHUTTINGDOWN),
}

SUCCESS, FAILURE, ERROR = "success", "failure", "error"
REFUSED = "refused"  # not a transition at all: unknown, or not available from the state
# the answer to a transition of a STRICT switch that failed elsewhere: not made, or made
# and undone in the same iteration (rtcf._core._switching); ``end`` is where it is now
UNDONE = "undone"
RESULT_LABELS = {
    SUCCESS: "transition_success",
    FAILURE: "transition_failure",
    ERROR: "transition_error",
}

# how a transition state ends: (state, result) -> (transition id, goal state)
RESULTS: dict[tuple[int, str], tuple[int, int]] = {
    (CONFIGURING, SUCCESS): (10, INACTIVE),
    (CONFIGURING, FAILURE): (11, UNCONFIGURED),
    (CONFIGURING, ERROR): (12, ERRORPROCESSING),
    (CLEANINGUP, SUCCESS): (20, UNCONFIGURED),
    (CLEANINGUP, FAILURE): (21, INACTIVE),
    (CLEANINGUP, ERROR): (22, ERRORPROCESSING),
    (ACTIVATING, SUCCESS): (30, ACTIVE),
    (ACTIVATING, FAILURE): (31, INACTIVE),
    (ACTIVATING, ERROR): (32, ERRORPROCESSING),
    (DEACTIVATING, SUCCESS): (40, INACTIVE),
    (DEACTIVATING, FAILURE): (41, ACTIVE),
    (DEACTIVATING, ERROR): (42, ERRORPROCESSING),
    (SHUTTINGDOWN, SUCCESS): (50, FINALIZED),
    (SHUTTINGDOWN, FAILURE): (51, FINALIZED),
    (SHUTTINGDOWN, ERROR): (52, ERRORPROCESSING),
    (ERRORPROCESSING, SUCCESS): (60, UNCONFIGURED),
    (ERRORPROCESSING, FAILURE): (61, FINALIZED),
    (ERRORPROCESSING, ERROR): (62, FINALIZED),
}


@dataclass(frozen=True)
class TransitionDescription:
    """One edge of the state machine (lifecycle_msgs/msg/TransitionDescription)."""

    transition: int
    label: str
    start: int
    goal: int


def available_transitions(state: int) -> list[TransitionDescription]:
    """What may be asked for in ``state``; the goal is the transition state, as rcl says."""
    return [
        TransitionDescription(tid, label, start, via)
        for tid, (label, start, via) in REQUESTS.items()
        if start == state
    ]


def transition_graph() -> list[TransitionDescription]:
    """Every edge: the requests, then how each transition state ends (rcl's order)."""
    out: list[TransitionDescription] = []
    for tid, (label, start, via) in REQUESTS.items():
        out.append(TransitionDescription(tid, label, start, via))
        if tid in (UNCONFIGURED_SHUTDOWN, INACTIVE_SHUTDOWN):
            continue  # the three shutdowns share their ends, listed after the last one
        for result in (SUCCESS, FAILURE, ERROR):
            end_id, goal = RESULTS[(via, result)]
            out.append(TransitionDescription(end_id, RESULT_LABELS[result], via, goal))
    for result in (SUCCESS, FAILURE, ERROR):
        end_id, goal = RESULTS[(ERRORPROCESSING, result)]
        out.append(TransitionDescription(end_id, RESULT_LABELS[result], ERRORPROCESSING, goal))
    return out


def resolve_transition(state: int, transition: int | str) -> int | None:
    """The id of the transition asked for (by id or by label) if ``state`` allows it.

    A label wins over an id, as in rclpy's change_state service: ``shutdown`` is 5, 6
    or 7 depending on the state.
    """
    for d in available_transitions(state):
        if (isinstance(transition, str) and d.label == transition) or d.transition == transition:
            return d.transition
    return None


@dataclass(frozen=True)
class TransitionOutcome:
    """What a transition did: where it started and ended, and how each step went.

    ``result`` is that of the transition's hooks (``success``, ``failure``,
    ``error``), or ``refused`` when nothing ran (an unknown transition, one the state
    does not allow, a component that is not loaded); ``error_result`` is that of error
    processing after an error. ``reason`` says why it did not succeed.
    """

    transition: int  # the id asked for (0 when refused)
    start: int
    end: int
    result: str
    error_result: str = ""
    reason: str = ""

    @property
    def ok(self) -> bool:
        return self.result == SUCCESS

    @property
    def end_label(self) -> str:
        return STATE_LABELS[self.end]

    @property
    def label(self) -> str:
        return REQUESTS[self.transition][0] if self.transition in REQUESTS else ""

    def steps(self) -> list[TransitionDescription]:
        """The state changes, one per transition_event a ROS 2 lifecycle node publishes."""
        if self.result in (REFUSED, UNDONE):  # (an answer, never told as a change)
            return []
        label, start, via = REQUESTS[self.transition]
        steps = [TransitionDescription(self.transition, label, start, via)]
        end_id, goal = RESULTS[(via, self.result)]
        steps.append(TransitionDescription(end_id, RESULT_LABELS[self.result], via, goal))
        if goal == ERRORPROCESSING:
            end_id, goal = RESULTS[(ERRORPROCESSING, self.error_result or FAILURE)]
            steps.append(
                TransitionDescription(
                    end_id, RESULT_LABELS[self.error_result or FAILURE], ERRORPROCESSING, goal
                )
            )
        return steps

    def describe(self) -> str:
        """One line for a log: what was asked, where it ended, and why if it failed."""
        if self.result in (REFUSED, UNDONE):
            return f"{self.result}: {self.reason}"
        what = self.label or f"transition {self.transition}"
        line = f"{what}: {STATE_LABELS[self.start]} -> {STATE_LABELS[self.end]}"
        if self.result != SUCCESS:
            line += f" ({self.result}"
            line += f", error processing: {self.error_result})" if self.error_result else ")"
        return line + (f": {self.reason}" if self.reason else "")


def refused(state: int, reason: str) -> TransitionOutcome:
    return TransitionOutcome(0, state, state, REFUSED, reason=reason)


def inferred(start: int, end: int) -> TransitionOutcome | None:
    """The successful transition that leads from ``start`` to ``end``, if one does: for
    a change seen from outside (the runner activating what it loaded, say)."""
    for tid, (_, first, via) in REQUESTS.items():
        if first == start and RESULTS[(via, SUCCESS)][1] == end:
            return TransitionOutcome(tid, start, end, SUCCESS)
    return None


STATE_IDS = {label: state for state, label in STATE_LABELS.items()}


# -- crossing from the worker to the supervisor ------------------------------------------

OUTCOME_RECORD_SIZE = 1024
OUTCOME_RING_RECORDS = 64
# request (0: a change nobody asked for), transition, start, end, result, error result,
# then the lengths of the component's name and of the reason
_OUTCOME = struct.Struct("<qBBBBBHH")
_RESULT_CODES = {SUCCESS: 1, FAILURE: 2, ERROR: 3, REFUSED: 4, UNDONE: 5, "": 0}
_CODE_RESULTS = {v: k for k, v in _RESULT_CODES.items()}


def encode_outcome(request: int, outcome: TransitionOutcome, component: str = "") -> bytes:
    """One record of the outcome ring (the reason is cut to fit)."""
    name = component.encode("utf-8", "replace")[:255]
    room = OUTCOME_RECORD_SIZE - _OUTCOME.size - len(name)
    reason = outcome.reason.encode("utf-8", "replace")[:room]
    return (
        _OUTCOME.pack(
            request,
            outcome.transition,
            outcome.start,
            outcome.end,
            _RESULT_CODES[outcome.result],
            _RESULT_CODES[outcome.error_result],
            len(name),
            len(reason),
        )
        + name
        + reason
    )


def decode_outcome(record: bytes | memoryview) -> tuple[int, str, TransitionOutcome]:
    """(request, component, outcome) of an outcome record."""
    request, tid, start, end, result, error, nc, nr = _OUTCOME.unpack_from(record)
    at = _OUTCOME.size
    component = bytes(record[at : at + nc]).decode("utf-8", "replace")
    reason = bytes(record[at + nc : at + nc + nr]).decode("utf-8", "replace")
    return request, component, TransitionOutcome(
        tid, start, end, _CODE_RESULTS[result], _CODE_RESULTS[error], reason
    )
