"""
The topic contract of whisker_node: every topic's name (relative to the node), type and QoS.

In: ``~/foot_pose`` (PoseStamped, ``POSES``); out: ``OUTPUTS`` and ``/diagnostics`` (depth 10).
The recorder reads the QoS back from the endpoints the node creates from this table, and
every node of the package creates its outputs with :func:`output_publisher`.
"""

from geometry_msgs.msg import PointStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Path
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Float64, String, UInt8
from visualization_msgs.msg import Marker, MarkerArray

RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE)
# poses: keep all, so that a slow step delays the ones behind it instead of losing them
POSES = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1000,
                   reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
OUTPUTS = {  # key: (type, QoS); every topic is ~/key
    "wrench": (WrenchStamped, RELIABLE), "phase": (UInt8, RELIABLE),
    "contact_force": (Vector3Stamped, RELIABLE), "contact_force_magnitude": (Float64, RELIABLE),
    "contact_point": (PointStamped, RELIABLE), "arc_length": (Float64, RELIABLE),
    "events": (String, RELIABLE), "centerline": (Path, RELIABLE), "obstacle": (Marker, LATCHED),
    "obstacles": (MarkerArray, LATCHED), "contacts": (PointCloud2, RELIABLE),
}
OPTIONAL = ("phase", "contact_force", "contact_force_magnitude", "contact_point", "arc_length",
            "centerline", "contacts")


def output_publisher(node, kind, topic: str, qos):
    """
    Create an output's publisher without publisher-side QoS event handlers.

    rclpy gives every publisher two event handlers by default (a warning when a subscriber with
    an incompatible QoS or type appears), and its executor rebuilds the wait set from all of a
    node's handlers on every turn: with whisker_node's 12 publishers a turn of the executor cost
    ~124 µs against ~25 µs without them (doc/benchmarks.md, "The executor's turn"), at 1 kHz a
    tenth of a core. Nothing goes silent: the subscriber's side has the same warnings by
    default (rclpy's and rclcpp's, e.g. ``ros2 topic echo`` or RViz), and the nodes' inputs
    keep theirs.

    Parameters
    ----------
    node : rclpy.node.Node
        The node.
    kind : type
        The message type.
    topic : str
        The topic name (``~/`` for the node's own).
    qos : rclpy.qos.QoSProfile or int
        Its QoS (or a KEEP_LAST depth).

    Returns
    -------
    rclpy.publisher.Publisher
        The publisher.

    """
    return node.create_publisher(kind, topic, qos,
                                 event_callbacks=PublisherEventCallbacks(
                                     use_default_callbacks=False))
