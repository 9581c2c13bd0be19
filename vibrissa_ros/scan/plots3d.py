"""
The figure of a 3D scan (matplotlib, Agg backend, deterministic PNGs).

Top: a 3D view of the scene around the whisker's path, the whisker's shapes at several poses
(coloured by the number of contacts) and the contact points (black dots on the drawn shapes,
grey dots for every pose's contacts: the contacts' track). Obstacles are clipped to a box around
the path: spheres and cylinder segments as translucent meshes, half-spaces as the patch of their
boundary plane inside the box, prisms (planar obstacles) as their outline extruded over the
box's z range (a point peg: a vertical line). Below: the base load along the path (pose index),
the total contact force (fx, fy, fz) and the moment of the contact forces about the base point
(mx, my, mz), world frame, dimensionless; the spans with contacts are shaded and the events
marked.

The plotting code only draws states and events; it never computes mechanics.
"""

from __future__ import annotations

import math
from typing import List, Sequence, Tuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

from .plots import (CONTACT_COLORS, CONTACT_NAMES, CONTACT_SHADES, SCENE_EDGE,  # noqa: E402
                    SCENE_FILL, Figure)

#: colours of the base load's components
COMPONENT_COLORS = {"x": "#d62728", "y": "#2ca02c", "z": "#1f77b4"}
#: at most this many event kinds are written above the force panel
_EVENT_LABELS = 24


def _picks(states: Sequence, event_steps: Sequence[int], count: int) -> List[int]:
    """Return the indices of the drawn shapes: evenly spread, plus the events' poses."""
    n = len(states)
    picks = set(np.linspace(0, n - 1, min(count, n)).round().astype(int).tolist())
    extra = sorted(set(int(i) for i in event_steps) - picks)
    if len(extra) > count:
        extra = [extra[int(k)] for k in np.linspace(0, len(extra) - 1, count).round()]
    return sorted(picks | set(extra))


def path_box(states: Sequence, lines: Sequence[np.ndarray], margin: float = 0.15
             ) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return the box (lo (3,), hi (3,)) around the whisker's path that the scene is clipped to.

    Parameters
    ----------
    states : sequence of RodState
        Every state (their base points, tips and contact points are inside).
    lines : sequence of numpy.ndarray
        The drawn centerlines (k, 3).
    margin : float, optional
        Added on every side [L]; the box is at least 0.4 L wide in every direction.

    Returns
    -------
    tuple of numpy.ndarray
        The corners lo and hi [L].

    """
    pts = [np.asarray(s.pose.position) for s in states] + [np.asarray(s.tip) for s in states]
    pts += [np.asarray(c.point) for s in states for c in s.contacts]
    pts = np.vstack([np.array(pts)] + [np.asarray(line) for line in lines])
    lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
    mid, half = 0.5 * (lo + hi), np.maximum(0.5 * (hi - lo), 0.2)
    return mid - half, mid + half


def _reach_planes(scene, lo: np.ndarray, hi: np.ndarray, reach: float = 0.5):
    """Grow the box to a half-space's boundary that misses it by less than ``reach`` [L]."""
    lo, hi = lo.copy(), hi.copy()
    for ob in scene:
        if ob.kind != "plane":
            continue
        n = np.asarray(ob.normal, dtype=float)
        corners = np.array([[(lo, hi)[(k >> j) & 1][j] for j in range(3)] for k in range(8)])
        d = (corners - np.asarray(ob.point, dtype=float)) @ n
        gap = float(d.min())
        if gap <= 0.0 or gap > reach:  # cuts the box already, or far away
            continue
        j = int(np.argmax(np.abs(n)))
        step = (gap + 0.05) / abs(n[j])
        if n[j] > 0.0:
            lo[j] -= step
        else:
            hi[j] += step
    return lo, hi


def _inside(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.all((points >= lo - 1e-12) & (points <= hi + 1e-12), axis=-1)


def _mesh(ax, X, Y, Z, lo, hi, gid: str) -> None:
    """Draw the quads of a surface grid whose centre lies in the box (translucent)."""
    P = np.stack((X, Y, Z), axis=-1)
    quads = np.stack((P[:-1, :-1], P[1:, :-1], P[1:, 1:], P[:-1, 1:]), axis=2)
    quads = quads.reshape(-1, 4, 3)
    keep = _inside(quads.mean(axis=1), lo, hi)
    if np.any(keep):
        ax.add_collection3d(Poly3DCollection(quads[keep], facecolor=SCENE_FILL, alpha=0.35,
                                             edgecolor=SCENE_EDGE, linewidth=0.15, gid=gid))


def _line_in_box(point, axis, lo, hi, pad: float):
    """Return the range (t0, t1) where point + t axis lies in the box grown by ``pad``."""
    t0, t1 = -math.inf, math.inf
    for k in range(3):
        a, b = lo[k] - pad, hi[k] + pad
        if abs(axis[k]) < 1e-15:
            if not a <= point[k] <= b:
                return None
            continue
        u, v = (a - point[k]) / axis[k], (b - point[k]) / axis[k]
        t0, t1 = max(t0, min(u, v)), min(t1, max(u, v))
    return (t0, t1) if t0 < t1 else None


def _basis(normal) -> Tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to ``normal`` and to each other."""
    n = np.asarray(normal, dtype=float)
    helper = np.array((1.0, 0.0, 0.0)) if abs(n[0]) < 0.9 else np.array((0.0, 1.0, 0.0))
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def _draw_sphere(ax, ob, lo, hi) -> None:
    u, v = np.meshgrid(np.linspace(0.0, 2.0 * math.pi, 37), np.linspace(0.0, math.pi, 19))
    c = np.asarray(ob.center, dtype=float)
    _mesh(ax, c[0] + ob.r * np.cos(u) * np.sin(v), c[1] + ob.r * np.sin(u) * np.sin(v),
          c[2] + ob.r * np.cos(v), lo, hi, f"obstacle:{ob.name}")


def _draw_cylinder(ax, ob, lo, hi) -> None:
    p, a = np.asarray(ob.point, dtype=float), np.asarray(ob.axis, dtype=float)
    span = _line_in_box(p, a, lo, hi, ob.r)
    if span is None:
        return
    e1, e2 = _basis(a)
    t, u = np.meshgrid(np.linspace(span[0], span[1], 25), np.linspace(0.0, 2.0 * math.pi, 37))
    P = (p[None, None, :] + t[..., None] * a + ob.r * (np.cos(u)[..., None] * e1
                                                       + np.sin(u)[..., None] * e2))
    _mesh(ax, P[..., 0], P[..., 1], P[..., 2], lo, hi, f"obstacle:{ob.name}")


def _draw_plane(ax, ob, lo, hi) -> None:
    """Draw the boundary plane inside the box: the polygon where it cuts the box's edges."""
    p, n = np.asarray(ob.point, dtype=float), np.asarray(ob.normal, dtype=float)
    corners = np.array([[(lo, hi)[(k >> j) & 1][j] for j in range(3)] for k in range(8)])
    d = (corners - p) @ n
    pts = []
    for i in range(8):
        for j in range(3):
            k = i | (1 << j)
            if k == i:
                continue
            if d[i] == 0.0:
                pts.append(corners[i])
            elif d[i] * d[k] < 0.0:
                pts.append(corners[i] + d[i] / (d[i] - d[k]) * (corners[k] - corners[i]))
    if len(pts) < 3:
        return
    pts = np.array(pts)
    centre = pts.mean(axis=0)
    e1, e2 = _basis(n)
    order = np.argsort(np.arctan2((pts - centre) @ e2, (pts - centre) @ e1))
    ax.add_collection3d(Poly3DCollection([pts[order]], facecolor=SCENE_FILL, alpha=0.3,
                                         edgecolor=SCENE_EDGE, linewidth=0.8,
                                         gid=f"obstacle:{ob.name}"))


def _draw_prism(ax, ob, lo, hi) -> None:
    """Draw a planar obstacle's outline inside the box, extruded over the box's z range."""
    planar, gid = ob.planar, f"obstacle:{ob.name}"
    z0, z1 = float(lo[2]), float(hi[2])
    if getattr(planar, "is_point", False):
        ax.plot([planar.x] * 2, [planar.y] * 2, [z0, z1], color=SCENE_EDGE, lw=2.0, gid=gid)
        return
    window = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    walls, rims = [], []
    for ring in planar.outline(300, window):
        ring = np.asarray(ring, dtype=float)
        for a, b in zip(ring[:-1], ring[1:]):
            middle = 0.5 * (a + b)
            if not (lo[0] <= middle[0] <= hi[0] and lo[1] <= middle[1] <= hi[1]):
                continue
            walls.append(((a[0], a[1], z0), (b[0], b[1], z0), (b[0], b[1], z1),
                          (a[0], a[1], z1)))
            rims += [((a[0], a[1], z), (b[0], b[1], z)) for z in (z0, z1)]
    if walls:
        ax.add_collection3d(Poly3DCollection(walls, facecolor=SCENE_FILL, alpha=0.3,
                                             edgecolor="none", gid=gid))
        ax.add_collection3d(Line3DCollection(rims, colors=SCENE_EDGE, linewidths=1.0, gid=gid))


_DRAW = {"sphere": _draw_sphere, "cylinder": _draw_cylinder, "plane": _draw_plane}


def draw_scene3d(ax, scene, lo, hi) -> None:
    """
    Draw a 3D scene's obstacles on 3D axes, clipped to the box [lo, hi].

    Every artist of obstacle ``name`` has gid ``"obstacle:<name>"``. The axes' limits are left
    to the caller.

    Parameters
    ----------
    ax : mpl_toolkits.mplot3d.axes3d.Axes3D
        The axes drawn on.
    scene : Scene3D
        The obstacles (whisker lengths).
    lo, hi : array_like
        The box's corners (3,) [L].

    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    for ob in scene:
        _DRAW.get(ob.kind, _draw_prism)(ax, ob, lo, hi)


def _spans(ax, counts: np.ndarray) -> None:
    """Shade the runs of poses with one, two, three or more contacts."""
    start = 0
    for i in range(1, len(counts) + 1):
        if i == len(counts) or counts[i] != counts[start]:
            k = min(int(counts[start]), 3)
            if k in CONTACT_SHADES:
                ax.axvspan(start - 0.5, i - 0.5, color=CONTACT_SHADES[k], alpha=0.08, lw=0,
                           gid=f"contacts{k}")
            start = i


def plot_scene_scan3d(scene, states: Sequence, events: Sequence = (),
                      event_steps: Sequence[int] = (), title: str = "",
                      sketch_count: int = 8) -> Figure:
    """
    Draw a 3D scan: the scene with whisker shapes and contacts, and the base load along the path.

    Parameters
    ----------
    scene : Scene3D
        The obstacles (whisker lengths).
    states : sequence of RodState
        The scan's states, one per pose, in order.
    events : sequence of RodEvent, optional
        The events crossed.
    event_steps : sequence of int, optional
        For each event, the index of the pose whose step crossed it (marked between that pose
        and the one before).
    title : str, optional
        The figure's title.
    sketch_count : int, optional
        About how many whisker shapes are drawn (evenly spread, plus the poses of events).

    Returns
    -------
    Figure
        The drawn figure; ``sketch_states`` are the states whose shapes are drawn and ``axes``
        holds ``scene``, ``force`` and ``moment``.

    """
    states = list(states)
    if not states:
        raise ValueError("a 3D scan figure needs at least one state")
    fig = plt.figure(figsize=(12, 10.5), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=[1.7, 1])
    ax3 = fig.add_subplot(grid[0, :], projection="3d")
    ax_f = fig.add_subplot(grid[1, 0])
    ax_m = fig.add_subplot(grid[1, 1], sharex=ax_f)
    out = Figure(fig, axes={"scene": ax3, "force": ax_f, "moment": ax_m})
    counts = np.array([len(s.contacts) for s in states])
    # -- the scene, the whisker's shapes, the contacts -----------------------------------------
    picks = _picks(states, event_steps, sketch_count)
    lines = [states[i].centerline(81) for i in picks]
    lo, hi = _reach_planes(scene, *path_box(states, lines))
    draw_scene3d(ax3, scene, lo, hi)
    track = np.array([c.point for s in states for c in s.contacts]).reshape(-1, 3)
    if len(track):
        ax3.plot(track[:, 0], track[:, 1], track[:, 2], ".", ms=2, color="#999999",
                 label="contact points (every pose)", gid="contact_track")
    seen = set()
    for i, line in zip(picks, lines):
        s = states[i]
        k = min(int(counts[i]), 3)
        ax3.plot(line[:, 0], line[:, 1], line[:, 2], color=CONTACT_COLORS[k], lw=1.3,
                 label=CONTACT_NAMES[k] if k not in seen else None, gid="centerline")
        seen.add(k)
        base = s.pose.position
        ax3.plot([base[0]], [base[1]], [base[2]], "^", ms=4, color="#444444", gid="base")
        for c in s.contacts:
            ax3.plot([c.point[0]], [c.point[1]], [c.point[2]], "o", ms=4.5, color="black",
                     gid=f"contact:{c.kind}")
        out.sketch_states.append(s)
    ax3.plot([], [], "o", ms=4.5, color="black", label="contact (drawn shapes)")
    ax3.set_xlim(lo[0], hi[0])
    ax3.set_ylim(lo[1], hi[1])
    ax3.set_zlim(lo[2], hi[2])
    ax3.set_box_aspect(tuple(hi - lo))
    ax3.set_xlabel("x [L]")
    ax3.set_ylabel("y [L]")
    ax3.set_zlabel("z [L]")
    ax3.set_title("scene and whisker shapes (world frame)")
    ax3.legend(loc="upper left", fontsize=8)
    # -- the base load along the path ----------------------------------------------------------
    index = np.arange(len(states))
    force = np.array([s.force for s in states], dtype=float).reshape(-1, 3)
    moment = np.array([s.moment for s in states], dtype=float).reshape(-1, 3)
    for j, axis in enumerate("xyz"):
        ax_f.plot(index, force[:, j], color=COMPONENT_COLORS[axis], lw=1.4, label=f"f{axis}",
                  gid=f"f{axis}")
        ax_m.plot(index, moment[:, j], color=COMPONENT_COLORS[axis], lw=1.4, label=f"m{axis}",
                  gid=f"m{axis}")
    for ax in (ax_f, ax_m):
        _spans(ax, counts)
        for e, step in zip(events, event_steps):
            ax.axvline(step - 0.5, color="black", lw=0.5, ls=":", gid=f"event:{e.kind}")
        ax.set_xlabel("pose index")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=8, loc="best")
    if len(events) <= _EVENT_LABELS:
        for e, step in zip(events, event_steps):
            ax_f.annotate(e.kind, (step - 0.5, 1.0), xycoords=("data", "axes fraction"),
                          rotation=90, fontsize=6, va="top", ha="right", color="#333333")
    ax_f.set_ylabel("force [EI/L²] (world frame)")
    ax_m.set_ylabel("moment about the base [EI/L] (world frame)")
    ax_f.set_title("total contact force on the whisker fx, fy, fz")
    ax_m.set_title("moment of the contact forces about the base mx, my, mz")
    if title:
        fig.suptitle(title)
    return out


__all__ = ["draw_scene3d", "path_box", "plot_scene_scan3d"]
