"""The methods from Python give the CLI's documents bit for bit (the documents
compare as parsed JSON, whose floats read back exactly), and their errors carry
file and line."""

from __future__ import annotations

import json

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


def test_ballbar_setup_error_equals_the_cli(cli, tmp_path):
    args = dict(length=100.012, lmax=100.02, lmin=99.996, theta2=135.0)
    expected = cli.json("ballbar", "setup-error", "--length", "100.012", "--lmax", "100.02",
                        "--lmin", "99.996", "--theta2", "135", cwd=tmp_path)
    assert mtwin.ballbar_setup_error(**args).to_dict() == expected
