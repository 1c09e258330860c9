"""rtcf: real-time control components in Python, wired like ROS nodes, run in one loop."""

from ._core._action_protocol import ActionEvent as ActionEvent
from ._core._action_protocol import ActionRequest as ActionRequest
from ._core._action_protocol import GoalStatus as GoalStatus
from ._core._actions import ActionServer as ActionServer
from ._core._cdr import Serialized as Serialized
from ._core._chaining import ChainableComponent as ChainableComponent
from ._core._clock import Clock as Clock
from ._core._clock import MonotonicClock as MonotonicClock
from ._core._clock import SimClock as SimClock
from ._core._command_limits import JointLimits as JointLimits
from ._core._component import Component as Component
from ._core._errors import ComponentError as ComponentError
from ._core._errors import ConfigurationError as ConfigurationError
from ._core._errors import GraphError as GraphError
from ._core._errors import LaunchError as LaunchError
from ._core._errors import RtcfError as RtcfError
from ._core._graph import Graph as Graph
from ._core._hardware import ActuatorInterface as ActuatorInterface
from ._core._hardware import CallbackReturn as CallbackReturn
from ._core._hardware import ReturnType as ReturnType
from ._core._hardware import SensorInterface as SensorInterface
from ._core._hardware import SystemInterface as SystemInterface
from ._core._log import LogLevel as LogLevel
from ._core._params import ParameterStore as ParameterStore
from ._core._ports import FlowStatus as FlowStatus
from ._core._ports import InputPort as InputPort
from ._core._ports import OutputPort as OutputPort
from ._core._rates import Rate as Rate
from ._core._robot_description import HardwareInfo as HardwareInfo
from ._core._runner import ComponentSpec as ComponentSpec
from ._core._runner import Runner as Runner
from ._core._runner import RunResult as RunResult
from ._core._settings import RunnerSettings as RunnerSettings

__version__ = "0.1.0"
