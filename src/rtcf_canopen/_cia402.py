"""The CiA 402 drive profile: states from the statusword, the controlword that steps a
drive toward a target state, and the modes of operation.

Pure functions on integers, shared by the hardware plugin (the master's side) and the
simulated drive (the drive's side), and tested without a bus. The numbers are CiA 402's
(IEC 61800-7-201): the statusword's masks and the controlword's commands, as canopen's
``canopen.profiles.p402.State402`` lists them.
"""

from __future__ import annotations

# ----------------------------------------------------------------------------- states
NOT_READY_TO_SWITCH_ON = 0
SWITCH_ON_DISABLED = 1
READY_TO_SWITCH_ON = 2
SWITCHED_ON = 3
OPERATION_ENABLED = 4
QUICK_STOP_ACTIVE = 5
FAULT_REACTION_ACTIVE = 6
FAULT = 7

STATE_NAMES = (
    "NOT READY TO SWITCH ON", "SWITCH ON DISABLED", "READY TO SWITCH ON", "SWITCHED ON",
    "OPERATION ENABLED", "QUICK STOP ACTIVE", "FAULT REACTION ACTIVE", "FAULT",
)

# statusword (0x6041): (mask, value) per state, in the order they are tested
_STATUS = (
    (0x4F, 0x00, NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, SWITCH_ON_DISABLED),
    (0x6F, 0x21, READY_TO_SWITCH_ON),
    (0x6F, 0x23, SWITCHED_ON),
    (0x6F, 0x27, OPERATION_ENABLED),
    (0x6F, 0x07, QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, FAULT),
)
STATUSWORD_OF = {
    NOT_READY_TO_SWITCH_ON: 0x00, SWITCH_ON_DISABLED: 0x40, READY_TO_SWITCH_ON: 0x21,
    SWITCHED_ON: 0x23, OPERATION_ENABLED: 0x27, QUICK_STOP_ACTIVE: 0x07,
    FAULT_REACTION_ACTIVE: 0x0F, FAULT: 0x08,
}
SW_FAULT = 0x0008
SW_WARNING = 0x0080
SW_TARGET_REACHED = 0x0400

# ------------------------------------------------------------------------ controlword
CW_DISABLE_VOLTAGE = 0x0000
CW_QUICK_STOP = 0x0002
CW_SHUTDOWN = 0x0006
CW_SWITCH_ON = 0x0007
CW_ENABLE_OPERATION = 0x000F
CW_FAULT_RESET = 0x0080

# ------------------------------------------------------------------- modes (0x6060)
CSP = 8  # cyclic synchronous position
CSV = 9  # cyclic synchronous velocity
CST = 10  # cyclic synchronous torque
MODE_NAMES = {CSP: "cyclic synchronous position", CSV: "cyclic synchronous velocity",
              CST: "cyclic synchronous torque"}
MODE_OF_INTERFACE = {"position": CSP, "velocity": CSV, "effort": CST}
SUPPORTED_BIT = {CSP: 0x0080, CSV: 0x0100, CST: 0x0200}  # 0x6502 supported drive modes


def state_of(statusword: int) -> int:
    """The state a statusword says (NOT READY TO SWITCH ON for an unknown pattern)."""
    for mask, value, state in _STATUS:
        if statusword & mask == value:
            return state
    return NOT_READY_TO_SWITCH_ON


def is_fault(statusword: int) -> bool:
    """FAULT or FAULT REACTION ACTIVE."""
    return statusword & 0x4F in (0x08, 0x0F)


def step_toward(state: int, target: int, last_controlword: int = 0) -> int:
    """The controlword that takes a drive in ``state`` one transition toward ``target``
    (OPERATION ENABLED, QUICK STOP ACTIVE or SWITCH ON DISABLED).

    Toward OPERATION ENABLED the path is CiA 402's: fault reset (a rising edge of bit 7,
    so the word after a fault reset is a plain disable voltage), shutdown, switch on,
    enable operation; from QUICK STOP ACTIVE through SWITCH ON DISABLED, as canopen's
    ``BaseNode402`` and ros2_canopen's ``Motor402`` go. Toward QUICK STOP ACTIVE: quick
    stop from OPERATION ENABLED (the drive brakes on its quick-stop ramp and holds),
    disable voltage from the states before it. Toward SWITCH ON DISABLED: disable voltage.
    A drive in FAULT stays there unless the target is OPERATION ENABLED.
    """
    if state == target:
        return _holding(state, last_controlword)
    if state == FAULT:
        if target != OPERATION_ENABLED:
            return CW_DISABLE_VOLTAGE
        return CW_DISABLE_VOLTAGE if last_controlword & CW_FAULT_RESET else CW_FAULT_RESET
    if state in (NOT_READY_TO_SWITCH_ON, FAULT_REACTION_ACTIVE):
        return CW_DISABLE_VOLTAGE  # the drive moves on by itself
    if target == OPERATION_ENABLED:
        return {
            SWITCH_ON_DISABLED: CW_SHUTDOWN,
            READY_TO_SWITCH_ON: CW_SWITCH_ON,
            SWITCHED_ON: CW_ENABLE_OPERATION,
            QUICK_STOP_ACTIVE: CW_DISABLE_VOLTAGE,
        }.get(state, CW_DISABLE_VOLTAGE)
    if target == QUICK_STOP_ACTIVE:
        return CW_QUICK_STOP if state == OPERATION_ENABLED else CW_DISABLE_VOLTAGE
    return CW_DISABLE_VOLTAGE


def _holding(state: int, last_controlword: int) -> int:
    """The controlword that keeps a drive in ``state``."""
    if state == OPERATION_ENABLED:
        return CW_ENABLE_OPERATION
    if state == QUICK_STOP_ACTIVE:
        return CW_QUICK_STOP
    if state == SWITCHED_ON:
        return CW_SWITCH_ON
    if state == READY_TO_SWITCH_ON:
        return CW_SHUTDOWN
    return CW_DISABLE_VOLTAGE


def drive_transition(state: int, controlword: int) -> int:
    """The drive's side: the state a drive in ``state`` goes to on ``controlword`` (the
    simulated drive's state machine; FAULT only leaves on a fault reset's rising edge,
    which the caller detects, so here FAULT stays)."""
    cw = controlword & 0x8F
    if state in (FAULT, FAULT_REACTION_ACTIVE):
        return state
    if state == NOT_READY_TO_SWITCH_ON:
        return SWITCH_ON_DISABLED
    if cw & 0x02 == 0:  # disable voltage: from everywhere to SWITCH ON DISABLED
        return SWITCH_ON_DISABLED
    if cw & 0x06 == 0x02:  # quick stop (bit 2 low, bit 1 high)
        if state == OPERATION_ENABLED:
            return QUICK_STOP_ACTIVE
        if state == QUICK_STOP_ACTIVE:
            return QUICK_STOP_ACTIVE
        return SWITCH_ON_DISABLED
    low = cw & 0x0F
    if state == SWITCH_ON_DISABLED:
        return READY_TO_SWITCH_ON if low in (0x06, 0x0E) else state
    if state == READY_TO_SWITCH_ON:
        if low == 0x07:
            return SWITCHED_ON
        if low == 0x0F:  # switch on + enable operation: two transitions in one (3, 4)
            return OPERATION_ENABLED
        return state
    if state == SWITCHED_ON:
        if low == 0x0F:
            return OPERATION_ENABLED
        if low in (0x06, 0x0E):
            return READY_TO_SWITCH_ON
        return state
    if state == OPERATION_ENABLED:
        if low == 0x07:
            return SWITCHED_ON
        if low in (0x06, 0x0E):
            return READY_TO_SWITCH_ON
        return state
    if state == QUICK_STOP_ACTIVE:
        return OPERATION_ENABLED if low == 0x0F else state
    return state
