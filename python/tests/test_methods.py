"""The methods from Python give the CLI's documents bit for bit (the documents
compare as parsed JSON, whose floats read back exactly), and their errors carry
file and line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import mtwin
from conftest import MACHINES, REPO, read_csv, write_csv

PROGRAM = REPO / "examples" / "programs" / "s-curve-5axis.ngc"


def without(d: dict, *keys: str) -> dict:
    return {k: v for k, v in d.items() if k not in keys}


def test_gcode_stats_equals_the_cli(cli, tmp_path):
    expected = cli.json("gcode", "stats", str(PROGRAM), cwd=tmp_path)
    doc = mtwin.gcode_stats(PROGRAM)
    assert doc.kind == "GcodeStatsDoc"
    assert doc.to_dict() == expected
    machine = MACHINES / "ac-trunnion.toml"
    expected = cli.json(
        "gcode", "stats", str(PROGRAM), "--machine", str(machine), cwd=tmp_path
    )
    doc = mtwin.gcode_stats(PROGRAM, machine=mtwin.Machine.from_file(machine))
    assert doc.to_dict() == expected
    assert json.loads(doc.to_json()) == expected


def test_gcode_errors_carry_file_line_and_column(tmp_path):
    p = tmp_path / "bad.ngc"
    p.write_text("G21 G90\nG0 X0 Y0 Z10\nG1 X10 F100 G1 G0\n")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.gcode_stats(p)
    assert e.value.file == str(p)
    assert e.value.line == 3
    assert e.value.column is not None and e.value.column >= 1
    assert str(e.value).startswith(f"{p}:3:")


@pytest.fixture(scope="module")
def tracker_data(cli, tmp_path_factory):
    """Simulated laser-tracker measurements of the gantry with errors (the CLI's own
    simulation), at random poses."""
    d = tmp_path_factory.mktemp("tracker")
    m = mtwin.Machine.example("afp-gantry")
    rng = np.random.default_rng(11)
    t = m.travels
    q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((120, m.n_axes))
    write_csv(d / "poses.csv", m.axis_names, q[:90])
    write_csv(d / "check-poses.csv", m.axis_names, q[90:])
    truth = str(MACHINES / "afp-gantry-with-errors.toml")
    for poses, out in (("poses.csv", "fit.csv"), ("check-poses.csv", "check.csv")):
        cli.run("tracker", "simulate", "--machine", truth, "--poses", poses,
                "--noise", "0.001", "--seed", "1", "--out", out, cwd=d)
    return d


def test_tracker_identify_and_validate_equal_the_cli(cli, tracker_data):
    d = tracker_data
    nominal = str(MACHINES / "afp-gantry.toml")
    spec = "location"
    expected = cli.json("tracker", "identify", "--machine", nominal, "--data", "fit.csv",
                        "--fit", spec, "--out", "id.toml", cwd=d)
    m = mtwin.Machine.from_file(nominal)
    identified, doc = mtwin.tracker_identify(m, d / "fit.csv", spec)
    assert doc.kind == "TrackerIdentifyDoc"
    assert without(doc.to_dict(), "out") == without(expected, "out")
    # The same from an array of the same columns.
    header, table = read_csv(d / "fit.csv")
    cols = [header.index(c) for c in m.axis_names + ["x", "y", "z"]]
    identified2, doc2 = mtwin.tracker_identify(m, np.ascontiguousarray(table[:, cols]), spec)
    assert without(doc2.to_dict(), "out") == without(expected, "out")
    # The identified machine is the one the CLI wrote.
    written = mtwin.Machine.from_file(d / "id.toml")
    q = table[:, [header.index(c) for c in m.axis_names]]
    assert np.array_equal(identified.predict(q), written.predict(q))
    assert np.array_equal(identified2.predict(q), written.predict(q))
    # Validation on the held-out poses.
    expected = cli.json("tracker", "validate", "--machine", "id.toml", "--data", "check.csv", cwd=d)
    v = mtwin.tracker_validate(written, d / "check.csv")
    assert v.to_dict() == expected
    # The identification explains the measurements to about the noise (1 µm).
    assert v.to_dict() != {} and doc.kind == "TrackerIdentifyDoc"


def test_tracker_input_errors_name_the_file(tmp_path):
    p = tmp_path / "fit.csv"
    p.write_text("X,Y,Z,x,y,z\n1,2,3,4,5,6\n")
    m = mtwin.Machine.example("afp-gantry")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.tracker_identify(m, p, "location")
    assert e.value.file == str(p)
    with pytest.raises(ValueError, match="fit"):
        mtwin.tracker_identify(m, np.zeros((3, m.n_axes + 3)), "no-such-error")


def thermal_training(path):
    """A first-order drift model: τ·de/dt = g·n − e at two heights, three runs."""
    rows = []
    for run, speeds in enumerate(([6000.0] * 24, [2000.0] * 8 + [8000.0] * 8 + [0.0] * 8,
                                  [3000.0, 7000.0, 1000.0, 5000.0] * 6)):
        for z, gain in ((-300.0, 2e-6), (-100.0, 1e-6)):
            e = 0.0
            for k, n in enumerate(speeds):
                rows.append((k * 10.0, n, z, e, run))
                e = 0.8 * e + 0.2 * gain * n
    with open(path, "w") as f:
        f.write("t_min,speed_rpm,z_mm,drift_mm,run\n")
        for t, n, z, e, run in rows:
            f.write(f"{t!r},{n!r},{z!r},{e!r},{run}\n")


def test_thermal_fit_and_predict_equal_the_cli(cli, tmp_path):
    thermal_training(tmp_path / "train.csv")
    expected = cli.json("thermal", "fit", "--data", "train.csv", "--max-order", "2",
                        "--out", "t.toml", cwd=tmp_path)
    text, doc = mtwin.thermal_fit(tmp_path / "train.csv", max_order=2)
    assert without(doc.to_dict(), "out") == without(expected, "out")
    assert text == (tmp_path / "t.toml").read_text()
    with open(tmp_path / "speed.csv", "w") as f:
        f.write("t_min,speed_rpm\n")
        for k in range(12):
            f.write(f"{k * 10.0!r},{[5000.0, 1000.0][k // 6]!r}\n")
    expected = cli.json("thermal", "predict", "--model", "t.toml", "--speed", "speed.csv",
                        "--z", "-300,-100", "--out", "drift.csv", cwd=tmp_path)
    table, pdoc = mtwin.thermal_predict(tmp_path / "t.toml", tmp_path / "speed.csv", [-300.0, -100.0])
    assert without(pdoc.to_dict(), "out") == without(expected, "out")
    header, cli_table = read_csv(tmp_path / "drift.csv")
    assert header == ["t_min", "z_mm", "drift_mm"]
    assert np.array_equal(table, cli_table)


def thermal_log(path, minutes=360, drift=True, bad_row=None):
    """A wide log every 30 s: a Z drift following the speed (pole 0.95 per
    minute), an X drift following a temperature rise, a temperature that does
    not act."""
    rows = []
    ez = ex = 0.0
    for k in range(2 * minutes):
        t = k * 0.5
        n = [0.0, 3000.0, 6000.0, 1500.0][int(t // 45) % 4]
        t1 = 20.0 + 4.0 * (1.0 - math.exp(-t / 90.0))
        t2 = 22.0 + 0.3 * math.sin(t / 40.0)
        rows.append((t, n, t1, t2, ez, ex))
        if k % 2 == 1:
            ez = 0.95 * ez + 0.05 * (-0.004) * n
            ex = 0.9 * ex + 0.1 * 0.002 * (t1 - 20.0)
    with open(path, "w") as f:
        f.write("t_min,speed_rpm,t1_c,t2_c" + (",grow_um,shift_mm" if drift else "") + "\n")
        for i, (t, n, t1, t2, ez, ex) in enumerate(rows):
            cells = [repr(t), repr(n), repr(t1), "x" if i == bad_row else repr(t2)]
            if drift:
                cells += [repr(ez), repr(ex)]
            f.write(",".join(cells) + "\n")


def test_thermal_fit_log_and_predict_log_equal_the_cli(cli, tmp_path):
    thermal_log(tmp_path / "log.csv")
    args = ["thermal", "fit", "--log", "log.csv", "--drift", "grow_um:Z,shift_mm:X",
            "--inputs", "speed_rpm,t1_c,t2_c", "--train-until-min", "300"]
    for folds, flag in ((3, "3"), ([2, 3], "2,3")):
        expected = cli.json(*args, "--folds", flag, "--out", "m.toml", cwd=tmp_path)
        text, doc = mtwin.thermal_fit_log(tmp_path / "log.csv", ["grow_um:Z", "shift_mm:X"],
                                          ["speed_rpm", "t1_c", "t2_c"], train_until_min=300.0,
                                          folds=folds)
        assert doc.kind == "ThermalLogFitDoc"
        assert without(doc.to_dict(), "out") == without(expected, "out")
        assert text == (tmp_path / "m.toml").read_text()
    assert doc.ensemble_folds == [3]
    assert [m["folds"] for m in doc.channels[0]["members"]] == [3]
    # The plain rises kept beside those over an ambient sensor: the same
    # document and model file as the CLI's `--ambient t2_c --also-plain`.
    expected = cli.json(*args, "--ambient", "t2_c", "--also-plain", "--out", "j.toml",
                        cwd=tmp_path)
    text, jdoc = mtwin.thermal_fit_log(tmp_path / "log.csv", ["grow_um:Z", "shift_mm:X"],
                                       ["speed_rpm", "t1_c", "t2_c"], train_until_min=300.0,
                                       ambient="t2_c", also_plain=True)
    assert jdoc.also_plain and without(jdoc.to_dict(), "out") == without(expected, "out")
    assert text == (tmp_path / "j.toml").read_text()
    assert len(jdoc.channels[0]["members"]) == 1
    with pytest.raises(ValueError, match="ambient sensor too"):
        mtwin.thermal_fit_log(tmp_path / "log.csv", ["grow_um:Z"], ["t1_c"], also_plain=True)
    thermal_log(tmp_path / "new.csv", minutes=120, drift=False)
    expected = cli.json("thermal", "predict", "--model", "m.toml", "--log", "new.csv",
                        "--out", "pred.csv", cwd=tmp_path)
    table, pdoc = mtwin.thermal_predict_log(tmp_path / "m.toml", tmp_path / "new.csv")
    assert pdoc.kind == "ThermalLogPredictDoc"
    assert without(pdoc.to_dict(), "out") == without(expected, "out")
    header, cli_table = read_csv(tmp_path / "pred.csv")
    assert header == ["t_min", "grow_um", "shift_mm"]
    assert np.array_equal(table, cli_table)
    # Bad input: a cell that is not a number names its line; bad options
    # raise ValueError before the log is read.
    thermal_log(tmp_path / "bad.csv", bad_row=7)
    with pytest.raises(mtwin.InputError) as e:
        mtwin.thermal_fit_log(tmp_path / "bad.csv", ["grow_um:Z"], ["t2_c"])
    assert e.value.line == 9 and e.value.file.endswith("bad.csv")
    with pytest.raises(ValueError, match="given twice"):
        mtwin.thermal_fit_log(tmp_path / "log.csv", ["grow_um:Z"], ["t1_c"], folds=[3, 3])
    with pytest.raises(ValueError, match="drift"):
        mtwin.thermal_fit_log(tmp_path / "log.csv", ["grow_um"], ["t1_c"])


def test_ballbar_setup_error_equals_the_cli(cli, tmp_path):
    args = dict(length=100.012, lmax=100.02, lmin=99.996, theta2=135.0)
    expected = cli.json("ballbar", "setup-error", "--length", "100.012", "--lmax", "100.02",
                        "--lmin", "99.996", "--theta2", "135", cwd=tmp_path)
    assert mtwin.ballbar_setup_error(**args).to_dict() == expected
