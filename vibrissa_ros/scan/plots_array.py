"""
The figures of a whisker array's run (matplotlib, Agg backend, deterministic PNGs).

Three figures (:func:`plot_array_scan`), SI units:

``3d``
    The array in 3D with the scene: every whisker's shape at one tick (coloured by its number
    of contacts), its base (triangles) and its contacts (black dots); the obstacles clipped to
    a box around the whiskers.
``heatmap``
    Whisker x time maps of norm(F) [N] and norm(M) [N m] (the base load's norms, the same in
    any frame); whiskers in the array's order, grouped by row.
``rows``
    One panel per row of the array, one line per whisker (coloured by column) of norm(M)
    [N m] over time.

The plotting code only draws results; it never computes mechanics.
"""

from __future__ import annotations

from typing import Dict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .plots import CONTACT_COLORS, CONTACT_NAMES, Figure  # noqa: E402
from .plots3d import draw_scene3d  # noqa: E402


def _box(points: np.ndarray, margin: float):
    lo, hi = points.min(axis=0) - margin, points.max(axis=0) + margin
    mid, half = 0.5 * (lo + hi), np.full(3, 0.5 * float((hi - lo).max()))
    return mid - half, mid + half


def plot_array_shapes(scene, result, tick: int = None, title: str = "") -> Figure:
    """
    Draw the array in 3D at one tick: the scene, every whisker's shape, bases and contacts.

    Parameters
    ----------
    scene : Scene3D
        The obstacles (world frame, metres).
    result : ArrayScanResult
        The run; its kept centerlines (``shapes``) are drawn.
    tick : int, optional
        The tick drawn (default: the run's ``shape_tick``); it must be the kept one.
    title : str, optional
        The figure's title.

    Returns
    -------
    Figure
        The figure; ``axes["scene"]`` the 3D axes.

    Raises
    ------
    ValueError
        When the run kept no centerlines at that tick.

    """
    if result.shapes is None or (tick is not None and tick != result.shape_tick):
        raise ValueError("the run kept no whisker shapes at that tick (run it with shape_tick)")
    tick = result.shape_tick
    step = result.steps[tick]
    lines = np.asarray(result.shapes)
    fig = plt.figure(figsize=(10, 8.5), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    out = Figure(fig, axes={"scene": ax})
    lo, hi = _box(lines.reshape(-1, 3), 0.002)
    draw_scene3d(ax, scene, lo, hi)
    seen = set()
    for i, line in enumerate(lines):
        k = min(int(step.contacts[i]), 3)
        ax.plot(line[:, 0], line[:, 1], line[:, 2], color=CONTACT_COLORS[k],
                lw=1.6 if k else 0.9, label=CONTACT_NAMES[k] if k not in seen else None,
                gid=f"whisker:{step.names[i]}")
        seen.add(k)
    base = np.asarray(step.base_position)
    ax.plot(base[:, 0], base[:, 1], base[:, 2], "^", ms=3, color="#444444", label="bases",
            gid="bases")
    touching = np.flatnonzero(np.asarray(step.contacts) > 0)
    if len(touching):
        p = np.asarray(step.contact_point)[touching]
        ax.plot(p[:, 0], p[:, 1], p[:, 2], "o", ms=4.5, color="black", label="contacts",
                gid="contacts")
        for i in touching:
            q = step.contact_point[i]
            ax.text(q[0], q[1], q[2], f" {step.names[i]}", fontsize=7, gid="contact_label")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"t = {result.times[tick]:.4g} s (tick {tick}): {step.in_contact} of "
                 f"{len(step.names)} whiskers in contact")
    ax.legend(loc="upper left", fontsize=8)
    if title:
        fig.suptitle(title)
    return out


def _norms(result, field: str) -> np.ndarray:
    return np.linalg.norm(result.stacked(field), axis=2).T  # (k, ticks)


def plot_array_heatmap(result, title: str = "") -> Figure:
    """
    Draw whisker x time maps of norm(F) and norm(M).

    Parameters
    ----------
    result : ArrayScanResult
        The run.
    title : str, optional
        The figure's title.

    Returns
    -------
    Figure
        The figure; ``axes["force"]`` and ``axes["moment"]``.

    """
    names = result.array.names
    t = np.asarray(result.times)
    k = len(names)
    fig, (ax_f, ax_m) = plt.subplots(2, 1, figsize=(11, 3.0 + 0.36 * k), sharex=True,
                                     layout="constrained")
    out = Figure(fig, axes={"force": ax_f, "moment": ax_m})
    dt = (t[-1] - t[0]) / max(1, len(t) - 1)
    extent = (t[0] - 0.5 * dt, t[-1] + 0.5 * dt, k - 0.5, -0.5)
    for ax, field, label in ((ax_f, "force", "norm(F) [N]"), (ax_m, "moment", "norm(M) [N m]")):
        image = ax.imshow(_norms(result, field), aspect="auto", interpolation="nearest",
                          extent=extent, cmap="magma", gid=f"map:{field}")
        fig.colorbar(image, ax=ax, label=label)
        ax.set_yticks(range(k))
        ax.set_yticklabels(names, fontsize=6 if k > 30 else 7)
        rows = [w.row for w in result.array]
        for i in range(1, k):
            if rows[i] != rows[i - 1]:
                ax.axhline(i - 0.5, color="white", lw=0.5)
        ax.set_ylabel("whisker")
        ax.set_title(f"{label.split(' ')[0]} of the contact forces on each whisker (base load)")
    ax_m.set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    return out


def plot_array_rows(result, title: str = "") -> Figure:
    """
    Draw one panel per row of the array: norm(M) of each whisker over time, coloured by column.

    Parameters
    ----------
    result : ArrayScanResult
        The run.
    title : str, optional
        The figure's title.

    Returns
    -------
    Figure
        The figure; ``axes`` by row letter.

    """
    specs = result.array.whiskers
    rows = sorted({w.row for w in specs})
    t = np.asarray(result.times)
    moment = _norms(result, "moment")
    fig, axes = plt.subplots(len(rows), 1, figsize=(10, 1.2 + 1.9 * len(rows)), sharex=True,
                             squeeze=False, layout="constrained")
    out = Figure(fig)
    colors = plt.get_cmap("tab10").colors
    for ax, row in zip(axes[:, 0], rows):
        out.axes[row] = ax
        for i, w in enumerate(specs):
            if w.row != row:
                continue
            ax.plot(t, moment[i], color=colors[w.column % 10], lw=1.1,
                    label=w.name, gid=f"trace:{w.name}")
        ax.set_ylabel(f"row {row}\nnorm(M) [N m]")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=7, ncol=7, loc="upper right")
    axes[-1, 0].set_xlabel("t [s]")
    axes[0, 0].set_title("moment of the contact forces about each base, by row (colour: column)")
    if title:
        fig.suptitle(title)
    return out


def plot_array_scan(scene, result, title: str = "") -> Dict[str, Figure]:
    """
    Draw the three figures of an array run.

    Parameters
    ----------
    scene : Scene3D
        The obstacles (world frame, metres).
    result : ArrayScanResult
        The run (with kept centerlines for the 3D figure; without, it is left out).
    title : str, optional
        The figures' title.

    Returns
    -------
    dict
        ``{"3d": Figure, "heatmap": Figure, "rows": Figure}`` (``3d`` only when the run kept
        shapes).

    """
    out = {}
    if result.shapes is not None:
        out["3d"] = plot_array_shapes(scene, result, title=title)
    out["heatmap"] = plot_array_heatmap(result, title=title)
    out["rows"] = plot_array_rows(result, title=title)
    return out


__all__ = ["plot_array_heatmap", "plot_array_rows", "plot_array_scan", "plot_array_shapes"]
