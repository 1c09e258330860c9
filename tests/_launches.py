"""Launch texts that tests of several folders run (unit, integration, ROS 1, ROS 2).

One copy of each, so that a change of the launch format is made once; a test that
needs a variant says what differs (the keyword arguments) rather than repeating it.
"""

import textwrap


def _params(before, params):
    """``<param>`` elements (ROS 1 format), each after ``before``."""
    return "".join(f'{before}<param name="{k}" value="{v}"/>' for k, v in params.items())


def runner_xml(frequency=200.0, mode="no_wait", **params):
    """An rt_runner node (ROS 1 format) with these parameters."""
    extra = _params("\n    ", params)
    return f"""
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <param name="mode" value="{mode}"/>
    <param name="frequency" value="{frequency}"/>{extra}
  </node>"""


def launcher_xml(name, args, remaps=None, **params):
    """An rt_launcher node (ROS 1 format) named ``name`` running ``args`` ("MODULE
    CLASS"), its ports remapped by ``remaps`` (port -> topic), with these parameters."""
    inner = "".join(f'\n    <remap from="{k}" to="{v}"/>' for k, v in (remaps or {}).items())
    inner += _params("\n    ", params)
    return f'\n  <node name="{name}" pkg="rtcf" type="rt_launcher" args="{args}">{inner}\n  </node>'


def launch_xml(body, runner=None):
    """A launch file's text: the runner (``runner_xml()`` if not given), then ``body``."""
    return f"<launch>{runner or runner_xml()}\n{textwrap.dedent(body)}\n</launch>\n"


# one component writing each kind of value (tests/integration/fixtures), at 100 Hz
EVERY_KIND = launch_xml(
    '<node name="k" pkg="rtcf" type="rt_launcher" args="rtcf_test_components EveryKind"/>',
    runner_xml(100.0),
)


def tuned_launch(package, topic_in, topic_out, **params):
    """/ctl/tuned, the Tuned component of ``package`` (either ROS's test components),
    its in and out mapped to ROS topics, in a 100 Hz runner."""
    return launch_xml(f"""
  <group ns="ctl">
    <node name="tuned" pkg="rtcf" type="rt_launcher" args="{package} Tuned">
      <remap from="in" to="{topic_in}"/>
      <remap from="out" to="{topic_out}"/>{_params(chr(10) + "      ", params)}
    </node>
  </group>""", runner_xml(100.0, ros_mapping_whitelist="/ros/.*"))


def write_launch(tmp_path, body, runner=None, name="test.launch"):
    path = tmp_path / name
    path.write_text(launch_xml(body, runner))
    return path

# a sine into a component in a lane of its own on logical execution time (released
# every ``every`` iterations from ``phase``, its output seen one window later), read by
# a lock-step sink in the main lane: /x -> {name} -> /y -> sink -> /z
_LET = """<launch>
  <node name="rt_runner" pkg="rtcf" type="rt_runner">
    <rosparam param="mode">"wait_for_components"</rosparam>
    <rosparam param="num_components_expected">3</rosparam>
    <rosparam param="frequency">{frequency}</rosparam>
  </node>
  <node name="src" pkg="rtcf" type="rt_launcher" args="rtcf_examples Sine">
    <remap from="out" to="/x"/>
  </node>
  <node name="{name}" pkg="rtcf" type="rt_launcher" args="rtcf_examples {cls}">
    <remap from="in_port" to="/x"/><remap from="out_port" to="/y"/>
    <param name="every" value="{every}"/><param name="phase" value="{phase}"/>{params}
    <param name="lane" value="{lane}"/>
  </node>
  <node name="sink" pkg="rtcf" type="rt_launcher" args="rtcf_examples Identity">
    <remap from="in_port" to="/y"/><remap from="out_port" to="/z"/>
  </node>
</launch>
"""


def let_launch(*, frequency=1000.0, name="slow", cls="Identity", every=10, phase=3,
               lane="mpc", **params):
    """The LET launch (ROS 1 format); ``params`` are more parameters of its component."""
    extra = _params("", params)
    return _LET.format(frequency=frequency, name=name, cls=cls, every=every, phase=phase,
                       lane=lane, params=extra)
