"""
Scene files (YAML): read and write the obstacles of :class:`~vibrissa_ros.core.scenes.scene.Scene`.

The format (doc/guide/scenes.md)::

    friction: 0.0                 # global Coulomb coefficient (default 0)
    obstacles:
      - {type: peg, x: 0.0, y: 0.45, r: 0.03, friction: 0.3}
      - {type: polygon, vertices: [[0.3, 0.6], [0.5, 0.6], [0.5, 0.8], [0.3, 0.8]]}
      - {type: curve, points: [[-1.0, 0.8], [0.0, 0.5], [1.0, 0.9]], side: above}
      - {type: parabola, p0: 0.3, k: 1.0, placement: {x: 0.0, y: 0.0, rotation: 0.0}}

Lengths are in whisker lengths (the command-line tool) or in metres (the ROS node: pass
``length_scale`` = the whisker's length in metres; they are converted to whisker lengths here, at
the edge). Rotations are in radians (``rotation``) or degrees (``rotation_deg``); friction
coefficients have no unit. Every error names the file, the obstacle's index and the key.

The 3D whisker's scenes (:class:`~vibrissa_ros.core.rod3d.scene.Scene3D`, :func:`load_scene3d`)
add three types, and read every planar type as its prism along z::

    obstacles:
      - {type: sphere, center: [0.3, 0.5, 0.1], r: 0.05}
      - {type: cylinder, point: [0.0, 0.6, 0.0], axis: [0.0, 0.0, 1.0], r: 0.03}
      - {type: plane, point: [0.0, 0.0, -0.2], normal: [0.0, 0.0, 1.0]}
      - {type: peg, x: -0.35, y: 0.45, r: 0.03}

``point``, ``center`` and ``r`` are lengths; ``axis`` and ``normal`` are directions (no unit,
normalised when read). The 3D whisker is frictionless: ``friction`` must be 0 or absent.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Dict, Optional, Union

import yaml

from ..core.errors import ParameterError
from ..core.rod3d.scene import Scene3D, has_solids
from ..core.scenes.scene import Scene
from ..core.units import (  # noqa: F401 (re-exported: scene files' units)
    DIRECTION_KEYS, INVERSE_LENGTH_KEYS, UNITLESS_KEYS, convert_lengths,
)


def _read(source: Union[str, os.PathLike]):
    """Return (text, label) of a scene given as a path or as YAML text."""
    if isinstance(source, os.PathLike) or (
            isinstance(source, str) and "\n" not in source and ": " not in source
            and not source.lstrip().startswith("{")):
        path = Path(source)
        try:
            return path.read_text(encoding="utf-8"), str(path)
        except OSError as exc:
            raise ParameterError(f"scene file {str(path)!r} cannot be read: "
                                 f"{exc.strerror or exc}") from None
    if not isinstance(source, str):
        raise ParameterError(f"a scene is a file path or YAML text, not {type(source).__name__}")
    return source, "scene text"


def load_scene(source: Union[str, os.PathLike], length_scale: float = 1.0) -> Scene:
    """
    Read a scene from a YAML file (path) or YAML text.

    Parameters
    ----------
    source : str or path-like
        A YAML file's path, or YAML text.
    length_scale : float, optional
        [m]: the whisker's length when the file is in metres (the node), > 0; 1: the file is in
        whisker lengths.

    Returns
    -------
    Scene
        The scene, in whisker lengths.

    Raises
    ------
    ParameterError
        Naming the file, the obstacle's index and the key; also when the file cannot be read,
        is not valid YAML or ``length_scale`` is not a length > 0.

    """
    data, label = _parse(source, length_scale)
    try:
        return Scene.from_dict(convert_lengths(data, length_scale))
    except ParameterError as exc:
        raise ParameterError(f"{label}: {exc}") from None


def _parse(source: Union[str, os.PathLike], length_scale: float):
    """Return (mapping, label) of a scene source; check ``length_scale``."""
    if not (isinstance(length_scale, (int, float)) and math.isfinite(length_scale)
            and length_scale > 0.0):
        raise ParameterError(f"length_scale = {length_scale!r} must be a length > 0 [m]")
    text, label = _read(source)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ParameterError(f"{label}: not valid YAML{where}: {problem}") from None
    if not isinstance(data, dict):
        raise ParameterError(f"{label}: a scene file is a mapping with keys 'obstacles' and "
                             "'friction'")
    return data, label


def scene_to_dict(scene: Scene, length_scale: float = 1.0) -> Dict[str, Any]:
    """Return the scene's mapping with lengths in metres (``length_scale`` [m] per L)."""
    return convert_lengths(scene.to_dict(), length_scale, into_l=False)


def dump_scene(scene: Scene, path: Optional[Union[str, os.PathLike]] = None,
               length_scale: float = 1.0) -> str:
    """
    Write a scene as YAML (to ``path`` if given) and return the text; :func:`load_scene` reads it.

    Parameters
    ----------
    scene : Scene
        The scene (whisker lengths).
    path : str or path-like, optional
        The file written (UTF-8); None: only the text is returned.
    length_scale : float, optional
        [m]: write lengths in metres for a whisker of that length; 1: in whisker lengths.

    Returns
    -------
    str
        The YAML text.

    """
    text = yaml.safe_dump(scene_to_dict(scene, length_scale), sort_keys=False,
                          default_flow_style=None)
    if path is not None:
        Path(path).write_text(text, encoding="utf-8")
    return text


# -- 3D scenes -----------------------------------------------------------------------------------
def load_scene3d(source: Union[str, os.PathLike], length_scale: float = 1.0,
                 drop_friction: bool = False) -> Scene3D:
    """
    Read a 3D scene from a YAML file (path) or YAML text; a planar scene file gives its prisms.

    Parameters
    ----------
    source : str or path-like
        A YAML file's path, or YAML text.
    length_scale : float, optional
        [m]: the whisker's length when the file is in metres (the node), > 0; 1: the file is in
        whisker lengths. Directions (``axis``, ``normal``) are not scaled.
    drop_friction : bool, optional
        True: ignore nonzero friction coefficients (a planar scene with friction read as the
        frictionless 3D scene of the same obstacles) instead of refusing them.

    Returns
    -------
    Scene3D
        The scene, in whisker lengths.

    Raises
    ------
    ParameterError
        One line starting with the file's name (or ``scene text``), then the obstacle's index
        and the key; also when the file cannot be read, is not valid YAML, has a nonzero
        friction, or ``length_scale`` is not a length > 0.

    """
    data, label = _parse(source, length_scale)
    try:
        return Scene3D.from_dict(convert_lengths(data, length_scale), drop_friction=drop_friction)
    except ParameterError as exc:
        raise ParameterError(f"{label}: {exc}") from None


def scene3d_to_dict(scene: Scene3D, length_scale: float = 1.0) -> Dict[str, Any]:
    """
    Return the 3D scene's mapping with lengths in metres (``length_scale`` [m] per L).

    Parameters
    ----------
    scene : Scene3D
        The scene (whisker lengths).
    length_scale : float, optional
        [m] per whisker length; 1: lengths in whisker lengths.

    Returns
    -------
    dict
        The mapping :func:`load_scene3d` reads (with the same ``length_scale``).

    """
    return convert_lengths(scene.to_dict(), length_scale, into_l=False)


def dump_scene3d(scene: Scene3D, path: Optional[Union[str, os.PathLike]] = None,
                 length_scale: float = 1.0) -> str:
    """
    Write a 3D scene as YAML (to ``path`` if given) and return the text.

    :func:`load_scene3d` reads it back (with the same ``length_scale``).

    Parameters
    ----------
    scene : Scene3D
        The scene (whisker lengths).
    path : str or path-like, optional
        The file written (UTF-8); None: only the text is returned.
    length_scale : float, optional
        [m]: write lengths in metres for a whisker of that length; 1: in whisker lengths.

    Returns
    -------
    str
        The YAML text.

    """
    text = yaml.safe_dump(scene3d_to_dict(scene, length_scale), sort_keys=False,
                          default_flow_style=None)
    if path is not None:
        Path(path).write_text(text, encoding="utf-8")
    return text


def is_3d_scene(source: Union[Dict[str, Any], str, os.PathLike]) -> bool:
    """
    Tell whether a scene has a 3D-only obstacle (sphere, cylinder, plane).

    A scene without one is a planar scene: :func:`load_scene` and :func:`load_scene3d` both
    read it.

    Parameters
    ----------
    source : dict, str or path-like
        A scene file's mapping, a YAML file's path, or YAML text.

    Returns
    -------
    bool
        True when some obstacle's ``type`` is 3D-only.

    Raises
    ------
    ParameterError
        When a path or text cannot be read or is not a YAML mapping (starting with its name).

    """
    if isinstance(source, dict):
        return has_solids(source)
    return has_solids(_parse(source, 1.0)[0])
