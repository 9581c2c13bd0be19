"""
The mechanics core of vibrissa_ros: no ROS import anywhere below this package.

Dimensionless units of the paper: length L (whisker length), force EI/L^2, moment EI/L.
"""

from .exact.elastica import TipLoadedElastica, tip_loaded_elastica
from .errors import (
    ConvergenceError,
    InvalidPoseError,
    ModelAssumptionError,
    ParameterError,
    VibrissaError,
)
from .general.model import GeneralWhiskerModel, WhiskerShape
from .exact.models import ElasticaModel, make_model
from .profiles import (
    PROFILE_PARAMETERS,
    PROFILES,
    Catenary,
    Circle,
    ConvexProfile,
    Ellipse,
    Parabola,
    Peg,
    PlacedProfile,
    TwoCircles,
    make_profile,
)
from .scan import ScanResult, run_poses, run_scan, scan_grid, whisk_poses
from .state import Event, FootPose, Phase, StepResult, WhiskerState
from .exact.tracker import QuasistaticTracker, TrackerOptions

__all__ = [
    "Catenary",
    "Circle",
    "ConvergenceError",
    "ConvexProfile",
    "ElasticaModel",
    "Ellipse",
    "Event",
    "FootPose",
    "InvalidPoseError",
    "ModelAssumptionError",
    "PROFILES",
    "PROFILE_PARAMETERS",
    "Parabola",
    "Peg",
    "GeneralWhiskerModel",
    "WhiskerShape",
    "ParameterError",
    "Phase",
    "PlacedProfile",
    "QuasistaticTracker",
    "ScanResult",
    "StepResult",
    "TipLoadedElastica",
    "TrackerOptions",
    "TwoCircles",
    "VibrissaError",
    "WhiskerState",
    "make_model",
    "make_profile",
    "run_poses",
    "run_scan",
    "scan_grid",
    "tip_loaded_elastica",
    "whisk_poses",
]
