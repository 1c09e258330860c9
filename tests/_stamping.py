"""A component that stamps a std_msgs/Header, for the ROS 1 and ROS 2 stamp tests alike
(no middleware here: each test names its ROS's Header)."""

import rtcf


class StampsHeader(rtcf.Component):
    """Writes a ``header_type`` (std_msgs/Header of either ROS), stamped by stamp_to."""

    header_type: type

    def configure(self):
        self.out = self.add_output("header", self.header_type)

    def update(self):
        header = self.header_type(frame_id="base")
        self.stamp_to(header.stamp)
        self.out.write(header)
