"""
What the nodes do, without ROS: parameters, configuration, the pose pipeline, units and frames.

``parameters`` is the parameter machinery (types, ranges, reasons) both nodes share, ``config``
their parameters and the configurations they build, ``pipeline`` what whisker_node does with a
pose (checks, step, drop reasons, counters), ``edge`` every conversion between ROS and the core
(stamps, quaternions, frames, SI units, the event payload), ``noise`` the sensor model and
``reconstruction`` the contour from the sensor (contour_node, ``vibrissa reconstruct``),
``array`` what array_node does (parameters, inputs, the tick, its output layout). The
rclpy wiring lives in :mod:`vibrissa_ros.ros`; the log tools share this code to re-simulate.
"""
