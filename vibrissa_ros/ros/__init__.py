"""
The ROS 2 side of vibrissa_ros: everything that imports rclpy lives in this subpackage.

* :mod:`.whisker_node`, :mod:`.contour_node` and :mod:`.array_node`: the nodes (wiring only);
  :mod:`.array_messages`: array_node's messages (pure builders); :mod:`.topics`:
  whisker_node's topic names, types and QoS; :mod:`.backlog`: poses taken, not yet processed;
* :mod:`.messages`: pure builders of every message the nodes publish (testable without DDS);
  :mod:`.cdr`: whisker_node's per-pose messages straight to CDR bytes;
* :mod:`.params`: the shared parameter machinery turned into ROS descriptors and callbacks;
* :mod:`.recorder`: MCAP recording of a node's endpoints; :mod:`.serialization`: CDR;
* :mod:`.replay` and :mod:`.sweep`: the ``vibrissa replay`` and ``vibrissa sweep`` drivers;
* :mod:`.run`: the entry-point pattern of every node.

Conversions (stamps, quaternions, frames, units, event payloads) are in
:mod:`vibrissa_ros.node.edge`, the mechanics in :mod:`vibrissa_ros.core`; neither imports ROS.
"""
