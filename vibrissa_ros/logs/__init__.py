"""
Logs: MCAP recordings in the rosbag2 layout, and the tools that read them.

``mcap_log`` writes, reads and repairs the files (ROS 2 CDR, ros2msg schemas); ``tools`` is what
``vibrissa info``, ``resim`` and ``export`` do with them; ``array_resim`` re-simulates
array_node's logs.
"""
