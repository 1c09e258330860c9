"""ros2_controllers' controllers as rtcf components, on ros2_controllers' interfaces.

Each controller reads and writes ros2_control's interfaces as ports of float64
arrays, one value per joint in the order of its ``joints`` parameter (``position``,
``velocity``, ``effort``; commands ``position_command``, ``velocity_command``,
``effort_command``), and speaks to the outside with the topics, actions, message
types and parameter names of the ros2_controllers controller it stands for (its
``ros2_control_type``). A team's ros2_controllers YAML file configures them
unchanged: ``<param from="controllers.yaml"/>`` in a ROS 2 launch file.

Load them from a launch file with ``args="rtcf_controllers ClassName"``
(docs/controllers.md). Their message types are imported when they are configured, so
importing this package needs no ROS.
"""

from .diff_drive_controller import DiffDriveController
from .forward_command_controller import (
    ForwardCommandController,
    JointGroupEffortController,
    JointGroupPositionController,
    JointGroupVelocityController,
)
from .joint_state_broadcaster import JointStateBroadcaster
from .joint_trajectory_controller import JointTrajectoryController
from .pid_controller import PidController

__all__ = [
    "DiffDriveController",
    "ForwardCommandController",
    "JointGroupEffortController",
    "JointGroupPositionController",
    "JointGroupVelocityController",
    "JointStateBroadcaster",
    "JointTrajectoryController",
    "PidController",
]
