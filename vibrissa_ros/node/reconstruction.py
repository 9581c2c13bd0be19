"""
``vibrissa reconstruct``: the scanned contour from what the sensor measured (scan CSV or log).

Only the sensor's side of the data is read: foot poses and base wrenches (from a log), or the
columns x0, fx, fy, m0 (from a scan CSV); other columns are ignored by the estimate and used, when
present, only to draw the true contact points under the reconstruction.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from typing import IO, List, Optional, Sequence, Tuple

from ..core.errors import VibrissaError
from ..core.general.model import WhiskerShape
from ..core.exact.inverse import ContactEstimate, estimate_contact
from ..core.general.inverse import estimate_contact_general
from ..core.state import FootPose
from .edge import Units, header_ns, pose_of, wrench_to_core

RECONSTRUCTION_COLUMNS = ("x0", "phase", "contact_x", "contact_y", "alpha")


@dataclass(frozen=True)
class Reconstruction:
    """Estimates in the input's units and frame, and what the input says is true (if anything)."""

    estimates: List[ContactEstimate]  # dimensionless
    length: float  # input unit of length per L (1 for a scan CSV, L in m for a log)
    unit: str
    frame: str
    truth: List[
        Tuple[float, float]
    ]  # true contact points in input units, where the input carries them
    profile: Optional[object] = (
        None  # the true profile (dimensionless), where the input carries it
    )


def _estimate(pose: FootPose, fx: float, fy: float, m0: float, min_force: float,
              shape: Optional[WhiskerShape]) -> Optional[ContactEstimate]:
    """Estimate by the closed forms, or by the general whisker's inverse (taper, curvature)."""
    if shape is not None and not shape.is_paper:
        return estimate_contact_general(pose, fx, fy, m0, shape, min_force)
    return estimate_contact(pose, fx, fy, m0, min_force)


def from_scan_csv(path: str, min_force: float = 0.0,
                  shape: Optional[WhiskerShape] = None) -> Reconstruction:
    """
    Reconstruct from a scan CSV: columns x0 (or x, y, heading: ``--poses``), fx, fy, m0.

    ``shape``: the scanned whisker's taper and curvature (None: the paper's whisker).
    """
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    if not rows:
        raise VibrissaError(f"{path}: empty CSV")
    pose_columns = ("x0",) if "x0" in rows[0] or "x" not in rows[0] else ("x", "y", "heading")
    missing = set(pose_columns + ("fx", "fy", "m0")) - set(rows[0])
    if missing:
        raise VibrissaError(
            f"{path}: missing column(s) {', '.join(sorted(missing))}; need x0 (or x, y, heading),"
            " fx, fy, m0"
        )
    estimates, truth = [], []
    for i, row in enumerate(rows, start=2):
        try:
            pose = FootPose(*(float(row[k]) for k in pose_columns))
            fx, fy, m0 = (float(row[k]) for k in ("fx", "fy", "m0"))
        except (ValueError, VibrissaError):
            raise VibrissaError(f"{path}: line {i}: {', '.join(pose_columns)}, fx, fy, m0 must "
                                "be numbers") from None
        est = _estimate(pose, fx, fy, m0, min_force, shape)
        if est is not None:
            estimates.append(est)
        if row.get("contact_x") and row.get("contact_y"):
            truth.append((float(row["contact_x"]), float(row["contact_y"])))
    return Reconstruction(estimates, 1.0, "L", "paper frame", truth)


def from_log(path: str, min_force: float = 0.0) -> Reconstruction:
    """Pair every recorded foot pose with the wrench of its stamp (as whisker_node stamps it)."""
    from ..logs.tools import configurations
    from ..logs.mcap_log import read_log
    from .config import build_config
    from ..ros.serialization import decode

    _, _, metadata, messages = read_log(path)
    values = configurations(metadata)[0][1]
    cfg = build_config(values)
    node = values.get("node", "/whisker_node")
    poses, wrenches = {}, {}
    for m in messages:
        if m.topic == f"{node}/foot_pose":
            msg = decode(m)
            poses[header_ns(msg)] = msg
        elif m.topic == f"{node}/wrench":
            msg = decode(m)
            wrenches[header_ns(msg)] = msg
    units = cfg.units
    shape = cfg.model.shape if hasattr(cfg.model, "shape") else None  # as the log was made
    estimates = []
    for stamp in sorted(wrenches):
        if stamp not in poses:
            continue
        try:  # the node accepted only poses that pass its own checks
            x, y, yaw = pose_of(poses[stamp], cfg.values["input.z_tolerance"],
                                cfg.values["input.angle_tolerance"])
        except VibrissaError:
            continue
        w = wrenches[stamp].wrench
        est = estimate_from_wrench(x, y, yaw, w.force.x, w.force.y, w.torque.z, units, min_force,
                                   shape)
        if est is not None:
            estimates.append(est)
    points = (decode(m) for m in messages if m.topic == f"{node}/contact_point")
    truth = [(p.point.x, p.point.y) for p in points]
    return Reconstruction(
        estimates, units.length, "m", f"frame '{cfg.world_frame}'", truth, cfg.profile
    )


def estimate_from_wrench(x: float, y: float, yaw: float, force_x: float, force_y: float,
                         torque_z: float, units: Units,
                         min_force: float = 0.0,
                         shape: Optional[WhiskerShape] = None) -> Optional[ContactEstimate]:
    """
    One SI reading (base pose in the world, base-frame wrench) -> a dimensionless estimate.

    ``shape``: the whisker's taper and curvature in whisker lengths; anything but the paper's
    whisker uses :func:`~vibrissa_ros.core.general.inverse.estimate_contact_general`.
    """
    fx, fy, m0 = wrench_to_core(yaw, force_x, force_y, torque_z, units)
    return _estimate(units.foot_pose(x, y, yaw), fx, fy, m0, min_force / units.force, shape)


def write_csv(rec: Reconstruction, stream: IO[str]) -> None:
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(RECONSTRUCTION_COLUMNS)
    L = rec.length
    for e in rec.estimates:
        writer.writerow(
            [
                repr(e.pose.x * L),
                int(e.phase),
                repr(e.contact[0] * L),
                repr(e.contact[1] * L),
                repr(e.alpha),
            ]
        )


def plot(rec: Reconstruction, path: str, title: str = "") -> None:
    """Draw the reconstructed contact points (by phase) over the true profile / contact points."""
    import numpy as np

    from ..scan.plots import PHASE_COLORS, PHASE_NAMES, plt

    L = rec.length
    fig, (ax, ax_err) = plt.subplots(
        2, 1, figsize=(9, 8), layout="constrained", height_ratios=[2, 1]
    )
    if rec.profile is not None:
        prof = rec.profile
        alphas = np.linspace(prof.alpha_min + 1e-3, prof.alpha_max - 1e-3, 1500)
        pts = np.array([prof.point(float(a)) for a in alphas]) * L
        ys = np.array([e.contact[1] for e in rec.estimates] or [0.0]) * L
        keep = pts[:, 1] <= (ys.max() + 0.5 * L)
        ax.plot(
            pts[keep, 0],
            pts[keep, 1],
            color="#8c5a2b",
            lw=1.2,
            label="true profile",
            gid="profile",
        )
    if rec.truth:
        t = np.array(rec.truth)
        ax.plot(
            t[:, 0], t[:, 1], ".", ms=2, color="#999999", label="true contact points", gid="truth"
        )
    for phase in (1, 2):
        sel = [e for e in rec.estimates if int(e.phase) == phase]
        if sel:
            c = np.array([e.contact for e in sel]) * L
            ax.plot(
                c[:, 0],
                c[:, 1],
                "o",
                ms=2.5,
                color=PHASE_COLORS[phase],
                label=f"estimated, {PHASE_NAMES[phase]}",
                gid=f"estimate{phase}",
            )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"x [{rec.unit}] ({rec.frame})")
    ax.set_ylabel(f"y [{rec.unit}]")
    ax.legend(fontsize=8)
    ax.set_title(title or "contour reconstructed from the base wrench")
    if rec.truth and len(rec.truth) == len(rec.estimates):
        err = [math.dist(np.array(e.contact) * L, t) for e, t in zip(rec.estimates, rec.truth)]
        ax_err.semilogy(
            [e.pose.x * L for e in rec.estimates], np.maximum(err, 1e-17), ".", ms=2, gid="error"
        )
        ax_err.set_ylabel(f"|estimate - true contact| [{rec.unit}]")
    else:
        ax_err.plot(
            [e.pose.x * L for e in rec.estimates],
            [e.alpha for e in rec.estimates],
            ".",
            ms=2,
            gid="alpha",
        )
        ax_err.set_ylabel("profile slope alpha [rad]")
    ax_err.set_xlabel(f"foot position x0 [{rec.unit}]")
    ax_err.grid(True, lw=0.3)
    fig.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(fig)


def reconstruct_input(path: str, min_force: float = 0.0,
                      shape: Optional[WhiskerShape] = None) -> Reconstruction:
    """
    Reconstruct from a log (its recorded whisker) or a scan CSV (``shape``: its whisker).

    Parameters
    ----------
    path : str
        A whisker_node log (``.mcap``) or a scan CSV (columns x0, or x, y, heading, then fx, fy,
        m0).
    min_force : float, optional
        Readings with a force magnitude <= ``min_force`` are left out; in the input's force unit
        (N for a log, EI/L^2 for a scan CSV).
    shape : WhiskerShape or None, optional
        For a scan CSV: the scanned whisker's taper and curvature (None: the paper's whisker).
        A log carries its whisker's taper and curvature: giving ``shape`` for one is refused.

    Returns
    -------
    Reconstruction
        The estimates in the input's units and frame, and the truth where the input has it.

    Raises
    ------
    VibrissaError
        When ``shape`` is given for a log, or the input cannot be used (e.g. an empty CSV).

    """
    if path.endswith(".mcap"):
        if shape is not None:
            raise VibrissaError(f"{path}: a log carries its whisker's taper and curvature (its "
                                "recorded parameters); --taper/--curvature are for scan CSVs")
        return from_log(path, min_force)
    return from_scan_csv(path, min_force, shape)


__all__: Sequence[str] = [
    "Reconstruction",
    "reconstruct_input",
    "write_csv",
    "plot",
    "estimate_from_wrench",
]
