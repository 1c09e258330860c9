"""The periodic timing and health summary both ROS bridges publish on /diagnostics.

Middleware-neutral: the bridges turn it into diagnostic_msgs of their ROS version,
whose classes (alike in both) they hand to :func:`diagnostic_array`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .._core._timing import TimingAggregate
    from ._supervisor import LiveStatus


@dataclass
class Health:
    """One DiagnosticStatus: WARN as soon as anything overran or was dropped."""

    warn: bool
    name: str
    message: str
    values: list[tuple[str, str]]


def health(runner: str, status: LiveStatus, aggregate: TimingAggregate) -> Health:
    def text(value: float | int) -> str:
        return f"{value:.1f}" if isinstance(value, float) else str(value)

    summary = aggregate.summary()
    values = [
        ("iterations", text(status.iterations)),
        ("overruns", text(status.overruns)),
        ("log records dropped", text(status.log_records_dropped)),
        ("timing rows dropped", text(aggregate.dropped)),
        ("component faults contained", text(status.faults)),
        ("loop starts", text(status.starts)),
        ("inputs past their deadline", ", ".join(status.past_deadline) or "none"),
        ("input deadlines passed", text(status.deadline_misses)),
        ("commands clamped to limits", text(status.commands_clamped)),
        ("commands refused (not finite)", text(status.commands_refused)),
    ]
    values.append(("access", status.access or "open: any request on its domain"))
    for label, stats in (("jitter", summary.jitter_us), ("calc", summary.calc_us)):
        for q in ("p50", "p99", "p999", "max"):
            if q in stats:
                values.append((f"{label} {q} [us]", text(stats[q])))
    for name, stats in summary.components_us.items():
        if "p999" in stats:
            values.append((f"{name} calc p999 [us]", text(stats["p999"])))
            values.append((f"{name} calc max [us]", text(stats["max"])))
    return Health(
        warn=bool(
            status.overruns or status.log_records_dropped or aggregate.dropped or status.faults
            or status.past_deadline or status.commands_refused
        ),
        name=f"rtcf: {runner}",
        message=(
            f"{status.iterations} iterations, {status.overruns} overruns, "
            + (f"{status.faults} faults contained, " if status.faults else "")
            + (
                f"past deadline: {', '.join(status.past_deadline)}, "
                if status.past_deadline else ""
            )
            + (
                f"commands clamped {status.commands_clamped}, refused "
                f"{status.commands_refused}, "
                if status.commands_clamped or status.commands_refused else ""
            )
            + f"jitter p99.9 {status.jitter_p999_us:.1f} us, "
            + f"calc p99.9 {status.calc_p999_us:.1f} us"
        ),
        values=values,
    )


def diagnostic_array(h: Health, hardware_id: str, msgs: Any) -> Any:
    """``h`` as a DiagnosticArray of ``msgs``, the ``diagnostic_msgs.msg`` module of the
    bridge's ROS (ROS 1 and ROS 2 build it alike); its header's stamp is the bridge's."""
    status = msgs.DiagnosticStatus
    return msgs.DiagnosticArray(status=[status(
        level=status.WARN if h.warn else status.OK,
        name=h.name,
        message=h.message,
        hardware_id=hardware_id,
        values=[msgs.KeyValue(key=k, value=v) for k, v in h.values],
    )])
