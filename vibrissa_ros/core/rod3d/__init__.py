"""
The 3D whisker: a Kirchhoff rod (bending in two planes and twist) against obstacles in space.

Model, conventions and decisions: doc/mechanics/rod3d.md. Dimensionless like the rest of the core
(L = 1, EI_b = 1).
"""

from .inverse import ContactEstimate3D, contact_from_wrench
from .loads import LoadedRod, tip_loaded_rod
from .model import RodContactMode, RodEquilibrium, RodSolver
from .obstacles import Cylinder, Plane, Prism, Sphere, SurfacePoint
from .pose import BasePose
from .scene import Scene3D
from .shape import DEFAULT_POISSON, RodShape
from .tracker import RodContact, RodEvent, RodState, RodStepResult, RodTracker

__all__ = [
    "BasePose", "ContactEstimate3D", "Cylinder", "DEFAULT_POISSON", "LoadedRod", "Plane", "Prism",
    "RodContact", "RodContactMode", "RodEquilibrium", "RodEvent", "RodShape", "RodSolver",
    "RodState", "RodStepResult", "RodTracker", "Scene3D", "Sphere", "SurfacePoint",
    "contact_from_wrench", "tip_loaded_rod",
]
