"""
Whisker arrays: many 3D whiskers placed on a head (the mystacial pad), and the rat's array.

``array`` holds the data (:class:`WhiskerSpec`, :class:`WhiskerArray`) in SI units in the head
frame; ``rat`` generates the rat's array from the published morphology (Belli et al. 2018,
Towal et al. 2011). No ROS import: part of the mechanics core.
"""

from .array import WhiskerArray, WhiskerRod, WhiskerSpec
from .rat import rat_array

__all__ = ["WhiskerArray", "WhiskerRod", "WhiskerSpec", "rat_array"]
