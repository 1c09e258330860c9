"""A component that stamps a std_msgs/Header, for the ROS 1 and ROS 2 stamp tests alike
(no middleware here: each test names its ROS's Header)."""

import rtcf
from rtcf.testing import run_components


class StampsHeader(rtcf.Component):
    """Writes a ``header_type`` (std_msgs/Header of either ROS), stamped by stamp_to."""

    header_type: type

    def configure(self):
        self.out = self.add_output("header", self.header_type)

    def update(self):
        header = self.header_type(frame_id="base")
        self.stamp_to(header.stamp)
        self.out.write(header)


def stamped_headers(header_type):
    """The ``header_type`` messages a StampsHeader wrote in three iterations at 2 Hz:
    stamped with their iterations' ROS times, 0, 0.5 and 1 s."""
    stamps = type("Stamps", (StampsHeader,), {"header_type": header_type})
    return run_components([stamps], iterations=3, frequency=2.0).outputs["/header"]
