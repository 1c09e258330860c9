"""rtcf: real-time control components in Python, wired like ROS nodes, run in one loop."""

from ._clock import Clock as Clock
from ._clock import MonotonicClock as MonotonicClock
from ._clock import SimClock as SimClock
from ._component import Component as Component
from ._errors import ComponentError as ComponentError
from ._errors import ConfigurationError as ConfigurationError
from ._errors import GraphError as GraphError
from ._errors import LaunchError as LaunchError
from ._errors import RtcfError as RtcfError
from ._graph import Graph as Graph
from ._log import LogLevel as LogLevel
from ._params import ParameterStore as ParameterStore
from ._ports import FlowStatus as FlowStatus
from ._ports import InputPort as InputPort
from ._ports import OutputPort as OutputPort
from ._runner import ComponentSpec as ComponentSpec
from ._runner import Runner as Runner
from ._runner import RunResult as RunResult
from ._settings import RunnerSettings as RunnerSettings

__version__ = "0.1.0"
