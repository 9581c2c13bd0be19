"""
The topic contract of whisker_node: every topic's name (relative to the node), type and QoS.

In: ``~/foot_pose`` (PoseStamped, ``POSES``); out: ``OUTPUTS`` and ``/diagnostics`` (depth 10).
The recorder reads the QoS back from the endpoints the node creates from this table.
"""

from geometry_msgs.msg import PointStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Path
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
