"""ros2_controllers' controllers as rtcf components, on ros2_controllers' interfaces.

Each controller reads and writes ros2_control's interfaces as ports of float64
arrays, one value per joint in the order of its ``joints`` parameter (``position``,
``velocity``, ``effort``; commands ``position_command``, ``velocity_command``,
``effort_command``), and speaks to the outside with the topics, actions, message
types and parameter names of the ros2_controllers controller it stands for (its
``ros2_control_type``). A team's ros2_controllers YAML file configures them
unchanged: ``<param from="controllers.yaml"/>`` in a ROS 2 launch file.

Load them from a launch file with ``args="rtcf_controllers ClassName"``.
"""

from .diff_drive_controller import DiffDriveController

__all__ = ["DiffDriveController"]
