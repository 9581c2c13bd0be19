"""
The paper's figures from any scan or log (matplotlib, Agg backend, deterministic PNGs).

One figure, four panels: the configuration sketch (obstacle and centerlines at well-chosen foot
positions, coloured by phase, contact points marked, equal axes; paper Figs 2.1, 2.4, 3.1), and
the observables against the foot position, m0 and f (Figs 2.2, 2.5, 3.2), fx and fy (Figs 2.3,
2.6), s1 (Fig. 3.3), with the phases shaded and the events marked. A back-and-forth sweep draws
each direction as its own curve with arrows along the direction of travel (the hysteresis loops);
a second model (``--model both``) is drawn dashed on the same axes.

The plotting code only draws :class:`PlotRun` values; it never computes mechanics.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..core.profiles import ConvexProfile, Peg  # noqa: E402
from ..core.state import Event, WhiskerState  # noqa: E402

PHASE_COLORS = {0: "#7f7f7f", 1: "#1f77b4", 2: "#d62728"}
PHASE_NAMES = {0: "free", 1: "tangential (phase 1)", 2: "tip (phase 2)"}
SHADE = {1: "#1f77b4", 2: "#d62728"}


@dataclass(frozen=True)
class AxisUnits:
    """Axis units: dimensionless for scans, SI for logs (with the frame named)."""

    length: str = "L"
    force: str = "EI/L²"
    moment: str = "EI/L"
    scale_length: float = 1.0
    scale_force: float = 1.0
    scale_moment: float = 1.0
    frame: str = "paper frame"


@dataclass(frozen=True)
class PlotRun:
    """One model's run: states in travel order and the events crossed."""

    label: str
    states: Tuple[WhiskerState, ...]
    events: Tuple[Event, ...] = ()
    event_steps: Tuple[int, ...] = ()  # index of the state whose step crossed each event


@dataclass
class Figure:
    """The drawn figure and what was drawn where (for tests and callers)."""

    figure: "matplotlib.figure.Figure"
    sketch_states: List[WhiskerState] = field(default_factory=list)
    axes: dict = field(default_factory=dict)

    def save(self, path: str, dpi: int = 100, small: bool = False) -> None:
        """
        Write a PNG (no timestamp or software stamp: the same data gives the same file).

        ``small`` quantizes it to 256 colours, about 3x smaller, for documentation.
        """
        if not small:
            self.figure.savefig(path, dpi=dpi, metadata={"Software": None})
        else:
            import io

            from PIL import Image

            buffer = io.BytesIO()
            self.figure.savefig(buffer, dpi=dpi, format="png", metadata={"Software": None})
            buffer.seek(0)
            Image.open(buffer).convert("RGB").quantize(
                256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
            ).save(path, optimize=True)
        plt.close(self.figure)


def _foot_x(item) -> float:
    return item.pose.x


def _foot_heading(item) -> float:
    return item.pose.heading


#: what the observables are drawn against: the foot's x (a scan) or its heading (whisking)
ABSCISSAE = {"x0": _foot_x, "heading": _foot_heading}


def direction_segments(states: Sequence[WhiskerState], key=_foot_x) -> List[Tuple[int, int]]:
    """[start, end) index ranges of monotone foot travel (a back-and-forth sweep gives two)."""
    x = np.array([key(s) for s in states])
    if len(x) < 3:
        return [(0, len(x))]
    d = np.sign(np.diff(x))
    segments, start = [], 0
    for i in range(1, len(d)):
        if d[i] != 0 and d[i - 1] != 0 and d[i] != d[i - 1]:
            segments.append((start, i + 1))
            start = i
    segments.append((start, len(x)))
    return segments


def sketch_selection(
    states: Sequence[WhiskerState], events: Sequence[Event], count: int = 15, key=_foot_x
) -> List[int]:
    """
    Return the indices of ~``count`` states for the configuration sketch.

    The first contact state, the states next to every event (the last one before a snap
    included), then evenly spread contact states.
    """
    contact = [i for i, s in enumerate(states) if s.phase]
    if not contact:
        return [0]
    chosen = {contact[0], contact[-1]}
    xs = np.array([key(s) for s in states])
    for e in events:
        if e.kind == "snap":
            before = [i for i in contact if (xs[i] - key(e)) * (xs[contact[0]] - key(e)) >= 0]
            if before:
                chosen.add(max(before, key=lambda i: -abs(xs[i] - key(e))))
        else:
            near = min(contact, key=lambda i: abs(xs[i] - key(e)))
            chosen.add(near)
    for i in np.linspace(contact[0], contact[-1], max(count - len(chosen), 2)).round().astype(int):
        if states[int(i)].phase and len(chosen) < count:
            chosen.add(int(i))
    return sorted(chosen)


def _profile_curve(profile: ConvexProfile, xs: np.ndarray, top: float) -> np.ndarray:
    lo, hi = profile.alpha_min + 1e-6, profile.alpha_max - 1e-6
    alphas = np.linspace(lo, hi, 2001)
    pts = np.array([profile.point(float(a)) for a in alphas])
    keep = (pts[:, 1] <= top) & (pts[:, 0] >= xs.min() - 0.5) & (pts[:, 0] <= xs.max() + 0.5)
    return pts[keep]


def plot_runs(
    runs: Sequence[PlotRun],
    profile: Optional[ConvexProfile],
    units: AxisUnits = AxisUnits(),
    title: str = "",
    sketch_count: int = 15,
    abscissa: str = "x0",
) -> Figure:
    """
    Draw the figure for one or two models' runs (the first drives the sketch).

    Parameters
    ----------
    runs : sequence of PlotRun
        One or two models' runs; the first drives the sketch.
    profile : ConvexProfile or None
        The obstacle drawn in the sketch; None: none.
    units : AxisUnits, optional
        The axes' units: dimensionless for scans (the default), SI for logs.
    title : str, optional
        The figure's title.
    sketch_count : int, optional
        About how many whisker shapes the sketch draws.
    abscissa : {'x0', 'heading'}, optional
        Draw the observables against the foot's ``x0`` (a scan) or its ``heading`` (whisking).

    Returns
    -------
    Figure
        The drawn figure and what was drawn where.

    """
    coord = ABSCISSAE[abscissa]
    scale_key = units.scale_length if abscissa == "x0" else 1.0
    xlabel = f"foot position x0 [{units.length}]" if abscissa == "x0" else "foot heading [rad]"
    fig = plt.figure(figsize=(11, 9.5), layout="constrained")
    grid = fig.add_gridspec(3, 2, height_ratios=[1.25, 1, 1])
    ax_sketch = fig.add_subplot(grid[0, :])
    ax_m = fig.add_subplot(grid[1, 0])
    ax_fxy = fig.add_subplot(grid[1, 1], sharex=ax_m)
    ax_s1 = fig.add_subplot(grid[2, 0], sharex=ax_m)
    ax_f = fig.add_subplot(grid[2, 1], sharex=ax_m)
    out = Figure(
        fig, axes={"sketch": ax_sketch, "m0": ax_m, "fxy": ax_fxy, "s1": ax_s1, "f": ax_f}
    )
    main = runs[0]
    L, F, M = units.scale_length, units.scale_force, units.scale_moment

    # -- configuration sketch ----------------------------------------------------------------
    first = direction_segments(main.states, coord)[0]
    states = main.states[first[0]:first[1]]
    if main.event_steps:
        first_events = [
            e for e, i in zip(main.events, main.event_steps) if first[0] < i < first[1]
        ]
    else:
        first_events = list(main.events)
    picks = sketch_selection(states, first_events, sketch_count, coord)
    xs = np.array([s.x0 for s in main.states]) * L
    if isinstance(profile, Peg):
        ring = np.linspace(0.0, 2.0 * np.pi, 241)
        px, py = (profile.x + profile.r * np.cos(ring)) * L, (
            profile.y + profile.r * np.sin(ring)
        ) * L
        ax_sketch.fill(px, py, color="#c8a27a", alpha=0.6, lw=0)
        ax_sketch.plot(px, py, color="#8c5a2b", lw=1.5, label="peg", gid="obstacle")
        ax_sketch.plot(profile.x * L, profile.y * L, "+", color="#8c5a2b", ms=5)
    elif profile is not None:
        curve = _profile_curve(profile, xs / L, 1.6) * L
        ax_sketch.fill_between(
            curve[:, 0], curve[:, 1], 1.6 * L, color="#c8a27a", alpha=0.45, lw=0
        )
        ax_sketch.plot(
            curve[:, 0], curve[:, 1], color="#8c5a2b", lw=1.5, label="obstacle", gid="obstacle"
        )
    seen_phases = set()
    for i in picks:
        s = states[i]
        line = s.centerline(81) * L
        label = PHASE_NAMES[int(s.phase)] if int(s.phase) not in seen_phases else None
        seen_phases.add(int(s.phase))
        ax_sketch.plot(
            line[:, 0],
            line[:, 1],
            color=PHASE_COLORS[int(s.phase)],
            lw=1.3,
            label=label,
            gid="centerline",
        )
        if s.contact is not None:
            ax_sketch.plot(
                s.contact[0] * L, s.contact[1] * L, "o", ms=3.5, color="black", gid="contact"
            )
        ax_sketch.plot(s.x0 * L, s.pose.y * L, "^", ms=4, color="#444444", gid="foot")
        out.sketch_states.append(s)
    drawn = np.vstack([s.centerline(81) for s in out.sketch_states]) * L
    contacts = [c for s in out.sketch_states if (c := s.contact) is not None]
    x_lo = min(drawn[:, 0].min(), min((c[0] for c in contacts), default=0) * L) - 0.35 * L
    x_hi = max(drawn[:, 0].max(), max((c[0] for c in contacts), default=0) * L) + 0.35 * L
    ax_sketch.set_xlim(x_lo, x_hi)
    ax_sketch.set_ylim(
        min(drawn[:, 1].min(), 0.0) - 0.05 * L, 1.45 * L + max(0.0, drawn[:, 1].max() - L)
    )
    ax_sketch.set_aspect("equal", adjustable="box")
    ax_sketch.set_xlabel(f"x [{units.length}] ({units.frame})")
    ax_sketch.set_ylabel(f"y [{units.length}]")
    ax_sketch.set_title(
        "configurations during the scan"
        + (" (first sweep direction)" if len(direction_segments(main.states, coord)) > 1 else "")
    )
    ax_sketch.legend(loc="upper right", fontsize=8)

    # -- observables ---------------------------------------------------------------------------
    styles = ["-", "--"]
    for k, run in enumerate(runs):
        st = run.states
        x = np.array([coord(s) for s in st]) * scale_key
        series = {
            "m0": np.array([s.m0 for s in st]) * M,
            "f": np.array([s.f for s in st]) * F,
            "fx": np.array([s.fx for s in st]) * F,
            "fy": np.array([s.fy for s in st]) * F,
            "s1": np.array([np.nan if s.s1 is None else s.s1 for s in st]) * L,
        }
        segments = direction_segments(st, coord)
        for d, (a, b) in enumerate(segments):
            tag = f"{run.label}" + (f", sweep {d + 1}" if len(segments) > 1 else "")
            for ax, key, color in (
                (ax_m, "m0", "#2ca02c"),
                (ax_f, "f", "#9467bd"),
                (ax_fxy, "fx", "#ff7f0e"),
                (ax_fxy, "fy", "#17becf"),
                (ax_s1, "s1", "#8c564b"),
            ):
                alpha = 1.0 if d == 0 else 0.55
                (line,) = ax.plot(
                    x[a:b],
                    series[key][a:b],
                    styles[k % 2],
                    color=color,
                    lw=1.4,
                    alpha=alpha,
                    label=f"{key} ({tag})",
                    gid=f"{run.label}:{key}:{d}",
                )
                if len(segments) > 1:
                    _arrows(ax, x[a:b], series[key][a:b], color, alpha)
    # phases shaded (first run, first direction) and events marked (all of the first run)
    a, b = first
    x = np.array([coord(s) for s in main.states[a:b]]) * scale_key
    ph = np.array([int(s.phase) for s in main.states[a:b]])
    for ax in (ax_m, ax_f, ax_fxy, ax_s1):
        start = 0
        for i in range(1, len(ph) + 1):
            if i == len(ph) or ph[i] != ph[start]:
                if ph[start] in SHADE:
                    ax.axvspan(
                        min(x[start], x[i - 1]),
                        max(x[start], x[i - 1]),
                        color=SHADE[ph[start]],
                        alpha=0.08,
                        lw=0,
                        gid=f"phase{ph[start]}",
                    )
                start = i
        for e in main.events:
            ax.axvline(coord(e) * scale_key, color="black", lw=0.6, ls=":", gid=f"event:{e.kind}")
    for e in main.events:
        ax_m.annotate(
            e.kind,
            (coord(e) * scale_key, 1.0),
            xycoords=("data", "axes fraction"),
            fontsize=7,
            rotation=90,
            va="top",
            ha="right",
        )
    ax_m.set_ylabel(f"m0 [{units.moment}]")
    ax_f.set_ylabel(f"f [{units.force}]")
    ax_fxy.set_ylabel(f"fx, fy [{units.force}] ({units.frame})")
    ax_s1.set_ylabel(f"s1 [{units.length}]")
    for ax in (ax_m, ax_f, ax_fxy, ax_s1):
        ax.set_xlabel(xlabel)
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=7, loc="best")
    ax_m.set_title("base moment m0 (κ(0), ccw positive)")
    ax_f.set_title("contact force f")
    ax_fxy.set_title("force on the whisker fx, fy")
    ax_s1.set_title("contact arc length s1")
    if title:
        fig.suptitle(title)
    return out


def _arrows(ax, x, y, color, alpha) -> None:
    """Arrows along a curve in its direction of travel, at a few places where it is defined."""
    ok = np.flatnonzero(np.isfinite(y))
    if len(ok) < 8:
        return
    for frac in (0.3, 0.6, 0.85):
        i = ok[int(frac * (len(ok) - 2))]
        j = min(i + max(1, len(ok) // 50), len(x) - 1)
        if not (np.isfinite(y[i]) and np.isfinite(y[j])) or (x[i] == x[j] and y[i] == y[j]):
            continue
        ax.annotate(
            "",
            xy=(x[j], y[j]),
            xytext=(x[i], y[i]),
            arrowprops=dict(arrowstyle="->", color=color, alpha=alpha, lw=1.2),
            gid="arrow",
        )


def si_units(length: float, force: float, moment: float, frame: str) -> AxisUnits:
    return AxisUnits("m", "N", "N·m", length, force, moment, f"frame '{frame}'")


#: shading of the observables by the number of contacts (1, 2, 3 or more)
CONTACT_SHADES = {1: "#1f77b4", 2: "#d62728", 3: "#9467bd"}
CONTACT_NAMES = {0: "free", 1: "one contact", 2: "two contacts", 3: "three or more"}
CONTACT_COLORS = {0: "#7f7f7f", 1: "#1f77b4", 2: "#d62728", 3: "#9467bd"}


def plot_scene_scan(scene, states: Sequence, events: Sequence = (), title: str = "",
                    sketch_count: int = 14, abscissa: str = "x0",
                    units: AxisUnits = AxisUnits()) -> Figure:
    """
    Draw a scene scan: the scene, whisker shapes and every contact, and the observables.

    Top: the obstacles (:func:`draw_scene`), centerlines at evenly spread poses coloured by the
    number of contacts, each contact marked (filled square: sticking, open circle: slipping).
    Below: the base load m0 and fx, fy (what the follicle's sensor measures), the number of
    contacts with the nearest contact's force, and every contact's arc length s; the spans
    with one, two, three contacts are shaded and the events marked.

    Parameters
    ----------
    scene : Scene
        The obstacles (whisker lengths).
    states : sequence
        The scan's scene states, in travel order.
    events : sequence, optional
        The scene events crossed, marked on the observables.
    title : str, optional
        The figure's title.
    sketch_count : int, optional
        About how many whisker shapes the sketch draws.
    abscissa : {'x0', 'heading'}, optional
        Draw the observables against the foot's ``x0`` (a scan) or its ``heading`` (whisking).
    units : AxisUnits, optional
        The axes' units: dimensionless for scans (the default), SI for logs.

    Returns
    -------
    Figure
        The drawn figure and what was drawn where.

    """
    coord = ABSCISSAE[abscissa]
    L, F, M = units.scale_length, units.scale_force, units.scale_moment
    scale_key = L if abscissa == "x0" else 1.0
    xlabel = f"foot position x0 [{units.length}]" if abscissa == "x0" else "foot heading [rad]"
    fig = plt.figure(figsize=(11, 10), layout="constrained")
    grid = fig.add_gridspec(3, 2, height_ratios=[1.35, 1, 1])
    ax_sketch = fig.add_subplot(grid[0, :])
    ax_m = fig.add_subplot(grid[1, 0])
    ax_fxy = fig.add_subplot(grid[1, 1], sharex=ax_m)
    ax_n = fig.add_subplot(grid[2, 0], sharex=ax_m)
    ax_s = fig.add_subplot(grid[2, 1], sharex=ax_m)
    out = Figure(fig, axes={"sketch": ax_sketch, "m0": ax_m, "fxy": ax_fxy, "contacts": ax_n,
                            "s": ax_s})
    states = list(states)
    counts = np.array([len(s.contacts) for s in states])
    # -- the scene and the whisker ---------------------------------------------------------------
    first = direction_segments(states, coord)[0]
    picks = set(np.linspace(first[0], first[1] - 1, min(sketch_count, first[1] - first[0]))
                .round().astype(int).tolist())
    picks |= {i for i in range(1, len(states)) if counts[i] != counts[i - 1]
              and first[0] <= i < first[1]}
    seen = set()
    drawn = []
    for i in sorted(picks):
        s = states[i]
        line = s.centerline(81)
        drawn.append(line)
        k = min(int(counts[i]), 3)
        ax_sketch.plot(line[:, 0] * L, line[:, 1] * L, color=CONTACT_COLORS[k], lw=1.2,
                       label=CONTACT_NAMES[k] if k not in seen else None, gid="centerline")
        seen.add(k)
        for c in s.contacts:
            stick = c.state == "stick"
            ax_sketch.plot(c.x * L, c.y * L, "s" if stick else "o", ms=4.5,
                           mfc="black" if stick else "none", mec="black",
                           gid=f"contact:{c.state}")
        ax_sketch.plot(s.pose.x * L, s.pose.y * L, "^", ms=4, color="#444444", gid="foot")
        out.sketch_states.append(s)
    pts = np.vstack(drawn)
    lo, hi = pts.min(axis=0) - 0.3, pts.max(axis=0) + 0.3
    draw_scene(ax_sketch, scene, window=(lo[0], lo[1], hi[0], hi[1]), scale_length=L)
    ax_sketch.plot([], [], "s", mfc="black", mec="black", label="contact, sticking")
    ax_sketch.plot([], [], "o", mfc="none", mec="black", label="contact, slipping")
    ax_sketch.set_xlim(lo[0] * L, hi[0] * L)
    ax_sketch.set_ylim(lo[1] * L, hi[1] * L)
    ax_sketch.set_aspect("equal", adjustable="box")
    ax_sketch.set_xlabel(f"x [{units.length}] ({units.frame})")
    ax_sketch.set_ylabel(f"y [{units.length}]")
    ax_sketch.set_title("scene and whisker shapes"
                        + (" (first sweep direction)"
                           if len(direction_segments(states, coord)) > 1 else ""))
    ax_sketch.legend(loc="upper right", fontsize=8)
    # -- observables ---------------------------------------------------------------------------
    x = np.array([coord(s) for s in states]) * scale_key
    segments = direction_segments(states, coord)
    series = {
        "m0": (ax_m, np.array([s.m0 for s in states]) * M, "#2ca02c"),
        "fx": (ax_fxy, np.array([s.fx for s in states]) * F, "#ff7f0e"),
        "fy": (ax_fxy, np.array([s.fy for s in states]) * F, "#17becf"),
        "f (nearest)": (ax_n, np.array([s.f for s in states]) * F, "#9467bd"),
    }
    for d, (a, b) in enumerate(segments):
        alpha = 1.0 if d == 0 else 0.55
        tag = f", sweep {d + 1}" if len(segments) > 1 else ""
        for key, (ax, y, color) in series.items():
            ax.plot(x[a:b], y[a:b], color=color, lw=1.4, alpha=alpha, label=f"{key}{tag}",
                    gid=f"{key}:{d}")
            if len(segments) > 1:
                _arrows(ax, x[a:b], y[a:b], color, alpha)
    ax_count = ax_n.twinx()
    ax_count.step(x, counts, where="mid", color="black", lw=1.0, label="contacts",
                  gid="contacts")
    ax_count.set_ylabel("number of contacts")
    ax_count.set_ylim(-0.1, max(3, int(counts.max()) + 0.5))
    for i, s in enumerate(states):
        for c in s.contacts:
            ax_s.plot(x[i], c.s * L, "s" if c.state == "stick" else ".", ms=3,
                      color=CONTACT_COLORS[min(c.obstacle + 1, 3)], gid="contact_s")
    for ax in (ax_m, ax_fxy, ax_n, ax_s):
        start = 0
        for i in range(1, len(counts) + 1):
            if i == len(counts) or counts[i] != counts[start]:
                k = min(int(counts[start]), 3)
                if k in CONTACT_SHADES:
                    ax.axvspan(min(x[start], x[i - 1]), max(x[start], x[i - 1]),
                               color=CONTACT_SHADES[k], alpha=0.08, lw=0, gid=f"contacts{k}")
                start = i
        for e in events:
            ax.axvline(coord(e) * scale_key, color="black", lw=0.5, ls=":",
                       gid=f"event:{e.kind}")
        ax.set_xlabel(xlabel)
        ax.grid(True, lw=0.3, alpha=0.5)
    ax_m.set_ylabel(f"m0 [{units.moment}]")
    ax_fxy.set_ylabel(f"fx, fy [{units.force}] ({units.frame})")
    ax_n.set_ylabel(f"f [{units.force}]")
    ax_s.set_ylabel(f"contact arc length s [{units.length}]")
    ax_m.set_title("base moment m0 (total, ccw positive)")
    ax_fxy.set_title("total force on the whisker fx, fy")
    ax_n.set_title("number of contacts; force of the nearest")
    ax_s.set_title("contact arc lengths (colour: obstacle; square: sticking)")
    for ax in (ax_m, ax_fxy, ax_n):
        ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title)
    return out


__all__ = [
    "plot_scene_scan",
    "Figure",
    "PlotRun",
    "AxisUnits",
    "direction_segments",
    "plot_runs",
    "si_units",
    "sketch_selection",
]


#: scene colours: obstacles filled and outlined like the single obstacle of the sketch
SCENE_FILL, SCENE_EDGE = "#c8a27a", "#8c5a2b"


def draw_scene(ax, scene, window: Optional[Tuple[float, float, float, float]] = None,
               scale_length: float = 1.0, names: bool = True, n: int = 300) -> None:
    """
    Draw a scene's obstacles on matplotlib axes: filled, outlined, corners marked.

    Convex corners are drawn as filled dots, reflex ones as open circles, point pegs as "+".
    Every artist of obstacle ``name`` has gid ``"obstacle:<name>"``. The axes' limits are left to
    the caller.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes drawn on.
    scene : Scene
        The obstacles (whisker lengths).
    window : tuple of float, optional
        (x_min, y_min, x_max, y_max) [L], bounds the infinite obstacles (default: the scene's
        own window, :meth:`Scene.window`).
    scale_length : float, optional
        Converts L to the axes' unit.
    names : bool, optional
        Write each obstacle's name at the centre of its extent.
    n : int, optional
        The number of points of each drawn outline (the obstacles' ``outline``).

    """
    window = scene.window() if window is None else window
    L = scale_length
    for ob in scene:
        gid = f"obstacle:{ob.name}"
        if getattr(ob, "is_point", False):
            ax.plot(ob.x * L, ob.y * L, "+", color=SCENE_EDGE, ms=9, mew=2, gid=gid)
        else:
            for ring in ob.outline(n, window):
                ax.fill(ring[:, 0] * L, ring[:, 1] * L, color=SCENE_FILL, alpha=0.6, lw=0,
                        gid=gid)
            for line in ob.boundary_lines(n, window):
                ax.plot(line[:, 0] * L, line[:, 1] * L, color=SCENE_EDGE, lw=1.5, gid=gid)
            corners = [v for v in ob.vertices]
            convex = np.array([(v.x, v.y) for v in corners if v.convex]).reshape(-1, 2)
            reflex = np.array([(v.x, v.y) for v in corners if not v.convex]).reshape(-1, 2)
            if len(convex):
                ax.plot(convex[:, 0] * L, convex[:, 1] * L, "o", color=SCENE_EDGE, ms=3.5,
                        gid=gid)
            if len(reflex):
                ax.plot(reflex[:, 0] * L, reflex[:, 1] * L, "o", mfc="none", color=SCENE_EDGE,
                        ms=4.5, gid=gid)
        if names:
            x0, y0, x1, y1 = ob.extent()
            ax.annotate(ob.name, (0.5 * (x0 + x1) * L, 0.5 * (y0 + y1) * L), fontsize=7,
                        color="#5a3a1b", ha="center", va="center", gid=gid)
