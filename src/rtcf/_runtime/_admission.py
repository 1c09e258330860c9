"""Who may make requests of a runner: its lock and its allowed modules.

A runner's lock (``settings.lock``) applies once its loop has run (a launch file's
components load before); its ``allowed_modules`` refuse a module before anything
imports it (docs/security.md).
"""

from __future__ import annotations

from .._core._errors import RtcfError
from .._core._lane_names import MAIN_LANE
from .._core._loader import absent_component_class
from .._core._settings import RunnerSettings
from ._loaded import LoadedComponents
from ._request_fields import RequestRefused


def access_of(settings: RunnerSettings, locked: bool | None = None) -> str:
    """Who may change a runner, in a line: its lock (and whether it applies yet) and
    its allowed modules; empty when it is open to any request."""
    parts = []
    if settings.lock != "none":
        when = "" if locked is None else (" (applies)" if locked else
                                          " (applies once the loop runs)")
        parts.append(f"lock {settings.lock}{when}")
    if settings.allowed_modules:
        parts.append("allowed modules " + " ".join(settings.allowed_modules))
    return "; ".join(parts)


class Admission:
    """Whether a runner admits a request: its lock (once its loop has run) and its
    allowed modules, and, for a middleware's service, whether the component named
    is loaded or not as the request needs."""

    def __init__(self, settings: RunnerSettings, name: str, loaded: LoadedComponents) -> None:
        self.settings = settings
        self.name = name
        self._loaded = loaded
        # the runner's lock (settings.lock) applies once its loop has run: a launch
        # file's components load before (docs/security.md)
        self.locked = False

    def loop_started(self, lane: str) -> None:
        if lane == MAIN_LANE and self.settings.lock != "none":
            self.locked = True

    @property
    def access(self) -> str:
        """Who may change the runner, in a line (LiveStatus.access)."""
        return access_of(self.settings, self.locked)

    def refuse_if_locked(self, what: str, locks: tuple[str, ...] = ("structure", "all")) -> None:
        if self.locked and self.settings.lock in locks:
            raise RequestRefused(
                f"runner {self.name} is locked (lock {self.settings.lock}): it refuses "
                f"{what} while its loop runs; its launch file or parameters set lock"
            )

    def refuse_module(self, module: str, of: str = "") -> None:
        """RequestRefused if allowed_modules refuse ``module`` (before anything imports
        it); ``of``: the component it is for, to name in the refusal."""
        if not self.settings.allows_module(module):
            whose = f" of {of[:80]!r}" if of else ""
            raise RequestRefused(
                f"runner {self.name}: module {module[:80]!r}{whose} is not in its "
                f"allowed_modules ({' '.join(self.settings.allowed_modules)})"
            )

    def admits(
        self,
        what: str,
        module: str | None = None,
        component: str | None = None,
        class_name: str | None = None,
    ) -> None:
        """RequestRefused if the runner's lock or allowed_modules refuse a request, or a
        load names a component already loaded, or a module or class that does not exist
        (:func:`absent_component_class`, nothing imported), or an unload one that is not
        loaded, so that a middleware's service answers it without stopping the loop (any
        thread). ``what``: "loads", "unloads", "lifecycle transitions" or "tunables"."""
        if what == "loads" and component is not None and component in self._loaded.components:
            raise RequestRefused(
                f"component {component[:80]!r}: is already loaded; give each component a "
                "unique name"
            )
        if module is not None:
            self.refuse_module(module)
        if what == "tunables":
            self.refuse_if_locked("changes of tunable parameters", ("all",))
        else:
            self.refuse_if_locked(what)
        if what == "unloads" and component is not None:
            try:
                self._loaded.find(component)
            except RtcfError as exc:
                raise RequestRefused(str(exc)) from None
        if module and class_name:  # after the lock: a locked runner tells nothing of it
            problem = absent_component_class(module, class_name, component=component or "")
            if problem:
                raise RequestRefused(problem)
