"""``rtcf_canopen/Cia402System``: CiA 402 drives over CANopen as one hardware component.

Named as ros2_canopen names its C++ plugin (``canopen_ros2_control/Cia402System``) under
this package's prefix, the pluginlib way: a URDF written for ros2_canopen changes its
``<plugin>`` and its bus parameters, not its structure. See docs/canopen.md.

Per ``<joint>``: one drive (``node_id``, ``eds``/``dcf``, unit scales). The
``<hardware>``'s ``<param>``s: ``interface`` (socketcan, udp_multicast, virtual),
``channel``, ``bitrate``, ``sync_period`` (µs; default: the hardware's period),
``activate_timeout`` (s), ``max_stale_cycles``, ``sdo_timeout`` (s).

The lifecycle: ``on_configure`` opens the bus and brings every drive up over SDO (an
absent drive is one error naming its node id and the bus); ``on_activate`` takes every
drive to OPERATION ENABLED with its target at its actual position (no jump);
``on_deactivate`` (and so a shutdown from active) quick-stops, then disables the
voltage (SWITCH ON DISABLED), as ros2_canopen's halt and shutdown do; ``on_error`` sends
the quick stop once and closes the bus. In the loop ``read`` drains the bus without
waiting and ``write`` sends the RPDOs and SYNC (:mod:`._exchange`); no thread.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Sequence
from typing import Any

import canopen
import numpy as np

import rtcf
from rtcf import CallbackReturn, ReturnType
from rtcf._core._hardware_layout import InterfaceDescription, describe  # not public yet

from . import _cia402
from ._bus import INTERFACES, BusSettings, quiet_canopen
from ._drive import DriveConfig, DriveError, bring_up, config_of
from ._exchange import (
    CONTROLWORD,
    MODE,
    POSITION,
    TARGET_POSITION,
    TARGET_TORQUE,
    TARGET_VELOCITY,
    TORQUE,
    VELOCITY,
    Exchange,
)

EXTRA_STATES = ("statusword", "cia402_state", "pdo_age", "stale_cycles", "error_code")
_INT32 = (-(2**31), 2**31 - 1)
_INT16 = (-(2**15), 2**15 - 1)
_OK, _ERROR = ReturnType.OK, ReturnType.ERROR


class Cia402System(rtcf.SystemInterface):
    """CiA 402 drives on one CAN bus (see the module's docstring)."""

    def on_init(self, info: rtcf.HardwareInfo) -> CallbackReturn:
        p = info.hardware_parameters
        interface = p.get("interface", "socketcan")
        if interface not in INTERFACES:
            self.logger.error("hardware '%s': interface %r is not one of %s", info.name,
                              interface, ", ".join(INTERFACES))
            return CallbackReturn.ERROR
        default_channel = {"socketcan": "can0", "udp_multicast": "239.74.163.2",
                           "virtual": "rtcf"}[interface]
        try:
            self.bus_settings = BusSettings(interface, p.get("channel", default_channel),
                                            int(p.get("bitrate", "1000000")))
            self.sync_period_us = float(p.get("sync_period", "0"))
            self.activate_timeout = float(p.get("activate_timeout", "1.0"))
            self.max_stale_cycles = int(p.get("max_stale_cycles", "100"))
            self.sdo_timeout = float(p.get("sdo_timeout", "0.3"))
            self.drives: list[DriveConfig] = [
                config_of(j.name, dict(j.parameters),
                          tuple(i.name for i in j.command_interfaces),
                          tuple(i.name for i in j.state_interfaces))
                for j in info.joints]
        except ValueError as exc:
            self.logger.error("hardware '%s': %s", info.name, exc)
            return CallbackReturn.ERROR
        ids = [d.node_id for d in self.drives]
        if len(set(ids)) != len(ids):
            self.logger.error("hardware '%s': two joints have the same node_id (%s)",
                              info.name, ", ".join(map(str, ids)))
            return CallbackReturn.ERROR
        self.network: canopen.Network | None = None
        self.exchange: Exchange | None = None
        self._active = False
        return CallbackReturn.SUCCESS

    def export_unlisted_state_interface_descriptions(self) -> list[InterfaceDescription]:
        """Per joint: its drive's statusword, CiA 402 state (0 to 7: NOT READY TO SWITCH
        ON ... FAULT), the cycles since its TPDOs last all came (0: fresh), its stale
        cycles in all, and the last EMCY's error code."""
        return [describe(d.joint, name) for d in self.drives
                for name in EXTRA_STATES]

    @property
    def bus_name(self) -> str:
        return str(self.bus_settings)

    # ------------------------------------------------------------------ lifecycle

    def on_configure(self, previous_state: Any) -> CallbackReturn:
        self._sync_every = 0  # SYNC every n-th write: n from the first write's period
        self._writes = 0
        try:
            bus = self.bus_settings.open()
        except Exception as exc:  # python-can's errors, OSError: the bus is not there
            self.logger.error(
                "hardware '%s': cannot open the CAN bus %s (%s): check the interface and "
                "channel parameters (on a robot: interface socketcan, channel can0, the "
                "link up with 'ip link set can0 up type can bitrate %d')", self.name,
                self.bus_name, exc, self.bus_settings.bitrate)
            return CallbackReturn.ERROR
        network = self.network = canopen.Network(bus)  # no connect(): no Notifier thread
        layouts = []
        try:
            with quiet_canopen():
                for drive in self.drives:
                    layouts.append(bring_up(network, drive, self.bus_name))
        except DriveError as exc:
            self.logger.error("hardware '%s': %s", self.name, exc)
            self._close()
            return CallbackReturn.ERROR
        ex = self.exchange = Exchange(bus, layouts)
        n = len(self.drives)
        self._bind_views(n)
        for d, drive in enumerate(self.drives):
            ex.out[d][MODE] = drive.mode
            ex.out[d][CONTROLWORD] = _cia402.CW_DISABLE_VOLTAGE
        # a first exchange: the states are the drives' from configure on
        ex.send_rpdos()
        ex.send_sync()
        if not ex.collect(0.1):
            self._log_missing("after its bring-up")
        self._convert()
        self._fault_logged = [False] * n
        self._silent_logged = [False] * n
        self.logger.info("hardware '%s': %d CiA 402 drive(s) on %s: %s", self.name, n,
                         self.bus_name, ", ".join(
                             f"node {d.node_id} ({d.joint}, {_cia402.MODE_NAMES[d.mode]})"
                             for d in self.drives))
        return CallbackReturn.SUCCESS

    def _bind_views(self, n: int) -> None:
        """Views and scratch arrays, once (nothing is allocated in read and write)."""
        self._pos = self._state_view("position")
        self._vel = self._state_view("velocity")
        self._eff = self._state_view("effort")
        self._cmd = {k: self._command_view(k) for k in ("position", "velocity", "effort")}
        self._extra = {k: self.joint_states(k) for k in EXTRA_STATES}
        drv = self.drives
        self._scale = {
            "position": (np.array([d.scale_pos_from_dev for d in drv]),
                         np.array([d.offset_pos_from_dev for d in drv]),
                         np.array([d.scale_pos_to_dev for d in drv]),
                         np.array([d.offset_pos_to_dev for d in drv])),
            "velocity": (np.array([d.scale_vel_from_dev for d in drv]), np.zeros(n),
                         np.array([d.scale_vel_to_dev for d in drv]), np.zeros(n)),
            "effort": (np.array([d.scale_eff_from_dev for d in drv]), np.zeros(n),
                       np.array([d.scale_eff_to_dev for d in drv]), np.zeros(n)),
        }
        self._tmp = np.empty(n)
        self._finite = np.empty(n, dtype=bool)
        self._targets = {k: np.zeros(n) for k in ("position", "velocity", "effort")}
        self._mode_of = [d.mode for d in self.drives]

    def _state_view(self, interface: str) -> tuple[np.ndarray, np.ndarray] | None:
        """(the joints' view, the drives they are) for a state interface, or None."""
        joints = self.joints_with_state(interface)
        if not joints:
            return None
        where = np.array([i for i, d in enumerate(self.drives) if d.joint in joints], np.intp)
        return self.joint_states(interface), where

    def _command_view(self, interface: str) -> tuple[np.ndarray, np.ndarray] | None:
        joints = self.joints_with_command(interface)
        if not joints:
            return None
        where = np.array([i for i, d in enumerate(self.drives) if d.joint in joints], np.intp)
        return self.joint_commands(interface), where

    def on_activate(self, previous_state: Any) -> CallbackReturn:
        ex = self.exchange
        assert ex is not None
        for d in range(ex.n):
            ex.out[d][MODE] = self._mode_of[d]
        state = self._step_all(_cia402.OPERATION_ENABLED, self.activate_timeout)
        if state:
            self.logger.error("hardware '%s': %s did not reach OPERATION ENABLED within "
                              "%.1f s: %s", self.name, self.bus_name, self.activate_timeout,
                              state)
            return CallbackReturn.ERROR
        # hold where the drives are: the commands start at the actual values
        for kind, view in self._cmd.items():
            if view is not None:
                if kind == "position" and self._pos is not None:
                    view[0][:] = self._pos[0]
                else:
                    view[0][:] = 0.0
        self._targets["velocity"][:] = 0.0
        self._targets["effort"][:] = 0.0
        self._active = True
        self.logger.info("hardware '%s': %d drive(s) in OPERATION ENABLED", self.name, ex.n)
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state: Any) -> CallbackReturn:
        self._active = False
        self._safe_state(wait=True)
        self._report()
        return CallbackReturn.SUCCESS

    def on_cleanup(self, previous_state: Any) -> CallbackReturn:
        self._close(pre_operational=True)
        return CallbackReturn.SUCCESS

    def on_shutdown(self, previous_state: Any) -> CallbackReturn:
        self._close(pre_operational=True)
        return CallbackReturn.SUCCESS

    def on_error(self, previous_state: Any) -> CallbackReturn:
        """In the loop (a failed read or write): quick stop sent once, not waited for;
        the bus closed (configure opens it again)."""
        self._active = False
        self._safe_state(wait=False)
        self._report()
        self._close()
        return CallbackReturn.SUCCESS

    def safe_stop(self) -> None:
        """Bring the drives to a safe state now (quick stop, then voltage off)."""
        self._safe_state(wait=True)

    # ---------------------------------------------------------- command mode switch

    def prepare_command_mode_switch(self, start_interfaces: Sequence[str],
                                    stop_interfaces: Sequence[str]) -> ReturnType:
        for key in start_interfaces:
            joint, _, interface = key.rpartition("/")
            if any(d.joint == joint for d in self.drives) and \
                    interface not in _cia402.MODE_OF_INTERFACE:
                return _ERROR
        return _OK

    def perform_command_mode_switch(self, start_interfaces: Sequence[str],
                                    stop_interfaces: Sequence[str]) -> ReturnType:
        """A controller claims position, velocity or effort: the drive's mode of operation
        follows in the next RPDO (it is mapped: no SDO in the loop)."""
        for key in start_interfaces:
            joint, _, interface = key.rpartition("/")
            for d, drive in enumerate(self.drives):
                if drive.joint == joint and interface in _cia402.MODE_OF_INTERFACE:
                    self._mode_of[d] = _cia402.MODE_OF_INTERFACE[interface]
                    if self.exchange is not None:
                        self.exchange.out[d][MODE] = self._mode_of[d]
                        # the new mode starts from where the drive is
                        if self._pos is not None:
                            self._targets["position"][d] = self.exchange.raw[d, POSITION]
        return _OK

    # ------------------------------------------------------------------ the loop

    def read(self, time: float, period: float) -> ReturnType:
        ex = self.exchange
        if ex is None:
            return _ERROR
        ex.drain()
        ex.finish_cycle()
        self._convert()
        sws = ex.statusword
        age = ex.age
        active = self._active
        limit = self.max_stale_cycles
        failed = False
        for d in range(ex.n):
            sw = sws[d]
            if sw & 0x4F in (0x08, 0x0F):  # FAULT, FAULT REACTION ACTIVE
                if not self._fault_logged[d]:
                    self._fault_logged[d] = True
                    self._log_fault(d, sw)
                failed = True
            elif active and age[d] == 0 and sw & 0x6F != 0x27:
                self.logger.error(
                    "hardware '%s': %s left OPERATION ENABLED: it is %s (statusword "
                    "0x%04X); the hardware goes through on_error", self.name,
                    self.drives[d].name(self.bus_name), _cia402.STATE_NAMES[
                        _cia402.state_of(sw)], sw)
                failed = True
            a = age[d]
            if a:
                if a == 10 and not self._silent_logged[d]:
                    self._silent_logged[d] = True
                    self.logger.warning(
                        "hardware '%s': %s has not answered SYNC for %d cycles; its last "
                        "values are kept and marked old (pdo_age)", self.name,
                        self.drives[d].name(self.bus_name), a)
                if limit and a >= limit:
                    self.logger.error(
                        "hardware '%s': %s has not answered SYNC for %d cycles (%d stale in "
                        "all): check its power and wiring; the hardware goes through "
                        "on_error", self.name, self.drives[d].name(self.bus_name), a,
                        ex.stale[d])
                    failed = True
            elif self._silent_logged[d]:
                self._silent_logged[d] = False
                self.logger.info("hardware '%s': %s answers again (%d stale cycles in all)",
                                 self.name, self.drives[d].name(self.bus_name), ex.stale[d])
        if failed:
            return _ERROR
        if not active:
            # write does not run while inactive: keep the drives answering (state only)
            ex.send_rpdos()
            ex.send_sync()
        return _OK

    def write(self, time: float, period: float) -> ReturnType:
        ex = self.exchange
        if ex is None:
            return _ERROR
        out = ex.out
        for kind, field, bounds in (("position", TARGET_POSITION, _INT32),
                                    ("velocity", TARGET_VELOCITY, _INT32),
                                    ("effort", TARGET_TORQUE, _INT16)):
            view = self._cmd[kind]
            if view is None:
                continue
            values, where = view
            target = self._targets[kind]
            _, _, to_dev, off = self._scale[kind]
            tmp = self._tmp[:len(where)] if len(where) != ex.n else self._tmp
            np.multiply(values, to_dev[where] if len(where) != ex.n else to_dev, out=tmp)
            np.add(tmp, off[where] if len(where) != ex.n else off, out=tmp)
            np.isfinite(tmp, out=self._finite[:len(where)])
            np.clip(tmp, bounds[0], bounds[1], out=tmp)
            np.rint(tmp, out=tmp)
            if len(where) == ex.n:
                np.copyto(target, tmp, where=self._finite)
            else:
                for j in range(len(where)):
                    if self._finite[j]:
                        target[where[j]] = tmp[j]
            for d in range(ex.n):
                out[d][field] = int(target[d])
        for d in range(ex.n):
            out[d][CONTROLWORD] = _cia402.CW_ENABLE_OPERATION
        ex.send_rpdos()
        self._writes += 1
        if not self._sync_every:
            self._sync_every = max(1, round(self.sync_period_us * 1e-6 / period)) \
                if self.sync_period_us > 0 and period > 0 else 1
        if self._writes % self._sync_every == 0:
            ex.send_sync()
        return _OK

    # --------------------------------------------------------------- internals

    def _convert(self) -> None:
        """The drives' raw values into the state interfaces (SI units)."""
        ex = self.exchange
        assert ex is not None
        raw = ex.raw
        for view, col, kind in ((self._pos, POSITION, "position"),
                                (self._vel, VELOCITY, "velocity"),
                                (self._eff, TORQUE, "effort")):
            if view is None:
                continue
            values, where = view
            frm, off, _, _ = self._scale[kind]
            if len(where) == ex.n:
                np.multiply(raw[:, col], frm, out=values)
                np.add(values, off, out=values)
            else:
                for j in range(len(where)):
                    d = where[j]
                    values[j] = raw[d, col] * frm[d] + off[d]
        extra = self._extra
        sw, st, age, stale, code = (extra["statusword"], extra["cia402_state"],
                                    extra["pdo_age"], extra["stale_cycles"], extra["error_code"])
        for d in range(ex.n):
            s = ex.statusword[d]
            sw[d] = s
            st[d] = _cia402.state_of(s)
            age[d] = ex.age[d]
            stale[d] = ex.stale[d]
            code[d] = ex.emcy_code[d]
        if self._active:
            return
        # not commanding: the targets follow the drives (so activation holds them)
        if self._pos is not None:
            np.copyto(self._targets["position"], raw[:, POSITION])
            for d in range(ex.n):
                ex.out[d][TARGET_POSITION] = int(raw[d, POSITION])

    def _step_all(self, target: int, timeout: float) -> str:
        """Step every drive toward ``target`` with SYNC exchanges (outside the loop);
        "" when all are there, else which are not."""
        ex = self.exchange
        assert ex is not None
        deadline = time.monotonic() + timeout
        while True:
            ex.send_rpdos()
            ex.send_sync()
            ex.collect(0.02)
            self._convert()
            states = [_cia402.state_of(sw) for sw in ex.statusword]
            if all(s == target for s in states):
                return ""
            if time.monotonic() > deadline:
                return "; ".join(
                    f"node {self.drives[d].node_id} is {_cia402.STATE_NAMES[s]} (statusword "
                    f"0x{ex.statusword[d]:04X}{self._code_text(d)})"
                    for d, s in enumerate(states) if s != target)
            for d, s in enumerate(states):
                ex.out[d][CONTROLWORD] = _cia402.step_toward(s, target, ex.out[d][CONTROLWORD])

    def _safe_state(self, wait: bool) -> None:
        """Quick stop, then voltage off (wait: step until there, 0.5 s at most each)."""
        ex = self.exchange
        if ex is None:
            return
        for d in range(ex.n):
            s = _cia402.state_of(ex.statusword[d])
            ex.out[d][CONTROLWORD] = _cia402.step_toward(s, _cia402.QUICK_STOP_ACTIVE)
        if not wait:
            ex.send_rpdos()
            ex.send_sync()
            return
        quick = self._step_all(_cia402.QUICK_STOP_ACTIVE, 0.5)
        if quick and "FAULT" not in quick:
            self.logger.warning("hardware '%s': quick stop not confirmed: %s", self.name, quick)
        off = self._step_all(_cia402.SWITCH_ON_DISABLED, 0.5)
        if off and "FAULT" not in off:
            self.logger.warning("hardware '%s': not SWITCH ON DISABLED: %s", self.name, off)

    def _report(self) -> None:
        ex = self.exchange
        if ex is None or not ex.syncs:
            return
        for d, drive in enumerate(self.drives):
            self.logger.info(
                "hardware '%s': node %d: %d SYNCs, %d stale cycles (%.2f %%), longest %d",
                self.name, drive.node_id, ex.syncs, ex.stale[d],
                100.0 * ex.stale[d] / ex.syncs, ex.longest[d])

    def _code_text(self, d: int) -> str:
        ex = self.exchange
        assert ex is not None
        code = ex.emcy_code[d]
        return f", EMCY error code 0x{code:04X}" if code else ""

    def _log_fault(self, d: int, sw: int) -> None:
        ex = self.exchange
        assert ex is not None
        code = ex.emcy_code[d]
        said = (f"error code 0x{code:04X} (error register 0x{ex.emcy_register[d]:02X}) from "
                "its EMCY" if code else "no EMCY received")
        self.logger.error(
            "hardware '%s': %s is in FAULT (statusword 0x%04X, %s); the hardware goes "
            "through on_error: clear the cause, then configure and activate it again "
            "(set_hardware_component_state: the activation resets the fault)", self.name,
            self.drives[d].name(self.bus_name), sw, said)

    def _log_missing(self, when: str) -> None:
        ex = self.exchange
        assert ex is not None
        for d, drive in enumerate(self.drives):
            if ex.age[d]:
                self.logger.warning("hardware '%s': %s sent no TPDO %s", self.name,
                                    drive.name(self.bus_name), when)

    def _close(self, pre_operational: bool = False) -> None:
        network, self.network, self.exchange = self.network, None, None
        if network is None:
            return
        if pre_operational:
            with contextlib.suppress(Exception), quiet_canopen():
                for node in network.values():
                    node.nmt.state = "PRE-OPERATIONAL"
        bus = network.bus
        network.bus = None
        if bus is not None:
            with contextlib.suppress(Exception):
                bus.shutdown()

