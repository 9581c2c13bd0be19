"""The ``vibrissa`` command line: each verb parses its arguments and calls a library function."""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Dict, List, Optional

from .core.errors import VibrissaError
from .core.models import MODELS, make_model
from .core.profiles import PROFILE_PARAMETERS, make_profile
from .core.scan import run_scan, scan_grid
from .scan_io import write_events_json, write_scan_csv


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line and exits with status 2."""

    def error(self, message):  # noqa: D401 - argparse API
        self.exit(2, f"{self.prog}: error: {message}\n")


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} must be finite")
    return value


def _positive(text: str) -> float:
    value = _finite(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return value


def _param(text: str):
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=VALUE (e.g. p0=0.3)")
    return key.strip(), _finite(value)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="vibrissa", description="Virtual whisker: exact quasistatic elastica scans.")
    sub = parser.add_subparsers(dest="verb", required=True, parser_class=_Parser)
    scan = sub.add_parser(
        "scan",
        help="sweep the foot along the x-axis past an obstacle and write the states",
        description="Sweep the whisker's foot along the x-axis (heading +y) past a convex obstacle. "
        "Dimensionless units: length L, force EI/L^2, moment EI/L.",
    )
    names = ", ".join(f"{p} ({', '.join(ks)})" for p, ks in PROFILE_PARAMETERS.items())
    scan.add_argument("--profile", required=True, choices=sorted(PROFILE_PARAMETERS), help=f"obstacle: {names}")
    scan.add_argument("--param", action="append", type=_param, default=[], metavar="NAME=VALUE",
                      help="profile parameter, repeatable (e.g. --param p0=0.3 --param k=1)")
    scan.add_argument("--model", default="elastica", choices=sorted(MODELS) + ["both"],
                      help="whisker model: elastica (paper §2), rigid (paper §3) or both side by side")
    scan.add_argument("--spring-stiffness", type=_positive, default=None, metavar="K",
                      help="rigid model: pivot stiffness c = K*EI/L; its forces and moments are then "
                      "written in the elastica's units (EI/L^2, EI/L). Without it the rigid model is "
                      "written in the paper's §3 units (c/L, c). Default with --model both: 3, the "
                      "stiffness that matches the elastica's small-deflection tip stiffness")
    scan.add_argument("--from", dest="x_from", type=_finite, required=True, help="first foot position x0")
    scan.add_argument("--to", dest="x_to", type=_finite, required=True, help="last foot position x0 (inclusive)")
    scan.add_argument("--step", type=_positive, required=True, help="grid spacing of x0 (> 0)")
    scan.add_argument("--back", action="store_true", help="append the sweep back to --from")
    scan.add_argument("--csv", required=True, help="output CSV ('-' for standard output)")
    scan.add_argument("--events", help="output events JSON")
    scan.set_defaults(func=_cmd_scan)

    sweep = sub.add_parser(
        "sweep",
        help="drive a whisker_node through a sweep of foot poses and write its answers (SI)",
        description="Publish foot poses along the world x-axis to a whisker_node, one at a time, and write "
        "the wrench (base frame) and contact state it answers to a CSV in SI units. With --launch, start "
        "whisker_node with that parameter file first and stop it at the end.",
    )
    sweep.add_argument("--launch", metavar="PARAMS.yaml", help="start whisker_node with this parameter file")
    sweep.add_argument("--node", default="/whisker_node", help="the node's name with namespace (topic prefix)")
    sweep.add_argument("--from", dest="x_from", type=_finite, required=True, help="first foot x [m]")
    sweep.add_argument("--to", dest="x_to", type=_finite, required=True, help="last foot x [m] (inclusive)")
    sweep.add_argument("--step", type=_positive, required=True, help="spacing of foot x [m] (> 0)")
    sweep.add_argument("--back", action="store_true", help="append the sweep back to --from")
    sweep.add_argument("--y", type=_finite, default=0.0, help="foot y [m] (default 0)")
    sweep.add_argument("--yaw-deg", type=_finite, default=90.0, help="base yaw [deg] (default 90: whisker along +y)")
    sweep.add_argument("--frame", default="world", help="frame_id of the poses (the node's world_frame)")
    sweep.add_argument("--timeout", type=_positive, default=10.0, help="seconds to wait for each answer")
    sweep.add_argument("--csv", required=True, help="output CSV ('-' for standard output)")
    sweep.set_defaults(func=_cmd_sweep)
    return parser


def _params(pairs: List) -> Dict[str, float]:
    out: Dict[str, float] = {}
    for key, value in pairs:
        if key in out:
            raise VibrissaError(f"parameter {key} given twice")
        out[key] = value
    return out


def rigid_output_path(path: str) -> str:
    """Where ``--model both`` writes the rigid model's file: ``scan.csv`` -> ``scan.rigid.csv``."""
    stem, dot, ext = path.rpartition(".")
    return f"{stem}.rigid.{ext}" if dot and "/" not in ext else f"{path}.rigid"


def _cmd_scan(args) -> int:
    try:
        profile = make_profile(args.profile, _params(args.param))
        grid = scan_grid(args.x_from, args.x_to, args.step, args.back)
        if args.model == "both" and args.csv == "-":
            raise VibrissaError("--model both writes two CSV files: give --csv a file name, not '-'")
        if args.spring_stiffness is not None and args.model == "elastica":
            raise VibrissaError("--spring-stiffness applies to --model rigid or both, not elastica")
        stiffness = args.spring_stiffness or (3.0 if args.model == "both" else 1.0)
        runs = []
        for name in (["elastica", "rigid"] if args.model == "both" else [args.model]):
            model = make_model(name, stiffness=stiffness) if name == "rigid" else make_model(name)
            suffix = args.model == "both" and name == "rigid"
            csv_path = rigid_output_path(args.csv) if suffix else args.csv
            events_path = rigid_output_path(args.events) if (suffix and args.events) else args.events
            runs.append((model, csv_path, events_path))
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    for model, csv_path, events_path in runs:
        try:
            result = run_scan(profile, grid, model=model)
        except VibrissaError as exc:
            print(f"vibrissa scan: error: {model.name} model: {exc}", file=sys.stderr)
            return 2 if isinstance(exc, ValueError) else 1
        if csv_path == "-":
            write_scan_csv(result.states, sys.stdout)
        else:
            with open(csv_path, "w", newline="") as stream:
                write_scan_csv(result.states, stream)
        if events_path:
            with open(events_path, "w") as stream:
                write_events_json(result.events, stream)
    return 0


def _cmd_sweep(args) -> int:
    try:
        grid = scan_grid(args.x_from, args.x_to, args.step, args.back)
    except VibrissaError as exc:
        print(f"vibrissa sweep: error: {exc}", file=sys.stderr)
        return 2
    if args.launch and not os.path.isfile(args.launch):
        print(f"vibrissa sweep: error: --launch {args.launch!r}: no such parameter file", file=sys.stderr)
        return 2
    try:
        from .sweep import launch_node, run_sweep, stop_node, write_sweep_csv
    except ImportError as exc:  # ROS 2 is an optional dependency of the package
        print(f"vibrissa sweep: error: ROS 2 is not installed ({exc}); pip install '.[ros]'", file=sys.stderr)
        return 2
    yaw = math.radians(args.yaw_deg)
    poses = [(float(x), args.y, yaw) for x in grid]
    node_namespace = args.node.rsplit("/", 1)[0]
    proc = launch_node(args.launch, node_namespace) if args.launch else None
    code = 0
    try:
        rows = run_sweep(poses, node=args.node, frame=args.frame, timeout=args.timeout, progress=sys.stderr)
    except (TimeoutError, VibrissaError) as exc:
        print(f"vibrissa sweep: error: {exc}", file=sys.stderr)
        code = 1
    finally:
        if proc is not None:
            node_code = stop_node(proc)
            if node_code != 0 and code == 0:
                print(f"vibrissa sweep: error: whisker_node exited with status {node_code}", file=sys.stderr)
                code = 1
    if code:
        return code
    if args.csv == "-":
        write_sweep_csv(rows, sys.stdout)
    else:
        with open(args.csv, "w", newline="") as stream:
            write_sweep_csv(rows, stream)
    contact = sum(1 for r in rows if r.phase)
    print(f"vibrissa sweep: {len(rows)} poses answered ({contact} in contact) -> {args.csv}", file=sys.stderr)
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
