import csv
import io
import json
import math
import subprocess
import sys

import pytest

from vibrissa_ros.cli import main
from vibrissa_ros.scan.scan_io import CSV_COLUMNS


def _run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_scan_writes_the_csv_and_events_contract(tmp_path, capsys):
    csv_path, ev_path = tmp_path / "scan.csv", tmp_path / "events.json"
    code, _, err = _run(
        ["scan", "--profile", "parabola", "--param", "p0=0.3", "--param", "k=1", "--model",
         "elastica", "--from", "2", "--to", "-2", "--step", "0.01", "--csv", str(csv_path),
         "--events", str(ev_path)],
        capsys,
    )
    assert code == 0, err
    text = csv_path.read_text()
    assert text.splitlines()[0] == "x0,phase,alpha,s1,tip_slope,f,fx,fy,m0,contact_x,contact_y"
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == 401
    assert float(rows[0]["x0"]) == 2.0 and float(rows[-1]["x0"]) == -2.0
    assert "nan" not in text.lower()
    phases = [int(r["phase"]) for r in rows]
    assert set(phases) == {0, 1, 2}
    for r in rows:
        if r["phase"] == "0":
            assert (r["alpha"], r["s1"], r["contact_x"], r["contact_y"]) == ("", "", "", "")
            assert float(r["f"]) == float(r["fx"]) == float(r["fy"]) == float(r["m0"]) == 0.0
            assert float(r["tip_slope"]) == pytest.approx(math.pi / 2)
        else:
            assert all(r[c] != "" for c in CSV_COLUMNS)
    events = json.loads(ev_path.read_text())
    assert [(e["kind"], e["from_phase"], e["to_phase"]) for e in events] == [
        ("touch", 0, 2), ("phase", 2, 1), ("phase", 1, 2), ("snap", 2, 0)]
    assert all(set(e) == {"x0", "kind", "from_phase", "to_phase"} for e in events)
    assert events[0]["x0"] == pytest.approx(1.1832159566199232, abs=1e-10)


def test_back_appends_the_return_sweep(tmp_path, capsys):
    out = tmp_path / "s.csv"
    code, _, _ = _run(["scan", "--profile", "catenary", "--param", "p0=0.5", "--param", "c=0.6",
                       "--from", "1.5", "--to", "-1.5", "--step", "0.5", "--back", "--csv",
                       str(out)], capsys)
    assert code == 0
    x0 = [float(r["x0"]) for r in csv.DictReader(out.open())]
    assert x0 == [1.5, 1.0, 0.5, 0.0, -0.5, -1.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5]


def test_grid_ends_at_to_even_off_the_step(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert _run(["scan", "--profile", "parabola", "--param", "p0=0.3", "--from", "2", "--to",
                 "1.75", "--step", "0.1", "--csv", str(out)], capsys)[0] == 0
    assert ([float(r["x0"]) for r in csv.DictReader(out.open())]
            == pytest.approx([2.0, 1.9, 1.8, 1.75]))


@pytest.mark.parametrize(
    "args, words",
    [
        (["--profile", "parabola", "--param", "p0=1.5"], ["p0", "(0, 1)"]),
        (["--profile", "parabola", "--param", "p0=0.3", "--param", "R=2"],
         ["unknown parameter", "R"]),
        (["--profile", "circle", "--param", "p0=0.3"], ["R", "required"]),
        (["--profile", "cone", "--param", "p0=0.3"], ["invalid choice", "cone"]),
        (["--profile", "parabola", "--param", "p0"], ["NAME=VALUE"]),
        (["--profile", "parabola", "--param", "p0=abc"], ["not a number"]),
        (["--profile", "parabola", "--param", "p0=0.3", "--step", "-1"], ["--step", "> 0"]),
        (["--profile", "parabola", "--param", "p0=0.3", "--step", "0"], ["--step", "> 0"]),
        (["--profile", "parabola", "--param", "p0=0.3", "--from", "nan"], ["--from", "finite"]),
        (["--profile", "parabola", "--param", "p0=0.3", "--model", "beam"],
         ["--model", "invalid choice"]),
        (["--profile", "parabola", "--param", "p0=0.3", "--from", "0"], ["inside the obstacle"]),
    ],
)
def test_bad_arguments_exit_2_with_one_line(tmp_path, capsys, args, words):
    base = {"--from": "2", "--to": "-2", "--step": "0.5", "--csv": str(tmp_path / "x.csv")}
    for i, a in enumerate(args):
        if a in base:
            base[a] = args[i + 1]
    argv = ["scan"] + [a for i, a in enumerate(args) if a not in base
                       and (i == 0 or args[i - 1] not in base)]
    for k, v in base.items():
        argv += [k, v]
    with pytest.raises(SystemExit) as info:
        raise SystemExit(main(argv))
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    for word in words:
        assert word in err


def test_module_entry_point_runs_the_same_command(tmp_path):
    out = tmp_path / "s.csv"
    proc = subprocess.run(
        [sys.executable, "-m", "vibrissa_ros", "scan", "--profile", "two_circles", "--param",
         "p0=0.4", "--param", "R_left=0.8", "--param", "R_right=1.6", "--from", "2", "--to", "-2",
         "--step", "0.25", "--csv", str(out)],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert out.read_text().startswith("x0,phase,alpha,")
    proc = subprocess.run([sys.executable, "-m", "vibrissa_ros", "scan"], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1


def test_model_rigid_follows_the_same_contract(tmp_path, capsys):
    csv_path, ev_path = tmp_path / "r.csv", tmp_path / "r.json"
    code, _, err = _run(["scan", "--profile", "parabola", "--param", "p0=0.6", "--model", "rigid",
                         "--from", "2", "--to", "-2", "--step", "0.01", "--csv", str(csv_path),
                         "--events", str(ev_path)], capsys)
    assert code == 0, err
    assert csv_path.read_text().splitlines()[0] == ",".join(CSV_COLUMNS)
    events = json.loads(ev_path.read_text())
    assert [(e["kind"], e["to_phase"]) for e in events] == [("touch", 2), ("snap", 0)]
    assert events[1]["x0"] == pytest.approx(-1.2360068169203338, abs=1e-10)


def test_model_both_writes_both_models_in_the_same_units(tmp_path, capsys):
    csv_path, ev_path = tmp_path / "scan.csv", tmp_path / "events.json"
    args = ["scan", "--profile", "catenary", "--param", "p0=0.5", "--param", "c=0.6", "--model",
            "both", "--from", "2", "--to", "-2", "--step", "0.05", "--csv", str(csv_path),
            "--events", str(ev_path)]
    assert _run(args, capsys)[0] == 0
    el = list(csv.DictReader(csv_path.open()))
    rg = list(csv.DictReader((tmp_path / "scan.rigid.csv").open()))
    assert [r["x0"] for r in el] == [r["x0"] for r in rg]
    assert json.loads((tmp_path / "events.rigid.json").read_text())[0]["kind"] == "touch"
    # rigid in EI units with c = 3 EI/L: the same as --model rigid --spring-stiffness 3
    alone = tmp_path / "alone.csv"
    assert _run(args[:7] + ["--model", "rigid", "--spring-stiffness", "3", "--from", "2", "--to",
                            "-2", "--step", "0.05", "--csv", str(alone)], capsys)[0] == 0
    assert alone.read_text() == (tmp_path / "scan.rigid.csv").read_text()
    code, _, err = _run(args[:-4] + ["--csv", "-"], capsys)
    assert code == 2 and "two CSV files" in err


def test_scan_plot_and_plot_of_its_csv(tmp_path, capsys):
    csv_path, png = tmp_path / "s.csv", tmp_path / "s.png"
    base = ["--profile", "parabola", "--param", "p0=0.3"]
    assert _run(["scan", *base, "--from", "2", "--to", "-2", "--step", "0.05", "--back", "--csv",
                 str(csv_path), "--plot", str(png), "--small-png"], capsys)[0] == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = tmp_path / "again.png"
    assert _run(["plot", str(csv_path), "-o", str(again), *base, "--small-png"], capsys)[0] == 0
    assert again.stat().st_size > 10_000
    code, _, err = _run(["plot", str(csv_path), "-o", str(again)], capsys)
    assert code == 2 and "--profile" in err
    code, _, err = _run(["plot", str(csv_path), "-o", str(again), "--profile", "parabola",
                         "--param", "p0=0.35"], capsys)
    assert code == 2 and "not this profile's scan" in err


def test_reconstruct_a_scan_csv_uses_only_what_a_sensor_measures(tmp_path, capsys):
    scan_csv, out, png = tmp_path / "s.csv", tmp_path / "r.csv", tmp_path / "r.png"
    assert _run(["scan", "--profile", "two_circles", "--param", "p0=0.4", "--param", "R_left=0.8",
                 "--param", "R_right=1.6", "--from", "2", "--to", "-2", "--step", "0.02", "--back",
                 "--csv", str(scan_csv)],
                capsys)[0] == 0
    rows = list(csv.DictReader(scan_csv.open()))
    # keep only the sensor's columns: the estimate must not need anything else
    sensor = tmp_path / "sensor.csv"
    with sensor.open("w") as stream:
        stream.write("x0,fx,fy,m0\n")
        for r in rows:
            stream.write(f"{r['x0']},{r['fx']},{r['fy']},{r['m0']}\n")
    assert _run(["reconstruct", str(sensor), "--csv", str(out)], capsys)[0] == 0
    got = list(csv.DictReader(out.open()))
    assert list(got[0]) == ["x0", "phase", "contact_x", "contact_y", "alpha"]
    contact_rows = [r for r in rows if r["phase"] != "0"]
    assert len(got) == len(contact_rows)
    for g, r in zip(got, contact_rows):
        assert (g["x0"], g["phase"]) == (r["x0"], r["phase"])
        assert float(g["contact_x"]) == pytest.approx(float(r["contact_x"]), abs=1e-12)
        assert float(g["contact_y"]) == pytest.approx(float(r["contact_y"]), abs=1e-12)
        assert float(g["alpha"]) == pytest.approx(float(r["alpha"]), abs=1e-12)
    assert _run(["reconstruct", str(scan_csv), "--csv", str(out), "--plot", str(png)],
                capsys)[0] == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    bad = tmp_path / "bad.csv"
    bad.write_text("x0,fx\n1,2\n")
    code, _, err = _run(["reconstruct", str(bad), "--csv", str(out)], capsys)
    assert code == 1 and "m0" in err and len(err.strip().splitlines()) == 1
