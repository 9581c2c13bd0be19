"""The ``vibrissa`` command line: each verb parses its arguments and calls a library function."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from typing import Dict, List, Optional

from .core.errors import VibrissaError
from .core.exact.models import MODELS, make_model
from .core.profiles import PROFILE_PARAMETERS, make_profile
from .core.general.model import WhiskerShape
from .core.scan import run_poses, run_scan, scan_grid, whisk_poses
from .node.parameters import ParameterSpec
from .scan.scan_io import read_poses_csv, write_events_json, write_scan_csv


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line and exits with status 2."""

    def error(self, message):  # noqa: D401 - argparse API
        self.exit(2, f"{self.prog}: error: {message}\n")


def _number(spec: ParameterSpec):
    """Return an argparse type: a number that ``spec`` allows (the nodes' parameter checks)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        problem = spec.problem(value)
        if problem is not None:
            raise argparse.ArgumentTypeError(f"{text!r} {problem}")
        return value

    return parse


_finite = _number(ParameterSpec("value", 0.0, ""))
_positive = _number(ParameterSpec("value", 1.0, "", minimum=0.0, exclusive_minimum=True))
_nonnegative = _number(ParameterSpec("value", 0.0, "", minimum=0.0))


def _taper(text: str) -> float:
    value = _finite(text)
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(
            f"{text!r}: the taper (tip radius / base radius) must be in (0, 1]"
        )
    return value


def _curvature(text: str):
    parts = text.split(",")
    if len(parts) > 2 or not all(p.strip() for p in parts):
        raise argparse.ArgumentTypeError(f"{text!r} is not K0 or K0,K1 (e.g. --curvature=-1,0.5)")
    values = [_finite(p) for p in parts]
    return (values[0], values[1] if len(values) == 2 else 0.0)


def _parabola(text: str) -> float:
    value = _finite(text)
    if abs(value) > 10.0:
        raise argparse.ArgumentTypeError(
            f"{text!r}: the parabola's coefficient A [1/L] must satisfy |A| <= 10"
        )
    return value


def _poisson(text: str) -> float:
    value = _finite(text)
    if not 0.0 <= value <= 0.5:
        raise argparse.ArgumentTypeError(f"{text!r}: the Poisson ratio must be in [0, 0.5]")
    return value


def _param(text: str):
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=VALUE (e.g. p0=0.3)")
    return key.strip(), _finite(value)


def _placement(text: str):
    parts = text.split(",")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"{text!r} is not X,Y,DEG (e.g. 0,0.1,15)")
    return tuple(_finite(p) for p in parts)


def _numbers(text: str):
    parts = text.split(",")
    if not all(p.strip() for p in parts):
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of numbers")
    return tuple(_finite(p) for p in parts)


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 1")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="vibrissa", description="Virtual whisker: exact quasistatic elastica scans."
    )
    sub = parser.add_subparsers(dest="verb", required=True, parser_class=_Parser)
    scan = sub.add_parser(
        "scan",
        help="sweep the foot along the x-axis past an obstacle and write the states",
        description="Sweep the whisker's foot along the x-axis (heading +y) past a convex "
        "obstacle, or whisk (--whisk), or follow any foot poses (--poses). "
        "Dimensionless units: length L, force EI/L^2, moment EI/L.",
    )
    names = ", ".join(f"{p} ({', '.join(ks)})" for p, ks in PROFILE_PARAMETERS.items())
    scan.add_argument(
        "--profile", choices=sorted(PROFILE_PARAMETERS),
        help=f"one obstacle: {names} (the shorthand of a one-obstacle --scene)"
    )
    scan.add_argument(
        "--scene", metavar="SCENE.yaml",
        help="several obstacles (pegs, polygons, curves, profiles) and friction from a scene "
        "file, lengths in L (doc/guide/scenes.md); instead of --profile/--param/--place",
    )
    scan.add_argument(
        "--friction", type=_nonnegative, metavar="MU",
        help="with --scene: the scene's global Coulomb coefficient instead of the file's "
        "(obstacles with their own coefficient keep it)",
    )
    scan.add_argument(
        "--contacts", metavar="C.jsonl",
        help="with --scene: write every contact of every pose, one JSON object per line",
    )
    scan.add_argument(
        "--param",
        action="append",
        type=_param,
        default=[],
        metavar="NAME=VALUE",
        help="profile parameter, repeatable (e.g. --param p0=0.3 --param k=1)",
    )
    scan.add_argument(
        "--model",
        default="elastica",
        choices=sorted(MODELS) + ["both"],
        help="whisker model: elastica (paper §2), rigid (paper §3) or both side by side",
    )
    scan.add_argument(
        "--spring-stiffness",
        type=_positive,
        default=None,
        metavar="K",
        help="rigid model: pivot stiffness c = K*EI/L; its forces and moments are then "
        "written in the elastica's units (EI/L^2, EI/L). Without it the rigid model is "
        "written in the paper's §3 units (c/L, c). Default with --model both: 3, the "
        "stiffness that matches the elastica's small-deflection tip stiffness",
    )
    scan.add_argument(
        "--taper",
        type=_taper,
        default=None,
        metavar="RHO",
        help="tip radius / base radius in (0, 1] (default 1): bending stiffness "
        "(1-(1-RHO)s)^4 EI_b",
    )
    scan.add_argument(
        "--curvature",
        type=_curvature,
        default=None,
        metavar="K0[,K1]",
        help="intrinsic curvature k0 + k1 s [1/L], counter-clockwise positive (default 0,0); "
        "write --curvature=-1,0 for a negative k0",
    )
    scan.add_argument(
        "--parabola",
        type=_parabola,
        default=None,
        metavar="A",
        help="3D run: the unloaded whisker follows the parabola y = A x^2 [1/L] in its own "
        "plane, |A| <= 10 (instead of --curvature)",
    )
    scan.add_argument(
        "--poisson",
        type=_poisson,
        default=None,
        metavar="NU",
        help="3D run: Poisson ratio in [0, 0.5] (default 0.38): torsional stiffness "
        "B/(1+NU)",
    )
    scan.add_argument(
        "--solver",
        default="auto",
        choices=("auto", "exact", "numeric"),
        help="exact: the closed forms (uniform straight whisker, convex profiles); numeric: "
        "Chebyshev collocation, any whisker and obstacle; auto (default): exact where it applies",
    )
    scan.add_argument(
        "--place",
        type=_placement,
        default=(0.0, 0.0, 0.0),
        metavar="X,Y,DEG",
        help="move the obstacle: turn it by DEG degrees counter-clockwise about its apex, then "
        "shift it by (X, Y) (whisker lengths); as a study's placement",
    )
    scan.add_argument(
        "--from",
        dest="x_from",
        type=_finite,
        help="first foot position x0 (--whisk: first heading, deg)",
    )
    scan.add_argument(
        "--to",
        dest="x_to",
        type=_finite,
        help="last foot position x0, inclusive (--whisk: last heading, deg)",
    )
    scan.add_argument(
        "--step", type=_positive, help="grid spacing of x0, > 0 (--whisk: of the heading, deg)"
    )
    scan.add_argument(
        "--whisk",
        type=_numbers,
        metavar="X,Y | FREQ,RET,PRO",
        help="whisk instead of sliding: the foot fixed at (X, Y), the heading sweeping from "
        "--from to --to by --step degrees (counter-clockwise from +x; 90 = the paper's set-up), "
        "and back with --back; written as --poses is (columns x,y,heading, heading in rad). Write "
        "--whisk=-1.5,0 for a negative X. With --array: FREQ [Hz], RETRACTION and PROTRACTION "
        "[deg], every whisker's protraction a cosine between them (fully retracted at t = 0), "
        "e.g. --whisk=8,-20,20",
    )
    scan.add_argument(
        "--poses",
        metavar="POSES.csv",
        help="foot poses instead of --from/--to/--step: a CSV with columns x,y,heading "
        "(heading in rad, pi/2 = the paper's set-up), visited in order; with --scene, columns "
        "x,y,z,qw,qx,qy,qz (base position, unit quaternion scalar first) make a 3D run",
    )
    scan.add_argument("--back", action="store_true", help="append the sweep back to --from")
    scan.add_argument("--points-tolerance", type=float, metavar="TOL",
                      help="the 3D whisker (an array's run, or --scene with 3D --poses): each "
                      "whisker's discretization error asked for, in its own length, 1e-12 to "
                      "1e-6 (default 1e-11: resolved to the solver's convergence; coarser: fewer "
                      "points per segment, faster)")
    scan.add_argument("--csv", help="output CSV ('-' for standard output); required, except "
                      "with --array (--out)")
    scan.add_argument("--events", help="output events JSON")
    scan.add_argument("--plot", metavar="PNG",
                      help="also draw the paper's figures of this scan; with --array a PREFIX: "
                      "PREFIX-3d.png, PREFIX-heatmap.png and PREFIX-rows.png")
    arr = scan.add_argument_group(
        "whisker arrays", "every whisker of an array file against a 3D scene in metres, SI "
        "units: --array A.yaml --scene S.yaml (--poses P.csv | --whisk F,RET,PRO [--duration "
        "S --rate HZ --head ... --velocity ...]) --out OUT.parquet|OUT.csv")
    arr.add_argument("--array", metavar="ARRAY.yaml",
                     help="a whisker array file (vibrissa array rat writes the rat's); the "
                     "--scene file is then read in metres, and --poses has the head's columns "
                     "t,x,y,z,qw,qx,qy,qz [s, m] with optional protraction or "
                     "protraction_<WHISKER> columns [rad]")
    arr.add_argument("--side", choices=("left", "right"),
                     help="only this side's whiskers of the array (default: all)")
    arr.add_argument("--duration", type=_positive, metavar="S",
                     help="without --poses: the run's length [s] (default: one whisk period)")
    arr.add_argument("--rate", type=_positive, metavar="HZ",
                     help="without --poses: ticks per second [Hz] (default 1000)")
    arr.add_argument("--head", type=_numbers, metavar="X,Y,Z[,YAW,PITCH,ROLL]",
                     help="without --poses: the head's position [m] and orientation [deg] at "
                     "t = 0 (yaw about z, then pitch about y, then roll about x); default the "
                     "origin")
    arr.add_argument("--velocity", type=_numbers, metavar="VX,VY,VZ",
                     help="without --poses: the head moves at this velocity [m/s] (world "
                     "frame), its orientation kept; default 0")
    arr.add_argument("--out", metavar="OUT.parquet",
                     help="the rows (one per whisker and tick): Parquet for *.parquet (needs "
                     "pyarrow), else CSV ('-' for standard output)")
    arr.add_argument("--workers", type=_workers, metavar="W",
                     help="deal the whiskers to W processes (whisker i to i mod W; the same "
                     "results): for a long run on a machine with W cores to spare (default 1)")
    arr.add_argument("--plot-tick", type=_nonnegative, metavar="T",
                     help="the time [s] whose whisker shapes --plot draws (default: the first "
                     "tick with the most whiskers in contact)")
    scan.add_argument(
        "--small-png", action="store_true", help="write the figure with 256 colours (3x smaller)"
    )
    scan.set_defaults(func=_cmd_scan)

    sweep = sub.add_parser(
        "sweep",
        help="drive a whisker_node through a sweep of foot poses and write its answers (SI)",
        description="Publish foot poses along the world x-axis to a whisker_node, one at a time, "
        "and write the wrench (base frame) and contact state it answers to a CSV in SI units. "
        "With --launch, start "
        "whisker_node with that parameter file first and stop it at the end.",
    )
    sweep.add_argument(
        "--launch", metavar="PARAMS.yaml", help="start whisker_node with this parameter file"
    )
    sweep.add_argument(
        "--node", default="/whisker_node", help="the node's name with namespace (topic prefix)"
    )
    sweep.add_argument(
        "--from", dest="x_from", type=_finite, required=True, help="first foot x [m]"
    )
    sweep.add_argument(
        "--to", dest="x_to", type=_finite, required=True, help="last foot x [m] (inclusive)"
    )
    sweep.add_argument("--step", type=_positive, required=True, help="spacing of foot x [m] (> 0)")
    sweep.add_argument("--back", action="store_true", help="append the sweep back to --from")
    sweep.add_argument("--y", type=_finite, default=0.0, help="foot y [m] (default 0)")
    sweep.add_argument(
        "--yaw-deg",
        type=_finite,
        default=90.0,
        help="base yaw [deg] (default 90: whisker along +y)",
    )
    sweep.add_argument(
        "--frame", default="world", help="frame_id of the poses (the node's world_frame)"
    )
    sweep.add_argument(
        "--timeout", type=_positive, default=10.0, help="seconds to wait for each answer"
    )
    sweep.add_argument("--csv", required=True, help="output CSV ('-' for standard output)")
    sweep.set_defaults(func=_cmd_sweep)

    info = sub.add_parser(
        "info",
        help="what a recorded log holds: topics, counts, duration, configuration, "
        "phases and events",
    )
    info.add_argument("log", help="an MCAP log written by whisker_node or array_node "
                      "(record.path)")
    info.set_defaults(func=_cmd_info)

    replay = sub.add_parser(
        "replay", help="publish a log's messages into ROS with their recorded timing"
    )
    replay.add_argument("log")
    replay.add_argument(
        "--rate",
        type=_nonnegative,
        default=1.0,
        help="speed factor of the recorded timing (2 = twice as fast); 0 = as fast as the "
        "subscribers take them",
    )
    replay.add_argument(
        "--topics", nargs="+", metavar="TOPIC", help="only these topics (default: all)"
    )
    replay.set_defaults(func=_cmd_replay)

    resim = sub.add_parser(
        "resim",
        help="re-run a log's poses through the core with its configuration and "
        "compare with its outputs field by field",
    )
    resim.add_argument("log")
    resim.add_argument(
        "--tolerance",
        type=_positive,
        default=1e-12,
        help="largest relative deviation allowed (default 1e-12)",
    )
    resim.set_defaults(func=_cmd_resim)

    export = sub.add_parser(
        "export", help="a log as the scan CSV contract (dimensionless), plus a time column"
    )
    export.add_argument("log")
    export.add_argument("--csv", required=True, help="output CSV ('-' for standard output)")
    export.set_defaults(func=_cmd_export)

    repair = sub.add_parser(
        "repair",
        help="rewrite a log that was not finished (e.g. after kill -9) into a " "valid one",
    )
    repair.add_argument("log")
    repair.add_argument("-o", "--output", required=True, help="the repaired MCAP file")
    repair.set_defaults(func=_cmd_repair)

    plot = sub.add_parser("plot", help="draw the paper's figures of a scan CSV or a recorded log")
    plot.add_argument("input", help="a scan CSV (with --profile/--param) or an MCAP log")
    plot.add_argument("-o", "--output", required=True, metavar="PNG")
    plot.add_argument(
        "--profile", choices=sorted(PROFILE_PARAMETERS), help="the scanned profile (CSV input)"
    )
    plot.add_argument("--param", action="append", type=_param, default=[], metavar="NAME=VALUE")
    plot.add_argument(
        "--model", default="elastica", choices=sorted(MODELS), help="the model of the CSV"
    )
    plot.add_argument(
        "--spring-stiffness",
        type=_positive,
        default=None,
        metavar="K",
        help="rigid model of the CSV: c = K EI/L (as given to scan)",
    )
    plot.add_argument(
        "--small-png", action="store_true", help="write the figure with 256 colours (3x smaller)"
    )
    plot.set_defaults(func=_cmd_plot)

    rec = sub.add_parser(
        "reconstruct",
        help="the scanned contour from the sensor's readings (foot pose and base "
        "wrench) of a log or a scan CSV",
    )
    rec.add_argument(
        "input",
        help="an MCAP log, or a CSV with at least the columns x0, fx, fy, m0 (scan contract)",
    )
    rec.add_argument(
        "--csv", required=True, help="output: x0,phase,contact_x,contact_y,alpha ('-' for stdout)"
    )
    rec.add_argument(
        "--plot",
        metavar="PNG",
        help="draw the reconstruction over the true profile, if the input has it",
    )
    rec.add_argument(
        "--min-force",
        type=_nonnegative,
        default=0.0,
        help="readings with a smaller force are taken as no contact (input units; noisy data)",
    )
    rec.add_argument(
        "--taper",
        type=_taper,
        help="scan CSV of a conical whisker: tip radius / base radius (default 1); a log "
        "carries its own",
    )
    rec.add_argument(
        "--curvature",
        type=_curvature,
        help="scan CSV of a curved whisker: intrinsic curvature k0 + k1 s [1/L] (default 0,0; "
        "--curvature=-1,0 for a negative k0); a log carries its own",
    )
    rec.set_defaults(func=_cmd_reconstruct)
    batch = sub.add_parser(
        "batch",
        help="run a study (a grid and/or random sample of scans) on Dask and write a Parquet "
        "dataset",
        description="Run every task of a study (one task = one scan, as 'vibrissa scan' computes "
        "it) on an embedded Dask cluster or an existing one, and write the results as a Parquet "
        "dataset in DIR. Running the same command again computes only the tasks that are missing.",
    )
    batch.add_argument("study", help="the study file (YAML; see config/study_small.yaml)")
    batch.add_argument(
        "--out", required=True, metavar="DIR", help="the dataset directory (created or resumed)"
    )
    batch.add_argument(
        "--workers",
        type=_workers,
        default=None,
        metavar="N",
        help="worker processes of the embedded cluster (default: the number of cores)",
    )
    batch.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing Dask cluster, e.g. tcp://host:8786 (its workers need "
        "vibrissa_ros[batch] of this version)",
    )
    batch.add_argument(
        "--dry-run", action="store_true", help="check the study, print its size and stop"
    )
    batch.add_argument("--quiet", action="store_true", help="no progress bar")
    batch.set_defaults(func=_cmd_batch)
    array = sub.add_parser(
        "array", help="write a whisker-array file (the rat's, from the published morphology)",
        description="Write a whisker array as YAML: every whisker's base point and orientation "
        "in the head frame, arc length, shape, radius, taper and material, in SI units.",
    )
    kinds = array.add_subparsers(dest="kind", required=True, parser_class=_Parser)
    rat = kinds.add_parser(
        "rat", help="the rat's mystacial pad (Belli et al. 2018 or Towal et al. 2011)",
        description="Generate the rat's whisker array from the published equations (Belli et "
        "al. 2018: 30 whiskers per side; Towal et al. 2011: 31) and write it as YAML.",
    )
    rat.add_argument("--side", choices=("left", "right", "both"), default="both",
                     help="which side of the face (default: both)")
    rat.add_argument("--model", choices=("belli2018", "towal2011"), default="belli2018",
                     help="which published model (default: belli2018)")
    rat.add_argument("-o", "--output", metavar="OUT.yaml",
                     help="the file written (default: standard output)")
    rat.set_defaults(func=_cmd_array_rat)
    return parser


def _cmd_array_rat(args) -> int:
    from .scan.array_file import write_rat_array

    try:
        text = write_rat_array(args.side, args.model, args.output)
    except OSError as exc:
        print(f"vibrissa array rat: error: {args.output}: {exc.strerror or exc}",
              file=sys.stderr)
        return 2
    except VibrissaError as exc:
        print(f"vibrissa array rat: error: {exc}", file=sys.stderr)
        return 2
    if args.output is None:
        sys.stdout.write(text)
    return 0


def _cmd_batch(args) -> int:
    try:
        from .studies.batch import run_study
        from .studies.dataset import DatasetError
        from .studies.study import load_study
    except ImportError as exc:
        print(
            f"vibrissa batch: error: needs Dask, pyarrow, tqdm and PyYAML ({exc}); pip install "
            "'vibrissa_ros[batch]'",
            file=sys.stderr,
        )
        return 2
    if args.workers is not None and args.scheduler:
        print(
            "vibrissa batch: error: --workers sizes the embedded cluster; with --scheduler the "
            "cluster's own workers run the study",
            file=sys.stderr,
        )
        return 2
    try:
        study = load_study(args.study)
    except VibrissaError as exc:
        print(f"vibrissa batch: error: {args.study}: {exc}", file=sys.stderr)
        return 2
    if args.dry_run:
        if hasattr(study, "whiskers"):  # an array study: rows of whiskers and ticks
            print(f"{args.study}: {len(study.tasks)} tasks (array runs of {study.whiskers} "
                  f"whiskers), {study.poses} rows")
        else:
            print(f"{args.study}: {len(study.tasks)} tasks, {study.poses} poses")
        return 0
    try:
        report = run_study(
            study,
            args.out,
            workers=args.workers,
            scheduler=args.scheduler,
            progress=None if args.quiet else sys.stderr,
        )
    except DatasetError as exc:
        print(f"vibrissa batch: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            "vibrissa batch: interrupted; the tasks written are kept: run the same command again "
            "to compute the rest",
            file=sys.stderr,
        )
        return 130
    except OSError as exc:  # e.g. the scheduler cannot be reached
        print(f"vibrissa batch: error: {exc}", file=sys.stderr)
        return 1
    if report.computed == 0 and not report.errors:
        print(
            f"vibrissa batch: all {report.tasks} tasks of {args.study} are already in "
            f"{args.out}; nothing to do",
            file=sys.stderr,
        )
        return 0
    rate = report.computed / report.seconds if report.seconds > 0 else 0.0
    print(
        f"vibrissa batch: {report.computed} tasks computed ({report.failed} failed, reasons in "
        f"{args.out}/failures), {report.already_done} were already done; "
        f"{report.workers} workers, {report.seconds:.1f} s ({rate:.2f} tasks/s) -> {args.out}",
        file=sys.stderr,
    )
    if report.errors:
        for index, message in report.errors[:5]:
            print(f"vibrissa batch: error: task {index} not computed: {message}", file=sys.stderr)
        print(
            f"vibrissa batch: {len(report.errors)} tasks not computed; run the same command again "
            "to retry them",
            file=sys.stderr,
        )
        return 1
    return 0


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


def _scan_path(args):
    """Return the foot positions (x0 grid) or poses (--poses, --whisk) of a scan."""
    sweep = (args.x_from, args.x_to, args.step)
    if args.poses is not None:
        if args.whisk is not None:
            raise VibrissaError("give either --poses or --whisk, not both")
        if any(v is not None for v in sweep) or args.back:
            raise VibrissaError("give either --poses or --from/--to/--step [--back], not both")
        return None, read_poses_csv(args.poses)
    if args.whisk is not None:
        if len(args.whisk) != 2:
            raise VibrissaError(f"--whisk {','.join(f'{v:g}' for v in args.whisk)} is not X,Y "
                                "(the foot's position, e.g. --whisk=-1.5,0); FREQ,RET,PRO is "
                                "an array's whisk (--array)")
        if any(v is None for v in sweep):
            raise VibrissaError("--whisk X,Y needs the headings: --from, --to and --step [deg]")
        return None, list(whisk_poses(*args.whisk, args.x_from, args.x_to, args.step, args.back))
    if any(v is None for v in sweep):
        raise VibrissaError("give --from, --to and --step (or --poses POSES.csv, or --whisk X,Y)")
    return scan_grid(args.x_from, args.x_to, args.step, args.back), None


def _elastica_model(args, profile):
    """Choose the exact elastica or the general solver, by --solver, --taper and --curvature."""
    from .scan.scene_scan import elastica_model

    k0, k1 = args.curvature or (0.0, 0.0)
    shape = WhiskerShape(1.0 if args.taper is None else args.taper, k0, k1)
    return elastica_model(shape, args.solver, profile)


def _is_3d_run(args) -> bool:
    """Tell whether ``--poses`` is a 3D poses file (columns x,y,z,qw,qx,qy,qz)."""
    if args.poses is None:
        return False
    from .scan.scan_io3d import is_3d_poses_csv

    try:
        return is_3d_poses_csv(args.poses)
    except VibrissaError:  # unreadable: the planar reader says so, as it always has
        return False


#: the options of an array run only
_ARRAY_OPTIONS = ("side", "duration", "rate", "head", "velocity", "out", "plot_tick",
                  "workers")


def _cmd_scan(args) -> int:
    if args.array is not None:
        return _cmd_scan_array(args)
    try:
        given = [o for o in _ARRAY_OPTIONS if getattr(args, o) is not None]
        if given:
            raise VibrissaError(f"--{given[0].replace('_', '-')} applies to a whisker array's "
                                "run (--array ARRAY.yaml)")
        if args.csv is None:
            raise VibrissaError("the following arguments are required: --csv")
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    three_d = _is_3d_run(args)
    try:
        if three_d and args.scene is None:
            raise VibrissaError(f"--poses {args.poses} has 3D poses (columns x,y,z,qw,qx,qy,qz): "
                                "a 3D run needs --scene SCENE.yaml")
        if not three_d and (args.parabola is not None or args.poisson is not None):
            raise VibrissaError("--parabola and --poisson apply to a 3D run (--scene with --poses "
                                "of columns x,y,z,qw,qx,qy,qz)")
        if not three_d and args.points_tolerance is not None:
            raise VibrissaError("--points-tolerance applies to the 3D whisker (--array, or "
                                "--scene with --poses of columns x,y,z,qw,qx,qy,qz); the planar "
                                "models are exact or solved to their own tolerance")
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    if three_d:
        return _cmd_scan3d(args)
    if args.scene is not None:
        return _cmd_scan_scene(args)
    try:
        if args.profile is None:
            raise VibrissaError("give --profile (with --param) or --scene SCENE.yaml")
        if args.contacts is not None:
            raise VibrissaError("--contacts applies to --scene")
        if args.friction is not None:
            raise VibrissaError("--friction applies to --scene (a profile alone is frictionless)")
        from .studies.study import place_obstacle

        profile = place_obstacle(make_profile(args.profile, _params(args.param)), *args.place)
        grid, poses = _scan_path(args)
        if args.model != "elastica" and (
            args.taper is not None or args.curvature is not None or args.solver == "numeric"
        ):
            raise VibrissaError(
                "--taper, --curvature and --solver numeric apply to --model elastica"
            )
        if args.model == "both" and args.csv == "-":
            raise VibrissaError(
                "--model both writes two CSV files: give --csv a file name, not '-'"
            )
        if args.spring_stiffness is not None and args.model == "elastica":
            raise VibrissaError(
                "--spring-stiffness applies to --model rigid or both, not elastica"
            )
        stiffness = args.spring_stiffness or (3.0 if args.model == "both" else 1.0)
        runs = []
        for name in (["elastica", "rigid"] if args.model == "both" else [args.model]):
            model = (
                make_model(name, stiffness=stiffness)
                if name == "rigid"
                else _elastica_model(args, profile)
            )
            suffix = args.model == "both" and name == "rigid"
            csv_path = rigid_output_path(args.csv) if suffix else args.csv
            events_path = (
                rigid_output_path(args.events) if (suffix and args.events) else args.events
            )
            runs.append((model, csv_path, events_path))
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    results = []
    for model, csv_path, events_path in runs:
        try:
            result = (
                run_scan(profile, grid, model=model)
                if poses is None
                else run_poses(profile, poses, model=model)
            )
        except VibrissaError as exc:
            print(f"vibrissa scan: error: {model.name} model: {exc}", file=sys.stderr)
            return 2 if isinstance(exc, ValueError) else 1
        results.append((model.name, result))
        by_pose = poses is not None
        if csv_path == "-":
            write_scan_csv(result.states, sys.stdout, by_pose)
        else:
            with open(csv_path, "w", newline="") as stream:
                write_scan_csv(result.states, stream, by_pose)
        if events_path:
            with open(events_path, "w") as stream:
                write_events_json(result.events, stream, by_pose)
    if args.plot:
        try:
            from .scan.plots import PlotRun, plot_runs
        except ImportError as exc:
            print(
                f"vibrissa scan: error: --plot needs matplotlib ({exc}); pip install '.[plots]'",
                file=sys.stderr,
            )
            return 2

        title = f"{profile.describe()}: " + " vs ".join(name for name, _ in results)
        # foot poses that only turn the whisker (whisking) are drawn against the heading
        abscissa = "heading" if poses is not None and len({p.x for p in poses}) == 1 else "x0"
        figure = plot_runs(
            [PlotRun(name, r.states, r.events, r.event_steps) for name, r in results],
            profile,
            title=title,
            abscissa=abscissa,
        )
        figure.save(args.plot, small=args.small_png)
    return 0


def _refuse_3d_scene(path: str) -> None:
    """Refuse a scene with spheres, cylinders or planes (3D only), saying how to run it."""
    from .scan.scene_file import is_3d_scene

    try:
        solids = is_3d_scene(path)
    except VibrissaError:  # unreadable: load_scene says so, as it always has
        return
    if solids:
        raise VibrissaError(f"{path} has 3D obstacles (sphere, cylinder or plane): scan it "
                            "with --poses P.csv of columns x,y,z,qw,qx,qy,qz (a 3D run)")


def _cmd_scan_scene(args) -> int:
    """``vibrissa scan --scene``: several obstacles, several contacts, friction."""
    from .scan.scene_file import load_scene
    from .scan.scene_scan import plan_scene_scan

    try:
        if args.profile is not None or args.param or args.place != (0.0, 0.0, 0.0):
            raise VibrissaError("--scene replaces --profile, --param and --place (the scene "
                                "file places its obstacles)")
        if args.model != "elastica" or args.spring_stiffness is not None:
            raise VibrissaError("--scene needs --model elastica (the rigid model has one contact)")
        _refuse_3d_scene(args.scene)
        scene = load_scene(args.scene)
        grid, poses = _scan_path(args)
        k0, k1 = args.curvature or (0.0, 0.0)
        shape = WhiskerShape(1.0 if args.taper is None else args.taper, k0, k1)
        plan = plan_scene_scan(scene, grid, poses, shape, args.solver, args.friction)
        friction = plan.friction
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    by_pose = poses is not None
    try:
        result = plan.run()
        states, events = list(result.states), list(result.events)
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ValueError) else 1
    from .scan.scan_io import write_contacts_jsonl, write_scene_events_json

    if args.csv == "-":
        write_scan_csv(states, sys.stdout, by_pose, contacts=True)
    else:
        with open(args.csv, "w", newline="") as stream:
            write_scan_csv(states, stream, by_pose, contacts=True)
    if args.events:
        with open(args.events, "w") as stream:
            write_scene_events_json(events, stream, by_pose)
    if args.contacts:
        with open(args.contacts, "w") as stream:
            write_contacts_jsonl(states, stream, by_pose)
    if args.plot:
        try:
            from .scan.plots import plot_scene_scan
        except ImportError as exc:
            print(f"vibrissa scan: error: --plot needs matplotlib ({exc}); pip install '.[plots]'",
                  file=sys.stderr)
            return 2
        names = ", ".join(ob.name for ob in scene)
        title = (f"scene {os.path.basename(args.scene)} ({names}), friction "
                 f"{', '.join(f'{m:g}' for m in friction)}")
        figure = plot_scene_scan(scene, states, events, title=title,
                                 abscissa="heading" if by_pose and len(
                                     {p.x for p in poses}) == 1 else "x0")
        figure.save(args.plot, small=args.small_png)
    return 0


def _check_points_tolerance(args) -> None:
    """Refuse a --points-tolerance out of its range, naming the option (one line)."""
    from .core.rod3d.model import POINTS_TOLERANCE, POINTS_TOLERANCE_RANGE, _points_tolerance

    if args.points_tolerance is None:
        return
    try:
        _points_tolerance(args.points_tolerance)
    except VibrissaError:
        lo, hi = POINTS_TOLERANCE_RANGE
        raise VibrissaError(f"--points-tolerance {args.points_tolerance!r}: need a number from "
                            f"{lo:g} to {hi:g} (the discretization error asked of each whisker, "
                            f"in its length; default {POINTS_TOLERANCE:g})") from None


def _check_scan3d_options(args) -> None:
    """Refuse the options a 3D run does not take, saying why (one line)."""
    _check_points_tolerance(args)
    if args.profile is not None or args.param or args.place != (0.0, 0.0, 0.0):
        raise VibrissaError("--scene replaces --profile, --param and --place (the scene file "
                            "places its obstacles)")
    if args.model != "elastica" or args.spring_stiffness is not None:
        raise VibrissaError("a 3D run needs --model elastica (the rigid model is planar)")
    if args.solver == "exact":
        raise VibrissaError("--solver exact: the closed forms are planar; a 3D run is numeric "
                            "(--solver auto or numeric)")
    if args.friction is not None:
        raise VibrissaError("--friction: the 3D whisker is frictionless (give a scene without "
                            "friction, and no --friction)")
    if args.whisk is not None:
        raise VibrissaError("give either --poses or --whisk, not both")
    if any(v is not None for v in (args.x_from, args.x_to, args.step)) or args.back:
        raise VibrissaError("give either --poses or --from/--to/--step [--back], not both")
    if args.curvature is not None and args.parabola is not None:
        raise VibrissaError("give either --curvature K0,K1 or --parabola A (the whisker's "
                            "intrinsic shape), not both")


def _cmd_scan3d(args) -> int:
    """``vibrissa scan --scene S.yaml --poses P.csv`` with 3D poses: the 3D whisker."""
    from .core.rod3d import DEFAULT_POISSON, RodShape
    from .scan.scan_io3d import (read_poses3d_csv, write_contacts3d_jsonl, write_events3d_json,
                                 write_scan3d_csv)
    from .scan.scene_file import load_scene3d
    from .scan.scene_scan3d import plan_scene_scan3d

    try:
        _check_scan3d_options(args)
        scene = load_scene3d(args.scene)
        poses = read_poses3d_csv(args.poses)
        k0, k1 = args.curvature or (0.0, 0.0)
        shape = RodShape(1.0 if args.taper is None else args.taper, k0, k1, args.parabola,
                         DEFAULT_POISSON if args.poisson is None else args.poisson)
        plan = plan_scene_scan3d(scene, poses.poses, shape, poses.where,
                                 **({} if args.points_tolerance is None
                                    else {"points_tolerance": args.points_tolerance}))
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    try:
        result = plan.run()
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ValueError) else 1
    names = scene.names
    if args.csv == "-":
        write_scan3d_csv(result.states, sys.stdout)
    else:
        with open(args.csv, "w", newline="") as stream:
            write_scan3d_csv(result.states, stream)
    if args.events:
        with open(args.events, "w") as stream:
            write_events3d_json(result.events, stream, names)
    if args.contacts:
        with open(args.contacts, "w") as stream:
            write_contacts3d_jsonl(result.states, stream)
    if args.plot:
        try:
            from .scan.plots3d import plot_scene_scan3d
        except ImportError as exc:
            print(f"vibrissa scan: error: --plot needs matplotlib ({exc}); pip install '.[plots]'",
                  file=sys.stderr)
            return 2
        title = (f"3D scene {os.path.basename(args.scene)} ({', '.join(names)}), "
                 f"{len(result.states)} poses from {os.path.basename(args.poses)}")
        figure = plot_scene_scan3d(scene, result.states, result.events, result.event_steps,
                                   title=title)
        figure.save(args.plot, small=args.small_png)
    return 0


def _check_array_options(args) -> None:
    """Refuse what an array run does not take, saying why (one line)."""
    _check_points_tolerance(args)
    if args.scene is None:
        raise VibrissaError("--array needs --scene SCENE.yaml (the obstacles, in metres)")
    if args.profile is not None or args.param or args.place != (0.0, 0.0, 0.0):
        raise VibrissaError("--array takes its obstacles from --scene (no --profile, --param, "
                            "--place)")
    if args.model != "elastica" or args.spring_stiffness is not None or args.solver == "exact":
        raise VibrissaError("--array runs the 3D whisker (no --model, --spring-stiffness, "
                            "--solver exact)")
    shaped = [o for o in ("taper", "curvature", "parabola", "poisson") if getattr(args, o)
              is not None]
    if shaped:
        raise VibrissaError(f"--{shaped[0]}: the array file gives every whisker's shape")
    if args.friction is not None:
        raise VibrissaError("--friction: the 3D whisker is frictionless")
    if args.contacts is not None:
        raise VibrissaError("--contacts applies to a single whisker's scan; an array's rows "
                            "have the contact nearest each base (--out)")
    if any(v is not None for v in (args.x_from, args.x_to, args.step)) or args.back:
        raise VibrissaError("--array moves the head along --poses or whisks (--whisk "
                            "FREQ,RET,PRO); no --from/--to/--step/--back")
    if args.csv is not None:
        raise VibrissaError("--array writes its rows with --out OUT.parquet or OUT.csv (not "
                            "--csv)")
    if args.out is None:
        raise VibrissaError("--array needs --out OUT.parquet (or OUT.csv, '-' for standard "
                            "output)")
    if args.poses is None and args.whisk is None and args.velocity is None:
        raise VibrissaError("--array needs --poses P.csv (the head's path) and/or --whisk "
                            "FREQ,RET,PRO (or the head's --velocity)")
    if args.poses is None and args.whisk is None and args.duration is None:
        raise VibrissaError("--velocity without --whisk needs --duration S")
    if args.poses is not None:
        timed = [o for o in ("duration", "rate", "head", "velocity")
                 if getattr(args, o) is not None]
        if timed:
            raise VibrissaError(f"--{timed[0]}: --poses gives the ticks and the head's path")
    if args.whisk is not None and len(args.whisk) != 3:
        raise VibrissaError(f"--whisk {','.join(f'{v:g}' for v in args.whisk)} is not "
                            "FREQ,RETRACTION,PROTRACTION ([Hz], [deg], [deg], e.g. "
                            "--whisk=8,-20,20)")
    if args.head is not None and len(args.head) not in (3, 6):
        raise VibrissaError("--head is X,Y,Z [m] or X,Y,Z,YAW,PITCH,ROLL [m, deg]")
    if args.velocity is not None and len(args.velocity) != 3:
        raise VibrissaError("--velocity is VX,VY,VZ [m/s]")
    if args.out.endswith(".parquet"):
        try:
            import pyarrow.parquet  # noqa: F401
        except ImportError as exc:
            raise VibrissaError(f"--out {args.out}: Parquet needs pyarrow ({exc}); pip install "
                                "'vibrissa_ros[batch]', or write a .csv") from None


def _cmd_scan_array(args) -> int:
    """``vibrissa scan --array A.yaml --scene S.yaml``: every whisker of an array, SI units."""
    from .core.arrays.partition import MAX_WORKERS
    from .core.arrays.whisking import CosineWhisk
    from .scan.array_file import load_array
    from .scan.array_scan import (head_pose, plan_array_scan, read_head_poses_csv, timed_path,
                                  write_array_events_json, write_array_scan)
    from .scan.scene_file import load_scene3d

    try:
        _check_array_options(args)
        array = load_array(args.array)
        if args.side is not None:
            if not any(w.side == args.side for w in array):
                raise VibrissaError(f"--side {args.side}: {args.array} has no whisker on that "
                                    "side")
            array = array.side(args.side)
        if args.workers is not None and args.workers > min(MAX_WORKERS, len(array)):
            raise VibrissaError(f"--workers {args.workers}: need 1 to "
                                f"{min(MAX_WORKERS, len(array))} (the array's {len(array)} "
                                f"whiskers, at most {MAX_WORKERS})")
        scene = load_scene3d(args.scene)
        whisk = None
        if args.whisk is not None:
            f, ret, pro = args.whisk
            try:
                whisk = CosineWhisk(f, math.radians(ret), math.radians(pro))
            except VibrissaError as exc:
                raise VibrissaError(f"--whisk {','.join(f'{v:g}' for v in args.whisk)}: {exc}"
                                    ) from None
        if args.poses is not None:
            path = read_head_poses_csv(args.poses)
        else:
            head = head_pose(*((args.head[:3], *args.head[3:]) if args.head else ((0, 0, 0),)))
            duration = args.duration if args.duration is not None else 1.0 / whisk.frequency
            path = timed_path(duration, 1000.0 if args.rate is None else args.rate, head,
                              args.velocity or (0.0, 0.0, 0.0))
        plan = plan_array_scan(array, scene, path, whisk,
                               **({} if args.points_tolerance is None
                                  else {"points_tolerance": args.points_tolerance}))
    except VibrissaError as exc:
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 2
    shape_tick = None
    if args.plot:
        shape_tick = -1
        if args.plot_tick is not None:
            times = path.times
            shape_tick = min(range(len(times)), key=lambda i: abs(times[i] - args.plot_tick))
    try:
        result = plan.run(shape_tick=shape_tick, workers=args.workers or 1)
    except VibrissaError as exc:  # (a worker process that did not start, or ended)
        print(f"vibrissa scan: error: {exc}", file=sys.stderr)
        return 1
    try:
        write_array_scan(result, args.out)
        if args.events:
            with open(args.events, "w") as stream:
                write_array_events_json(result, stream)
    except OSError as exc:
        print(f"vibrissa scan: error: {exc.filename or args.out}: {exc.strerror or exc}",
              file=sys.stderr)
        return 2
    touched = int(sum(s.in_contact for s in result.steps))
    print(f"vibrissa scan: {len(array)} whiskers x {len(result.steps)} ticks, {touched} "
          f"whisker-ticks in contact -> {args.out}", file=sys.stderr)
    if result.errors:
        first = next(e for s in result.steps for e in s.errors)
        print(f"vibrissa scan: warning: {result.errors} whisker steps failed (the whisker kept "
              f"its state; column error): first {first.whisker}: {first.message}",
              file=sys.stderr)
    if args.plot:
        try:
            from .scan.plots_array import plot_array_scan
        except ImportError as exc:
            print(f"vibrissa scan: error: --plot needs matplotlib ({exc}); pip install '.[plots]'",
                  file=sys.stderr)
            return 2
        title = (f"{os.path.basename(args.array)}"
                 f"{'' if args.side is None else ' (' + args.side + ')'} against "
                 f"{os.path.basename(args.scene)} ({', '.join(scene.names)})")
        for name, figure in plot_array_scan(scene, result, title=title).items():
            figure.save(f"{args.plot}-{name}.png", small=args.small_png)
    return 0


def _cmd_sweep(args) -> int:
    try:
        grid = scan_grid(args.x_from, args.x_to, args.step, args.back)
    except VibrissaError as exc:
        print(f"vibrissa sweep: error: {exc}", file=sys.stderr)
        return 2
    if args.launch and not os.path.isfile(args.launch):
        print(
            f"vibrissa sweep: error: --launch {args.launch!r}: no such parameter file",
            file=sys.stderr,
        )
        return 2
    try:
        from .ros.sweep import launch_node, run_sweep, stop_node, write_sweep_csv
    except ImportError as exc:  # ROS 2 is an optional dependency of the package
        print(
            f"vibrissa sweep: error: ROS 2 is not installed ({exc}); pip install '.[ros]'",
            file=sys.stderr,
        )
        return 2
    yaw = math.radians(args.yaw_deg)
    poses = [(float(x), args.y, yaw) for x in grid]
    node_namespace = args.node.rsplit("/", 1)[0]
    proc = launch_node(args.launch, node_namespace) if args.launch else None
    code = 0
    try:
        rows = run_sweep(
            poses, node=args.node, frame=args.frame, timeout=args.timeout, progress=sys.stderr
        )
    except (TimeoutError, VibrissaError) as exc:
        print(f"vibrissa sweep: error: {exc}", file=sys.stderr)
        code = 1
    finally:
        if proc is not None:
            node_code = stop_node(proc)
            if node_code != 0 and code == 0:
                print(
                    f"vibrissa sweep: error: whisker_node exited with status {node_code}",
                    file=sys.stderr,
                )
                code = 1
    if code:
        return code
    if args.csv == "-":
        write_sweep_csv(rows, sys.stdout)
    else:
        with open(args.csv, "w", newline="") as stream:
            write_sweep_csv(rows, stream)
    contact = sum(1 for r in rows if r.phase)
    print(
        f"vibrissa sweep: {len(rows)} poses answered ({contact} in contact) -> {args.csv}",
        file=sys.stderr,
    )
    return 0


def _log_tool(verb: str, action) -> int:
    """Run a log tool: a missing file or a log error is one line and status 2 (1 for a bad log)."""
    try:
        return action()
    except FileNotFoundError as exc:
        print(f"vibrissa {verb}: error: {exc.filename}: no such file", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(
            f"vibrissa {verb}: error: ROS 2 or mcap is not installed ({exc}); "
            "pip install '.[ros]'",
            file=sys.stderr,
        )
        return 2
    except VibrissaError as exc:
        print(f"vibrissa {verb}: error: {exc}", file=sys.stderr)
        return 1


def _print_array_events(events, first: int = 20) -> None:
    """Print array_node's events: counts per kind and per whisker, then the first ones."""
    kinds: Dict[str, int] = {}
    per: Dict[str, Dict[str, int]] = {}
    for e in events:
        kinds[e["kind"]] = kinds.get(e["kind"], 0) + 1
        row = per.setdefault(e["whisker"], {})
        row[e["kind"]] = row.get(e["kind"], 0) + 1
    print("  by kind:    " + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items())))
    for name, row in per.items():
        print(f"  {name:<10}  " + ", ".join(f"{k} {n}" for k, n in sorted(row.items())))
    for e in events[:first]:
        where = "" if e.get("s") is None else f" at s = {e['s']:.6g} m"
        on = "" if e.get("obstacle") is None else f" on {e['obstacle']}"
        reason = f" ({e['reason']})" if e.get("reason") else ""
        print(f"  {e['kind']:<8} {e['whisker']}{on}{where}, contacts "
              f"{e['contacts_before']} -> {e['contacts_after']}{reason}")
    if len(events) > first:
        print(f"  ... and {len(events) - first} more")


def _cmd_info(args) -> int:
    def run():
        from .logs.tools import log_info

        info = log_info(args.log)
        print(f"log:       {args.log}")
        print(f"duration:  {info.duration:.3f} s ({info.start_ns} .. {info.end_ns} ns)")
        print("topics:")
        width = max((len(t) for t in info.topics), default=0)
        for topic, (kind, count) in info.topics.items():
            print(f"  {topic:<{width}}  {kind:<36} {count:>8}")
        for i, (log_time, values) in enumerate(info.configurations):
            when = "from the start" if i == 0 else f"from log time {log_time} ns"
            print(f"configuration ({when}{'' if values.get('resets', True) else ', no reset'}):")
            for key in sorted(values):
                if key not in ("resets",):
                    print(f"  {key} = {json.dumps(values[key])}")
        phases = ", ".join(f"phase {p}: {n}" for p, n in info.phases.items()) or "none recorded"
        print(f"phases:    {phases}")
        print(f"events:    {len(info.events)}")
        if info.events and "whisker" in info.events[0]:  # array_node's: counted per whisker
            _print_array_events(info.events)
            return 0
        for e in info.events:
            what = (f"{e['from_phase']} -> {e['to_phase']}" if "from_phase" in e
                    else f"{e['contact']} on obstacle {e['obstacle']}")  # a scene's event
            print(
                f"  {e['kind']:<8} {what} at x = {e['x']:.9g} m, "
                f"y = {e['y']:.9g} m, "
                f"yaw = {e['yaw']:.9g} rad"
            )
        return 0

    return _log_tool("info", run)


def _cmd_replay(args) -> int:
    def run():
        from tqdm import tqdm

        from .ros.replay import replay

        with tqdm(unit="msg", file=sys.stderr, desc="replay", dynamic_ncols=True) as bar:
            n = replay(args.log, rate=args.rate, topics=args.topics, progress=bar)
        print(f"vibrissa replay: {n} messages published", file=sys.stderr)
        return 0

    return _log_tool("replay", run)


def _cmd_resim(args) -> int:
    def run():
        from .logs.tools import resimulate

        sim = resimulate(args.log)
        # an array log keeps no states, only their number (a long one would not fit in memory)
        done = (f"{len(sim.states)} poses" if sim.ticks is None else f"{sim.ticks} ticks")
        print(
            f"{done} re-simulated, {sum(sim.dropped.values())} dropped as "
            "recorded" + (f" ({dict(sim.dropped)})" if sim.dropped else "")
        )
        print(f"{'field':<34} {'compared':>9} {'largest relative deviation':>28}")
        for key in sorted(sim.deviations):
            print(f"{key:<34} {sim.compared[key]:>9} {sim.deviations[key]:>28.3e}")
        for line in sim.mismatches:
            print(f"mismatch: {line}")
        bad = sim.mismatches or sim.worst() > args.tolerance
        print(
            f"{'FAIL' if bad else 'OK'}: largest deviation {sim.worst():.3e} "
            f"(tolerance {args.tolerance:g})"
        )
        return 1 if bad else 0

    return _log_tool("resim", run)


def _cmd_export(args) -> int:
    def run():
        from .logs.tools import export_rows
        from .scan.scan_io import CONTACTS_COLUMN, CSV_COLUMNS, state_row

        rows, sim = export_rows(args.log)
        # a run of the scene tracker: its number of contacts too, as `vibrissa scan --scene`
        scene = any(hasattr(state, "contacts") for _, state in rows)
        stream = sys.stdout if args.csv == "-" else open(args.csv, "w", newline="")
        try:
            extra = (CONTACTS_COLUMN,) if scene else ()
            stream.write(",".join(CSV_COLUMNS + extra + ("time",)) + "\n")
            for t, state in rows:
                count = [str(len(state.contacts))] if scene else []
                stream.write(",".join(state_row(state) + count + [repr(t)]) + "\n")
        finally:
            if stream is not sys.stdout:
                stream.close()
        if sim.mismatches or sim.worst() > 1e-12:
            print(
                "vibrissa export: warning: the log's outputs differ from its re-simulation by up "
                f"to "
                f"{sim.worst():.3e}; run 'vibrissa resim {args.log}'",
                file=sys.stderr,
            )
        return 0

    return _log_tool("export", run)


def _cmd_repair(args) -> int:
    def run():
        from .logs.mcap_log import repair

        kept = repair(args.log, args.output)
        print(f"vibrissa repair: {kept} messages kept -> {args.output}", file=sys.stderr)
        return 0

    return _log_tool("repair", run)


def _cmd_plot(args) -> int:
    try:
        from .scan.plots import PlotRun, plot_runs, si_units
    except ImportError as exc:
        print(
            f"vibrissa plot: error: needs matplotlib ({exc}); pip install '.[plots]'",
            file=sys.stderr,
        )
        return 2

    if args.input.endswith(".mcap"):

        def run():
            from .logs.tools import configurations, export_rows
            from .logs.mcap_log import read_log
            from .node.config import build_config

            rows, sim = export_rows(args.input)
            values = configurations(read_log(args.input)[2])[0][1]
            cfg = build_config(values)
            states = tuple(state for _, state in rows)
            units = si_units(cfg.units.length, cfg.units.force, cfg.units.moment, cfg.world_frame)
            title = f"{args.input}: {cfg.describe()}"
            run_ = PlotRun(
                values.get("model", "elastica"), states, tuple(sim.events), tuple(sim.event_steps)
            )
            plot_runs([run_], cfg.profile, units, title).save(args.output, small=args.small_png)
            return 0

        return _log_tool("plot", run)
    try:
        if not args.profile:
            raise VibrissaError(
                "a scan CSV needs --profile and --param (the figure draws the obstacle)"
            )
        profile = make_profile(args.profile, _params(args.param))
        with open(args.input) as stream:
            import csv as _csv

            rows = list(_csv.DictReader(stream))
        if not rows or "x0" not in rows[0]:
            raise VibrissaError(f"{args.input}: not a scan CSV (no x0 column)")
        x0 = [float(r["x0"]) for r in rows]
        model = (
            make_model("rigid", stiffness=args.spring_stiffness or 1.0)
            if args.model == "rigid"
            else make_model(args.model)
        )
        result = run_scan(profile, x0, model=model)
    except FileNotFoundError:
        print(f"vibrissa plot: error: {args.input}: no such file", file=sys.stderr)
        return 2
    except (VibrissaError, ValueError) as exc:
        print(f"vibrissa plot: error: {exc}", file=sys.stderr)
        return 2
    worst = max(abs(float(r["m0"]) - s.m0) for r, s in zip(rows, result.states))
    if worst > 1e-9 * max(1.0, max(abs(s.m0) for s in result.states)):
        print(
            f"vibrissa plot: error: the CSV is not this profile's scan (m0 differs by "
            f"{worst:.3g}); check "
            "--profile, --param and --model",
            file=sys.stderr,
        )
        return 2
    plot_runs(
        [PlotRun(model.name, result.states, result.events, result.event_steps)],
        profile,
        title=f"{profile.describe()} ({model.name})",
    ).save(args.output, small=args.small_png)
    return 0


def _cmd_reconstruct(args) -> int:
    def run():
        from .node.reconstruction import plot, reconstruct_input, write_csv

        if not os.path.isfile(args.input):
            raise FileNotFoundError(2, "no such file", args.input)
        shape = None
        if args.taper is not None or args.curvature is not None:
            k0, k1 = args.curvature or (0.0, 0.0)
            shape = WhiskerShape(1.0 if args.taper is None else args.taper, k0, k1)
        rec = reconstruct_input(args.input, args.min_force, shape)
        if args.csv == "-":
            write_csv(rec, sys.stdout)
        else:
            with open(args.csv, "w", newline="") as stream:
                write_csv(rec, stream)
        if args.plot:
            plot(rec, args.plot, title=f"{args.input}: contour from the base wrench")
        phases = [int(e.phase) for e in rec.estimates]
        print(
            f"vibrissa reconstruct: {len(rec.estimates)} contact points "
            f"({phases.count(1)} tangential, "
            f"{phases.count(2)} at the tip)",
            file=sys.stderr,
        )
        return 0

    return _log_tool("reconstruct", run)


def main(argv: Optional[List[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
