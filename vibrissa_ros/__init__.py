"""vibrissa_ros: a virtual artificial whisker (exact quasistatic elastica) for ROS 2."""

__version__ = "0.1.0"
