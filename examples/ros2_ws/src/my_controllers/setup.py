"""my_controllers: rtcf components as an ament_python package (colcon or pip)."""

from glob import glob

from setuptools import setup

package_name = "my_controllers"

setup(
    name=package_name,
    version="0.1.0",
    packages=[package_name],
    data_files=[
        # what makes it a ROS 2 package: the ament index marker and the manifest
        ("share/ament_index/resource_index/packages", [f"resource/{package_name}"]),
        (f"share/{package_name}", ["package.xml"]),
        # where `ros2 launch my_controllers FILE` and `rtcf launch my_controllers FILE`
        # find the launch files
        (f"share/{package_name}/launch", glob("launch/*.launch.xml")),
    ],
    zip_safe=True,
    maintainer="rtcf maintainers",
    maintainer_email="maintainers@example.com",
    description="Example rtcf components (a PID controller and a simulated mass)",
    license="MIT",
)
