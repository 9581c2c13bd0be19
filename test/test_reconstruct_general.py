"""Issue 12: `vibrissa reconstruct` and contour_node's estimate with a tapered, curved whisker."""

import csv
import io
import math

import numpy as np
import pytest

from vibrissa_ros.cli import main
from vibrissa_ros.node.config import build_config, build_contour_config
from vibrissa_ros.node.pipeline import PosePipeline
from vibrissa_ros.node.reconstruction import estimate_from_wrench

RAT = {"whisker.length": 0.03, "whisker.youngs_modulus": 3.3e9, "whisker.base_radius": 5e-5,
       "whisker.taper": 1.0 / 15.0, "whisker.curvature_k0": 1.0 / 0.06,
       "whisker.curvature_k1": -100.0}
PEG = {"obstacle.type": "peg", "obstacle.peg_x": 0.0, "obstacle.peg_y": 0.015,
       "obstacle.peg_radius": 2.5e-4}


def _run(args, capsys):
    try:
        code = main(args)
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def test_contour_config_takes_the_whisker_parameters_and_its_estimate_finds_the_contact():
    node = build_config({**RAT, **PEG})
    contour = build_contour_config(RAT)
    assert contour.shape == node.model.shape and not contour.shape.is_paper
    assert contour.units == node.units
    pipeline = PosePipeline(node)
    q = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    found = 0
    for i, x in enumerate(np.linspace(0.008, -0.01, 60)):
        state, _ = pipeline.handle("world", i, (float(x), 0.0, 0.0), q)
        reading, (fx, fy, tz) = pipeline.reading(state)
        est = estimate_from_wrench(float(x), 0.0, math.pi / 2, fx, fy, tz, contour.units, 0.0,
                                   contour.shape)
        if reading.contact_world is None:
            continue
        found += 1
        got = np.array(est.contact) * 0.03
        assert got == pytest.approx(reading.contact_world, abs=1e-8 * 0.03)
        assert int(est.phase) == reading.phase
    assert found > 20


def test_reconstruct_takes_taper_and_curvature_for_a_scan_csv(tmp_path, capsys):
    scan = tmp_path / "scan.csv"
    code, _, err = _run(
        ["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.6", "--param", "r=0.05",
         "--taper", "0.0667", "--curvature=-1,0.5", "--from", "0.6", "--to", "-0.6", "--step",
         "0.02", "--csv", str(scan)], capsys)
    assert code == 0, err
    out = tmp_path / "rec.csv"
    code, _, err = _run(["reconstruct", str(scan), "--csv", str(out), "--taper", "0.0667",
                         "--curvature=-1,0.5"], capsys)
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(scan.read_text())))
    truth = [(float(r["contact_x"]), float(r["contact_y"])) for r in rows if int(r["phase"]) > 0]
    rec = list(csv.DictReader(io.StringIO(out.read_text())))
    assert len(rec) == len(truth) > 10
    for r, (cx, cy) in zip(rec, truth):
        assert (float(r["contact_x"]), float(r["contact_y"])) == pytest.approx((cx, cy), abs=1e-8)
    # the paper's inverse on the same readings is wrong: the options matter
    code, _, err = _run(["reconstruct", str(scan), "--csv", str(tmp_path / "paper.csv")], capsys)
    paper = list(csv.DictReader(io.StringIO((tmp_path / "paper.csv").read_text())))
    assert code != 0 or len(paper) != len(truth) or any(
        abs(float(p["contact_x"]) - cx) > 1e-3 for p, (cx, _) in zip(paper, truth))


def test_reconstruct_refuses_whisker_options_for_a_log(tmp_path, capsys):
    log = tmp_path / "x.mcap"
    log.write_bytes(b"")
    code, _, err = _run(["reconstruct", str(log), "--csv", "-", "--taper", "0.5"], capsys)
    assert code != 0 and "log carries" in err
