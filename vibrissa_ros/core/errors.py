"""
Exceptions raised by the mechanics core.

Every error the core raises derives from :class:`VibrissaError`, so an adapter (the ROS node, the
command-line tool) can catch one class, report the message and keep its state.
"""


class VibrissaError(Exception):
    """Base class of every error raised by vibrissa_ros."""


class ParameterError(VibrissaError, ValueError):
    """A profile, model or scan parameter is outside its allowed range."""


class InvalidPoseError(VibrissaError, ValueError):
    """A foot pose is not finite or not placeable (e.g. the straight whisker cuts the obstacle)."""


class ModelAssumptionError(VibrissaError):
    """
    A step would leave the assumptions of the model (graph profile, WH1, reach of the profile).

    The tracker keeps the state it had before the step.
    """


class ConvergenceError(VibrissaError):
    """The equilibrium could not be followed numerically; the tracker keeps its previous state."""
