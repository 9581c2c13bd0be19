"""The entry-point pattern of every vibrissa_ros node (Jazzy): exit 0 on SIGINT and SIGTERM."""

from __future__ import annotations

from typing import Callable, Optional

import rclpy
from rclpy.exceptions import (
    InvalidHandle,
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterUninitializedException,
)
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node

from ..core.errors import VibrissaError

RCLError = rclpy_implementation.RCLError


def run_node(make_node: Callable[[], Node], name: str, args=None,
             make_executor: Optional[Callable[[Node], Optional[Executor]]] = None) -> int:
    """
    Init, build the node, spin until shutdown, clean up.

    An invalid start-up configuration is reported in one line and gives exit status 2. The
    standard single-threaded executor spins, unless ``make_executor(node)`` returns another
    (array_node's ``executor`` parameter: rclpy's experimental EventsExecutor, whose ``spin()``
    runs no callback in the Jazzy wheels: it is spun with ``spin_once`` until shutdown).
    whisker_node keeps the standard executor: measured against it, the EventsExecutor (Jazzy
    wheels, rclpy 7.1.5) refuses a node with a guard condition; with whisker_node's guard
    condition replaced by a timer, ``spin()`` kept a core busy and returned on neither SIGINT nor
    SIGTERM, and ``spin_once`` loops answered 25 of 3,000 poses sent at 1 kHz (the node takes
    what DDS holds from the subscription itself, which the events executor's message counts do
    not expect).
    """
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = make_node()
        executor = make_executor(node) if make_executor is not None else None
        if executor is None:
            executor = SingleThreadedExecutor()
        executor.add_node(node)
        if isinstance(executor, SingleThreadedExecutor):
            executor.spin()
        else:  # the EventsExecutor's spin() of the Jazzy wheels runs no callback; spin_once does
            while rclpy.ok():
                executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (RCLError, InvalidHandle):
        # SIGINT/SIGTERM shut the context down while a callback was publishing: a clean stop
        if rclpy.ok():
            raise
    except (VibrissaError, InvalidParameterValueException, InvalidParameterTypeException,
            ParameterUninitializedException) as exc:
        rclpy.logging.get_logger(name).fatal(f"invalid parameters: {exc}")
        code = 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code
