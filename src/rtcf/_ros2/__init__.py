"""The ROS 2 bridge (rclpy) and the ROS 2 executables rt_runner and rt_launcher.

Runs in the supervisor process only. Imports the runtime, launch and core layers,
never the ROS 1 bridge or the command line.
"""
