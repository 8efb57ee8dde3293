"""The remaining methods from Python: ballbar identify and circular, skiving,
servo fit, positioning, G-code interpolate, the twin and compensation give the
CLI's documents and tables bit for bit (documents compare as parsed JSON, whose
floats read back exactly; tables as the CSV the CLI wrote), and their errors
carry file and line."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mtwin
from conftest import MACHINES, REPO, read_csv, write_csv

PROGRAM = REPO / "examples" / "programs" / "s-curve-5axis.ngc"


def without(d: dict, *keys: str) -> dict:
    return {k: v for k, v in d.items() if k not in keys}


def test_ballbar_identify_equals_the_cli(cli, tmp_path):
    cli.run("ballbar", "simulate", "--ex", "-0.0403", "--ey", "-0.0765", "--noise", "0.0003",
            "--seed", "1", "--out", "data", cwd=tmp_path)
    modes = [str(tmp_path / "data" / f"mode{i}.csv") for i in range(1, 5)]
    expected = cli.json("ballbar", "identify", "--mode1", modes[0], "--mode2", modes[1],
                        "--mode3", modes[2], "--mode4", modes[3], "--ex", "-0.0403",
                        "--ey", "-0.0765", "--out", "id.toml", cwd=tmp_path)
    identified, doc = mtwin.ballbar_identify(*modes, ex=-0.0403, ey=-0.0765)
    assert doc.kind == "BallbarIdentifyDoc"
    assert without(doc.to_dict(), "out", "plots") == without(expected, "out", "plots")
    # The identified machine is the one the CLI wrote.
    written = mtwin.Machine.from_file(tmp_path / "id.toml")
    q = np.array([[0.0, 0.0, -100.0, a, c] for a in (-60.0, 0.0, 45.0) for c in (0.0, 90.0, 200.0)])
    assert np.array_equal(identified.predict(q), written.predict(q))
    # The same with the machine given.
    _, doc2 = mtwin.ballbar_identify(*modes, machine=mtwin.Machine.example("ac-trunnion"),
                                     ex=-0.0403, ey=-0.0765)
    assert doc2 == doc
    with pytest.raises(ValueError, match="mode1"):
        mtwin.ballbar_identify()


def test_ballbar_mode_file_errors_carry_the_line(tmp_path):
    p = tmp_path / "mode1.csv"
    p.write_text("angle_deg,length_mm\n0,100\n5,abc\n")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.ballbar_identify(p)
    assert e.value.file == str(p)
    assert e.value.line == 3


def test_ballbar_circular_equals_the_cli(cli, tmp_path):
    cli.run("ballbar", "simulate-circular", "--out", "traces", "--radius", "150",
            "--backlash-x-um", "8", "--squareness-um-per-m", "40", "--noise", "0.2",
            "--samples", "720", cwd=tmp_path)
    cw, ccw = tmp_path / "traces" / "cw.csv", tmp_path / "traces" / "ccw.csv"
    expected = cli.json("ballbar", "circular", "--cw", str(cw), "--ccw", str(ccw),
                        "--radius", "150", cwd=tmp_path)
    doc = mtwin.ballbar_circular(150.0, cw=cw, ccw=ccw)
    assert doc.to_dict() == expected
    # The same traces as (N, 2) arrays.
    _, a = read_csv(cw)
    _, b = read_csv(ccw)
    assert mtwin.ballbar_circular(150.0, cw=a, ccw=b).to_dict() == expected
    expected = cli.json("ballbar", "circular", "--cw", str(cw), "--radius", "150",
                        "--cyclic-pitch", "5", cwd=tmp_path)
    assert mtwin.ballbar_circular(150.0, cw=a, cyclic_pitch=5.0).to_dict() == expected
    with pytest.raises(ValueError, match="trace"):
        mtwin.ballbar_circular(150.0)


def test_skiving_setup_error_equals_the_cli(cli, tmp_path):
    dims = ["--h", "80", "--L", "150", "--rt", "40", "--rg", "60"]
    cli.run("skiving", "simulate", "--x", "0", *dims, "--dgx", "0.03", "--dgy", "-0.02",
            "--exz", "2e-4", "--ezy", "-1e-4", "--noise", "0.001", "--seed", "4",
            "--repeat", "2", "--out", "touches.csv", cwd=tmp_path)
    expected = cli.json("skiving", "setup-error", "--data", "touches.csv", *dims, cwd=tmp_path)
    doc = mtwin.skiving_setup_error(tmp_path / "touches.csv", h=80.0, l=150.0, rt=40.0, rg=60.0)
    assert without(doc.to_dict(), "source") == without(expected, "source")
    assert doc.source == str(tmp_path / "touches.csv")
    expected = cli.json("skiving", "setup-error", "--data", "touches.csv", *dims,
                        "--noise", "0.001", cwd=tmp_path)
    doc = mtwin.skiving_setup_error(tmp_path / "touches.csv", 80.0, 150.0, 40.0, 60.0, noise=0.001)
    assert without(doc.to_dict(), "source") == without(expected, "source")
    assert doc.kind == "SkivingSetupDoc"
    # With the wrong clamping height every face touch is 2·80 mm from its surface.
    with pytest.raises(mtwin.InputError) as e:
        mtwin.skiving_setup_error(tmp_path / "touches.csv", -80.0, 150.0, 40.0, 60.0)
    assert (e.value.file, e.value.line) == (str(tmp_path / "touches.csv"), 2)
    assert "-160.0" in str(e.value)


def servo_log(cli, d):
    """A servo log simulated by the CLI from a known second-order servo (1 ms)."""
    (d / "truth.toml").write_text(
        "ts = 0.001\nb = [0.00243725, 0.00243725]\na = [1.0, -1.8976255, 0.9025]\nnk = 1\n")
    t = np.arange(600) * 0.001
    u = np.where((t > 0.05) & (t < 0.3), 1.0, 0.0) + np.where(t > 0.4, -0.5, 0.0)
    write_csv(d / "cmd.csv", ["t_s", "command_mm"], np.column_stack([t, u]))
    cli.run("servo", "simulate", "--servo", "truth.toml", "--commands", "cmd.csv",
            "--noise", "0.0002", "--seed", "3", "--out", "log.csv", cwd=d)


def test_servo_fit_equals_the_cli(cli, tmp_path):
    servo_log(cli, tmp_path)
    expected = cli.json("servo", "fit", "--data", "log.csv", "--max-order", "2",
                        "--max-delay", "1", "--feed", "2000", "--out", "servo.toml", cwd=tmp_path)
    text, doc = mtwin.servo_fit(tmp_path / "log.csv", max_order=2, max_delay=1, feed=2000.0)
    assert doc.kind == "ServoFitDoc"
    assert without(doc.to_dict(), "out") == without(expected, "out")
    assert text == (tmp_path / "servo.toml").read_text()


def test_servo_log_errors_carry_the_line(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("t_s,command_mm,feedback_mm\n0,0,0\n0.001,x,0\n")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.servo_fit(p)
    assert e.value.file == str(p) and e.value.line == 3


def test_positioning_evaluate_equals_the_cli(cli, tmp_path):
    rows = []
    for target, up, down in ((0, (1.0, 2.5, 1.5), (-3.0, -2.0, -2.5)),
                             (100, (6.0, 7.0, 6.5), (2.0, 3.5, 2.5)),
                             (200, (-1.0, 0.0, -0.5), (-4.5, -4.0, -5.0))):
        for direction, devs in (("up", up), ("down", down)):
            for cycle, dev in enumerate(devs, 1):
                rows.append(f"{target},{direction},{cycle},{dev}")
    (tmp_path / "run.csv").write_text("target_mm,direction,cycle,deviation_um\n" + "\n".join(rows) + "\n")
    expected = cli.json("positioning", "evaluate", "--data", "run.csv", cwd=tmp_path)
    doc = mtwin.positioning_evaluate(tmp_path / "run.csv")
    assert without(doc.to_dict(), "source", "file") == without(expected, "source", "file")
    bad = tmp_path / "bad.csv"
    bad.write_text("target_mm,direction,cycle,deviation_um\n0,up,1,1.0\n0,sideways,1,2\n")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.positioning_evaluate(bad)
    assert e.value.file == str(bad) and e.value.line == 3


def test_gcode_interpolate_equals_the_cli(cli, tmp_path):
    machine = MACHINES / "ac-trunnion.toml"
    expected = cli.json("gcode", "interpolate", "--machine", str(machine), str(PROGRAM),
                        "--ts", "0.01", "--tcp", "--out", "cmd.csv", cwd=tmp_path)
    m = mtwin.Machine.from_file(machine)
    samples, doc = mtwin.gcode_interpolate(PROGRAM, m, ts=0.01, tcp=True)
    assert doc.kind == "GcodeInterpolateDoc"
    assert without(doc.to_dict(), "out") == without(expected, "out")
    header, table = read_csv(tmp_path / "cmd.csv")
    assert header == ["t_s"] + m.axis_names
    assert samples.shape == table.shape and np.array_equal(samples, table)
    # Offsets and the LinuxCNC planner as the CLI's options.
    expected = cli.json("gcode", "interpolate", "--machine", str(machine), str(PROGRAM),
                        "--ts", "0.01", "--tcp", "--offset", "Z=-5", "--planner", "linuxcnc",
                        "--out", "cmd2.csv", cwd=tmp_path)
    samples, doc = mtwin.gcode_interpolate(PROGRAM, m, ts=0.01, tcp=True, offsets={"Z": -5.0},
                                           planner="linuxcnc")
    assert without(doc.to_dict(), "out") == without(expected, "out")
    assert np.array_equal(samples, read_csv(tmp_path / "cmd2.csv")[1])


def test_gcode_interpolate_errors_carry_file_line_and_column(tmp_path):
    p = tmp_path / "bad.ngc"
    p.write_text("G21 G90\nG0 X0 Y0 Z10\nG1 X10 F100 G1 G0\n")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.gcode_interpolate(p, mtwin.Machine.example("ac-trunnion"))
    assert (e.value.file, e.value.line) == (str(p), 3)
    assert e.value.column is not None and e.value.column >= 1
    with pytest.raises(ValueError, match="planner"):
        mtwin.gcode_interpolate(p, mtwin.Machine.example("ac-trunnion"), planner="fast")


def test_twin_predict_equals_the_cli(cli, tmp_path):
    machine = MACHINES / "ac-trunnion-twin.toml"
    expected = cli.json("twin", "predict", "--machine", str(machine), "--gcode", str(PROGRAM),
                        "--tcp", "--out", "pred.csv", cwd=tmp_path)
    m = mtwin.Machine.from_file(machine)
    table, doc = mtwin.twin_predict(m, gcode=PROGRAM, tcp=True)
    assert doc.kind == "TwinPredictDoc"
    assert without(doc.to_dict(), "out", "plots") == without(expected, "out", "plots")
    header, cli_table = read_csv(tmp_path / "pred.csv")
    assert header == mtwin.TWIN_COLUMNS
    assert np.array_equal(table, cli_table)
    # From the axis commands of `gcode interpolate`, geometry only.
    cli.run("gcode", "interpolate", "--machine", str(machine), str(PROGRAM), "--tcp",
            "--out", "cmd.csv", cwd=tmp_path)
    expected = cli.json("twin", "predict", "--machine", str(machine), "--commands", "cmd.csv",
                        "--only", "geometry", "--out", "pred2.csv", cwd=tmp_path)
    table, doc = mtwin.twin_predict(m, commands=tmp_path / "cmd.csv", only="geometry")
    assert without(doc.to_dict(), "out", "plots") == without(expected, "out", "plots")
    assert np.array_equal(table, read_csv(tmp_path / "pred2.csv")[1])
    with pytest.raises(ValueError, match="one of the two"):
        mtwin.twin_predict(m)


def test_compensate_equals_the_cli(cli, tmp_path):
    machine = MACHINES / "ac-trunnion-with-errors.toml"
    expected = cli.json("compensate", "--machine", str(machine), "--program", str(PROGRAM),
                        "--tcp", "--out", "comp.ngc", cwd=tmp_path)
    m = mtwin.Machine.from_file(machine)
    text, doc = mtwin.compensate(m, PROGRAM.read_text(), tcp=True)
    assert doc.kind == "CompensateDoc"
    assert without(doc.to_dict(), "out") == without(expected, "out")
    assert text == (tmp_path / "comp.ngc").read_text()
    assert doc.blocks_changed > 0


def test_compensate_errors_carry_the_line(tmp_path):
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.compensate(m, "G21 G90\nG0 X0 Y0 Z10\nG1 X10 F100 G1 G0\n", path="part.ngc")
    assert (e.value.file, e.value.line) == ("part.ngc", 3)
    with pytest.raises(ValueError, match="tol"):
        mtwin.compensate(m, "G0 X0\n", tol=-1.0)
