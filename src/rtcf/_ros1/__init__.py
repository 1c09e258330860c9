"""The ROS 1 bridge (rospy) and the ROS 1 executables rt_runner and rt_launcher.

Runs in the supervisor process only. Imports the runtime, launch and core layers,
never the ROS 2 bridge or the command line.
"""
