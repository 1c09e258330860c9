"""``rtcf_canopen/Cia402System``: CiA 402 drives over CANopen as one hardware component.

Named as ros2_canopen names its C++ plugin (``canopen_ros2_control/Cia402System``) under
this package's prefix, the pluginlib way: a URDF written for ros2_canopen changes its
``<plugin>`` and its bus parameters, not its structure. See docs/canopen.md.

The lifecycle: ``on_configure`` opens the bus and brings every drive up over SDO
(:mod:`._bringup`; an absent drive is one error naming its node id and the bus);
``on_activate`` takes every drive to OPERATION ENABLED with its target at its actual
position (no jump; :mod:`._stepping`); ``on_deactivate`` (and so a shutdown from active)
quick-stops, then disables the voltage (SWITCH ON DISABLED), as ros2_canopen's halt and
shutdown do; ``on_error`` sends the quick stop once and closes the bus. In the loop
``read`` drains the bus without waiting (:mod:`._exchange`), converts (:mod:`._units`)
and checks (:mod:`._watch`); ``write`` sends the RPDOs and the SYNC, both only every n-th
cycle (``sync_period``; :mod:`._cadence`). ``on_configure`` checks the bus load
(:mod:`._busload`). No thread.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import canopen

import rtcf
from rtcf import CallbackReturn, ReturnType
from rtcf._core._hardware_layout import InterfaceDescription, describe  # not public yet

from . import _cia402
from ._bringup import DriveError, close, open_drives
from ._busload import BusLoad
from ._cadence import SyncCadence
from ._config import SystemConfig
from ._exchange import Exchange
from ._stepping import Stepper
from ._units import EXTRA_STATES, Units
from ._watch import DriveWatch

_OK, _ERROR = ReturnType.OK, ReturnType.ERROR


class Cia402System(rtcf.SystemInterface):
    """CiA 402 drives on one CAN bus (see the module's docstring)."""

    def on_init(self, info: rtcf.HardwareInfo) -> CallbackReturn:
        try:
            self.config = SystemConfig.from_info(info)
        except ValueError as exc:
            self.logger.error("hardware '%s': %s", info.name, exc)
            return CallbackReturn.ERROR
        self.drives = self.config.drives
        self.network: canopen.Network | None = None
        self.exchange: Exchange | None = None
        self._active = False
        return CallbackReturn.SUCCESS

    def export_unlisted_state_interface_descriptions(self) -> list[InterfaceDescription]:
        """Per joint: its drive's statusword, CiA 402 state (0 to 7: NOT READY TO SWITCH
        ON ... FAULT), the cycles since its TPDOs last all came (0: fresh), its stale
        cycles in all, and the last EMCY's error code."""
        return [describe(d.joint, name) for d in self.drives for name in EXTRA_STATES]

    @property
    def bus_name(self) -> str:
        return str(self.config.bus)

    # ------------------------------------------------------------------ lifecycle

    def on_configure(self, previous_state: Any) -> CallbackReturn:
        try:
            self.network, layouts = open_drives(self.config)
        except DriveError as exc:
            self.logger.error("hardware '%s': %s", self.name, exc)
            return CallbackReturn.ERROR
        assert self.network.bus is not None
        try:
            ex = self.exchange = Exchange(self.network.bus, layouts)
        except ValueError as exc:  # drives mapped unlike each other
            self.logger.error("hardware '%s': on bus %s, %s", self.name, self.bus_name, exc)
            self._close()
            return CallbackReturn.ERROR
        self.sync = SyncCadence(self.logger, self.name, self.config, BusLoad.of(layouts))
        if not self.sync.at_configure(self.info.rw_rate):
            self._close()
            return CallbackReturn.ERROR
        if self.config.bus.filters_in_kernel:  # the loop then sees its drives' frames only
            self.network.bus.set_filters(ex.filters())
        units = self.units = Units(self, self.drives, ex)
        self.watch = DriveWatch(self.logger, self.name, self.drives, self.bus_name,
                                self.config.max_stale_cycles)
        self.stepper = Stepper(ex, self.watch, lambda: units.to_states(self._active))
        self._mode_of = [d.mode for d in self.drives]
        ex.mode[:] = self._mode_of
        ex.controlword[:] = _cia402.CW_DISABLE_VOLTAGE
        # a first exchange: the states are the drives' from configure on
        ex.send_rpdos()
        ex.send_sync()
        if not ex.collect(0.1):
            self.watch.missing(ex, "after its bring-up")
        units.to_states(False)
        self.logger.info("hardware '%s': %d CiA 402 drive(s) on %s: %s", self.name,
                         len(self.drives), self.bus_name, ", ".join(
                             f"node {d.node_id} ({d.joint}, {_cia402.MODE_NAMES[d.mode]})"
                             for d in self.drives))
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state: Any) -> CallbackReturn:
        ex = self.exchange
        assert ex is not None
        ex.mode[:] = self._mode_of
        state = self.stepper.step_all(_cia402.OPERATION_ENABLED, self.config.activate_timeout)
        if state:
            self.logger.error("hardware '%s': %s did not reach OPERATION ENABLED within "
                              "%.1f s: %s", self.name, self.bus_name,
                              self.config.activate_timeout, state)
            return CallbackReturn.ERROR
        self.units.hold()
        ex.controlword[:] = _cia402.CW_ENABLE_OPERATION  # held by every write
        self._active = True
        self.logger.info("hardware '%s': %d drive(s) in OPERATION ENABLED", self.name, ex.n)
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state: Any) -> CallbackReturn:
        self._active = False
        self.safe_stop()
        if self.exchange is not None:
            self.watch.report(self.exchange)
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
        if self.exchange is not None:
            self.stepper.safe_state(wait=False)
            self.watch.report(self.exchange)
        self._close()
        return CallbackReturn.SUCCESS

    def safe_stop(self) -> None:
        """Bring the drives to a safe state now (quick stop, then voltage off)."""
        if self.exchange is not None:
            self.stepper.safe_state(wait=True)

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
                        self.exchange.mode[d] = self._mode_of[d]
                        # the new mode starts from where the drive is
                        if self.units.has_position:
                            self.units.targets["position"][d] = self.exchange.position[d]
        return _OK

    # ------------------------------------------------------------------ the loop

    def read(self, time: float, period: float) -> ReturnType:
        ex = self.exchange
        if ex is None:
            return _ERROR
        ex.drain()
        ex.finish_cycle()
        active = self._active
        units = self.units
        units.to_states(active)
        if not self.watch.check(ex, active, units.state_bytes):
            return _ERROR
        if not active:
            # write does not run while inactive: keep the drives answering (state only)
            due = self.sync.tick(period)
            if due:
                if due < 0:
                    return _ERROR
                ex.send_rpdos()
                ex.send_sync()
        return _OK

    def write(self, time: float, period: float) -> ReturnType:
        ex = self.exchange
        if ex is None:
            return _ERROR
        self.units.to_targets()  # every write: the RPDO sent with the SYNC has the newest
        due = self.sync.tick(period)
        if due:
            if due < 0:
                return _ERROR
            ex.send_rpdos()  # only with the SYNC: the drives act on them at the SYNC
            ex.send_sync()
        return _OK

    def _close(self, pre_operational: bool = False) -> None:
        network, self.network, self.exchange = self.network, None, None
        if network is not None:
            close(network, pre_operational)
