"""The URDF of two drives (j1 node 2, j2 node 3) the canopen unit tests build on."""

from __future__ import annotations


def two_drives(*, hardware: str = "", attrs: str = "", j1: str = "",
               j2_command: str = "position") -> str:
    """``hardware``: the <hardware> tag's <param>s; ``attrs``: the <ros2_control> tag's
    (rw_rate); ``j1``: j1's own <param>s; ``j2_command``: j2's command interface."""
    return f"""<robot name="r"><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
    <limit lower="-9" upper="9" velocity="9" effort="9"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/>
    <limit lower="-9" upper="9" velocity="9" effort="9"/></joint>
  <ros2_control name="drives" type="system"{attrs}>
    <hardware><plugin>rtcf_canopen/Cia402System</plugin>{hardware}</hardware>
    <joint name="j1"><param name="node_id">2</param>{j1}
      <command_interface name="position"/>
      <state_interface name="position"/><state_interface name="velocity"/></joint>
    <joint name="j2"><param name="node_id">3</param>
      <command_interface name="{j2_command}"/>
      <state_interface name="position"/><state_interface name="velocity"/></joint>
  </ros2_control></robot>"""
