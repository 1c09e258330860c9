"""The launch layer: ROS 1 and ROS 2 launch XML, substitutions, the deployment.

Turns a launch file into runner settings and component specs. Imports the core only.
"""
