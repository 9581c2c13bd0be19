"""
Whisker-array files (YAML): read and write :class:`~vibrissa_ros.core.arrays.array.WhiskerArray`.

The format, SI units in the head frame (the rat's: x lateral toward the right, y rostral,
z dorsal)::

    description: rat whisker array, ...     # optional free text
    whiskers:
      - name: RC2            # unique; side letter, row, column (standard numbering, Greek = 0)
        side: right          # left | right
        row: C               # A-E
        column: 2            # 0-6
        base_position: [0.0066, -0.0010, 0.0003]        # [m]
        base_quaternion: [0.84, -0.48, 0.05, -0.25]     # (qw, qx, qy, qz), base frame -> head
        length: 0.0278       # arc length [m]
        parabola: 12.78      # A [1/m] of y = A x^2 (or k0 [1/m] and k1 [1/m^2])
        base_radius: 7.4e-05 # [m]
        taper: 0.0667        # tip radius / base radius, (0, 1]
        youngs_modulus: 3.34e+09  # [Pa]
        poisson: 0.38

Unknown keys are refused; every error is one line starting with the file's name, then the whisker
and the key.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional, Union

import yaml

from ..core.arrays.array import WhiskerArray
from ..core.arrays.rat import rat_array
from ..core.errors import ParameterError

#: keys whose values are never read as numbers (a column is an integer as written)
_TEXT_KEYS = ("name", "side", "row", "column")


def _yaml_number(value):
    """Return a YAML 1.1 string such as ``1e-3`` (no dot) as the number it means."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    if isinstance(value, list):
        return [_yaml_number(v) for v in value]
    return value


def load_array(path: Union[str, os.PathLike]) -> WhiskerArray:
    """
    Read a whisker array from a YAML file.

    Parameters
    ----------
    path : str or path-like
        The file (UTF-8).

    Returns
    -------
    WhiskerArray
        The array (SI units, head frame).

    Raises
    ------
    ParameterError
        One line starting with the file's name, naming the whisker and the key; also when the
        file cannot be read or is not valid YAML.

    """
    label = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ParameterError(f"{label}: cannot be read: {exc.strerror or exc}") from None
    return parse_array(text, label)


def parse_array(text: str, label: str = "array text") -> WhiskerArray:
    """
    Read a whisker array from an array file's YAML text (as :func:`load_array` reads a file).

    Parameters
    ----------
    text : str
        The YAML text.
    label : str, optional
        What errors name first (e.g. the file it came from).

    Returns
    -------
    WhiskerArray
        The array (SI units, head frame).

    Raises
    ------
    ParameterError
        One line starting with ``label``, naming the whisker and the key; also when the text
        is not valid YAML.

    """
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ParameterError(f"{label}: not valid YAML{where}: {problem}") from None
    if isinstance(data, dict) and isinstance(data.get("whiskers"), list):
        data = dict(data)
        data["whiskers"] = [
            {k: (v if k in _TEXT_KEYS else _yaml_number(v)) for k, v in e.items()}
            if isinstance(e, dict) else e for e in data["whiskers"]]
    try:
        return WhiskerArray.from_dict(data)
    except ParameterError as exc:
        raise ParameterError(f"{label}: {exc}") from None


def dump_array(array: WhiskerArray, path: Optional[Union[str, os.PathLike]] = None,
               header: str = "") -> str:
    """
    Write a whisker array as YAML (to ``path`` if given) and return the text.

    :func:`load_array` reads it back to an equal array (floats written to full precision).

    Parameters
    ----------
    array : WhiskerArray
        The array.
    path : str or path-like, optional
        The file written (UTF-8); None: only the text is returned.
    header : str, optional
        Comment lines written first (each prefixed with a hash and a space).

    Returns
    -------
    str
        The YAML text.

    """
    body = yaml.safe_dump(array.to_dict(), sort_keys=False, default_flow_style=None, width=99)
    comment = "".join(f"# {line}".rstrip() + "\n" for line in header.splitlines())
    text = comment + body
    if path is not None:
        Path(path).write_text(text, encoding="utf-8")
    return text


def write_rat_array(side: str = "both", model: str = "belli2018",
                    path: Optional[Union[str, os.PathLike]] = None) -> str:
    """
    Generate the rat's array and write it as YAML, with a header saying how it was made.

    Parameters
    ----------
    side : str, optional
        ``left``, ``right`` or ``both``.
    model : str, optional
        ``belli2018`` or ``towal2011``.
    path : str or path-like, optional
        The file written; None: only the text is returned.

    Returns
    -------
    str
        The YAML text.

    Raises
    ------
    ParameterError
        When ``side`` or ``model`` is not allowed.

    """
    array = rat_array(side, model)
    out = f" -o {path}" if path is not None else ""
    header = (f"The rat's whisker array, generated by: vibrissa array rat --side {side} "
              f"--model {model}{out}\n"
              "(vibrissa_ros.core.arrays.rat.rat_array); do not edit: regenerate it.\n"
              "SI units in the head frame: x lateral (toward the right side), y rostral, "
              "z dorsal.")
    return dump_array(array, path, header)
