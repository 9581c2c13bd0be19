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


def interrupted(exc: BaseException) -> bool:
    """
    Tell whether an exception is a Ctrl-C in disguise.

    A KeyboardInterrupt that arrives while a compiled kernel runs comes out of it as a
    SystemError ("returned a result with an exception set") caused by the interrupt: a caller
    that catches errors to keep going (the array's whiskers, the nodes) must stop on it.
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
