"""
The general planar whisker: tapered, intrinsically curved (the paper's §4 outlook).

``model`` solves the elastica with a bending stiffness B(s) and an intrinsic curvature by
Chebyshev collocation and plugs into the quasistatic tracker of :mod:`vibrissa_ros.core.exact`;
``inverse`` finds the contact point from one base-wrench reading. The exact family is its
yardstick (a uniform, straight whisker must reproduce the closed forms).
"""

from .model import GeneralWhiskerModel, WhiskerShape, chebyshev_operators, free_centerline

__all__ = ["GeneralWhiskerModel", "WhiskerShape", "chebyshev_operators", "free_centerline"]
