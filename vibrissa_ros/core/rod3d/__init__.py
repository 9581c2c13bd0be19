"""
The 3D whisker: a Kirchhoff rod (bending in two planes and twist) against obstacles in space.

Model, conventions and decisions: doc/mechanics/rod3d.md. Dimensionless like the rest of the core
(L = 1, EI_b = 1).
"""

from .pose import BasePose
from .shape import DEFAULT_POISSON, RodShape

__all__ = ["BasePose", "DEFAULT_POISSON", "RodShape"]
