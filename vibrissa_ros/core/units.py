"""
Length units of scene mappings: whisker lengths L (the mechanics core) and metres (the adapters).

A scene mapping (a scene file's content, :meth:`Scene3D.to_dict
<vibrissa_ros.core.rod3d.scene.Scene3D.to_dict>`) holds lengths, inverse lengths (a parabola's
``k``) and quantities without unit (directions, angles, friction). :func:`convert_lengths`
converts every one of its lengths at once, so that one scene in metres becomes the scene of
each whisker in that whisker's own length.
"""

from __future__ import annotations

from typing import Any, Dict

from .profiles import PROFILE_PARAMETERS

#: shape keys measured in 1/length (all other shape keys are lengths)
INVERSE_LENGTH_KEYS = ("k",)
#: keys that are neither lengths nor inverse lengths
UNITLESS_KEYS = ("type", "name", "friction", "side", "rotation", "rotation_deg")
#: direction keys of the 3D obstacles: no unit (normalised), never scaled
DIRECTION_KEYS = ("axis", "normal")


def _scale(value: Any, factor: float, into_l: bool) -> Any:
    """Convert a number, or every number of nested lists (anything else is kept)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str):  # YAML 1.1 reads 1e-3 (no dot) as a string
        try:
            value = float(value)
        except ValueError:
            return value
    if isinstance(value, (int, float)):
        # into metres (written for people): 15 significant digits, no trailing rounding noise
        return value / factor if into_l else float(f"{value * factor:.15g}")
    if isinstance(value, (list, tuple)):
        return [_scale(v, factor, into_l) for v in value]
    return value


def convert_lengths(data: Any, length_scale: float, into_l: bool = True) -> Any:
    """
    Return a scene mapping with its lengths converted from metres to L (or back).

    Parameters
    ----------
    data : Any
        A scene mapping (``obstacles``: a list of obstacle mappings). Anything else, and
        malformed entries, are passed on unchanged, for the scene's validation to name.
    length_scale : float
        [m]: the whisker's length L. 1/length keys (the parabola's k) convert the other way;
        directions and angles are kept.
    into_l : bool, optional
        True: from metres into L (divide lengths by ``length_scale``); False: from L into
        metres (multiply, rounded to 15 significant digits).

    Returns
    -------
    Any
        The converted mapping (a new dict), or ``data`` itself when it is not a mapping or
        ``length_scale`` is 1.

    """
    factor = float(length_scale)
    if not isinstance(data, dict) or factor == 1.0:
        return data
    out = dict(data)
    entries = data.get("obstacles")
    if not isinstance(entries, list):
        return out
    converted = []
    for entry in entries:
        if not isinstance(entry, dict):
            converted.append(entry)
            continue
        new: Dict[str, Any] = {}
        family = entry.get("type") in PROFILE_PARAMETERS
        for key, value in entry.items():
            if key in UNITLESS_KEYS or key in DIRECTION_KEYS:
                new[key] = value
            elif key == "placement" and isinstance(value, dict):
                new[key] = {k: (_scale(v, factor, into_l) if k in ("x", "y") else v)
                            for k, v in value.items()}
            elif family and key in INVERSE_LENGTH_KEYS:
                new[key] = _scale(value, factor, not into_l)
            else:
                new[key] = _scale(value, factor, into_l)
        converted.append(new)
    out["obstacles"] = converted
    return out
