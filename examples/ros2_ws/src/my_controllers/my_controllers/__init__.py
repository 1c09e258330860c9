"""A team's own rtcf components, shipped as a ROS 2 package.

Load them from a launch file with ``args="my_controllers PidController"``.
"""

from ._components import MassDamper, PidController

__all__ = ["MassDamper", "PidController"]
