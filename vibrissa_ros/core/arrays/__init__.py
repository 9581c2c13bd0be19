"""
Whisker arrays: many 3D whiskers placed on a head (the mystacial pad), whisking, stepped together.

``array`` holds the data (:class:`WhiskerSpec`, :class:`WhiskerArray`) in SI units in the head
frame; ``rat`` generates the rat's array from the published morphology (Belli et al. 2018,
Towal et al. 2011); ``whisking`` turns protraction angles into base frames; ``tracker`` advances
every whisker of an array to a new head pose and whisk in one call (:class:`ArrayTracker`);
``partition`` does it with the whiskers dealt to several processes
(:class:`~.partition.PartitionedArrayTracker`). No ROS import: part of the mechanics core.
"""

from .array import WhiskerArray, WhiskerRod, WhiskerSpec
from .rat import rat_array
from .tracker import ArrayStep, ArrayTracker, WhiskerError, WhiskerEvent
from .whisking import CosineWhisk, Whisking

__all__ = ["ArrayStep", "ArrayTracker", "CosineWhisk", "WhiskerArray", "WhiskerError",
           "WhiskerEvent", "WhiskerRod", "WhiskerSpec", "Whisking", "rat_array"]
