"""The machine model from Python: loaders, predict (the contract, bit for bit with
`mtwin predict`), Jacobians, inverse kinematics, zero copy, errors."""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import mtwin
from conftest import MACHINES, read_csv, write_csv

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def random_poses(m: mtwin.Machine, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = m.travels
    return t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((n, m.n_axes))


@pytest.mark.parametrize(
    ("name", "n"),
    [
        ("ac-trunnion-with-errors", 257),
        ("afp-gantry-with-errors", 257),
        ("skiving-with-errors", 257),
        # Several of the binding's parallel blocks of 1024 poses, the last one partial.
        ("ac-trunnion-with-errors", 3 * 1024 + 37),
    ],
)
def test_predict_equals_the_cli_bit_for_bit(name, n, cli, tmp_path):
    path = MACHINES / f"{name}.toml"
    m = mtwin.Machine.from_file(path)
    q = random_poses(m, n, seed=3)
    write_csv(tmp_path / "poses.csv", m.axis_names, q)
    cli.run("predict", "--machine", str(path), "--data", "poses.csv", "--out", "pred.csv", cwd=tmp_path)
    header, table = read_csv(tmp_path / "pred.csv")
    assert header == m.axis_names + ["x", "y", "z", "i", "j", "k"]
    # The CLI read the very same positions (shortest round-trip text).
    assert np.array_equal(table[:, : m.n_axes], q)
    got = m.predict(q)
    assert got.shape == (n, 6) and got.dtype == np.float64
    assert np.array_equal(got, table[:, m.n_axes :]), "not bit for bit"


def test_every_loader_gives_the_same_machine():
    name = "ac-trunnion-with-errors"
    path = MACHINES / f"{name}.toml"
    text = path.read_text()
    with open(path, "rb") as f:
        data = tomllib.load(f)
    machines = [
        mtwin.Machine.from_file(path),
        mtwin.Machine.from_file(str(path)),
        mtwin.Machine.from_str(text),
        mtwin.Machine.from_dict(data),
        mtwin.Machine.example(name),
    ]
    back = mtwin.Machine.from_dict(machines[0].to_dict())
    machines.append(back)
    machines.append(mtwin.Machine.from_str(machines[0].to_toml()))
    q = random_poses(machines[0], 50, seed=1)
    ref = machines[0].predict(q)
    for m in machines[1:]:
        assert m.axis_names == machines[0].axis_names
        assert np.array_equal(m.predict(q), ref)
    assert set(mtwin.example_names()) == {p.stem for p in MACHINES.glob("*.toml")}
    assert "ac-trunnion-with-errors" in repr(machines[0])


def test_a_machine_without_errors_predicts_its_nominal_poses():
    ideal = mtwin.Machine.example("ac-trunnion")
    real = mtwin.Machine.example("ac-trunnion-with-errors")
    q = random_poses(ideal, 40, seed=2)
    assert np.array_equal(ideal.predict(q), ideal.predict_nominal(q))
    assert np.array_equal(real.predict_nominal(q), ideal.predict(q))
    # The errors move the tool by a little (µm … tenths of a mm), not by nothing.
    d = np.linalg.norm(real.predict(q)[:, :3] - ideal.predict(q)[:, :3], axis=1)
    assert 0 < d.max() < 1.0
    # Tool axes are unit vectors.
    assert np.allclose(np.linalg.norm(real.predict(q)[:, 3:], axis=1), 1.0, atol=1e-14)


def test_on_the_nominal_gantry_the_tip_moves_one_for_one_with_the_linear_axes():
    m = mtwin.Machine.example("afp-gantry")
    q = random_poses(m, 10, seed=4)
    lin = [i for i, n in enumerate(m.axis_names) if n in ("X", "Y", "Z")]
    q2 = q.copy()
    q2[:, lin] += 1.5
    # Translating every linear axis by 1.5 mm translates the tip by 1.5 mm along
    # each axis direction; |Δp| is then 1.5·√3 whatever the rotary axes.
    d = np.linalg.norm(m.predict(q2, check_travel=False)[:, :3] - m.predict(q)[:, :3], axis=1)
    assert np.allclose(d, 1.5 * np.sqrt(3.0), rtol=0, atol=1e-9)


def test_the_input_array_is_read_in_place_not_copied():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    q = np.ascontiguousarray(random_poses(m, 1000, seed=5))
    addr = q.__array_interface__["data"][0]
    assert mtwin._mtwin._rows_address(q, m.n_axes) == addr
    # A view of the rows is contiguous too: still no copy.
    view = q[100:200]
    assert mtwin._mtwin._rows_address(view, m.n_axes) == view.__array_interface__["data"][0]
    # A Fortran-ordered array cannot be read in place: it is copied, and the result is the same.
    f = np.asfortranarray(q)
    assert mtwin._mtwin._rows_address(f, m.n_axes) != f.__array_interface__["data"][0]
    assert np.array_equal(m.predict(f), m.predict(q))
    # Read only: the caller's array is untouched and stays writeable.
    before = q.copy()
    m.predict(q)
    assert np.array_equal(q, before) and q.flags.writeable


def test_predict_releases_the_gil():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    q = random_poses(m, 400_000, seed=6)
    ticks = []
    done = threading.Event()

    def work():
        m.predict(q)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    # While the Rust code runs, this Python thread keeps running.
    while not done.is_set():
        ticks.append(1)
        done.wait(0.001)
    t.join()
    assert len(ticks) > 3


def test_jacobian_equals_central_differences():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    q = random_poses(m, 20, seed=7)
    # Stay off the travel ends so that q ± h is inside.
    q = 0.5 * q + 0.25 * (m.travels[:, 0] + m.travels[:, 1])
    j = m.jacobian(q)
    assert j.shape == (20, 6, m.n_axes)
    h = 1e-4
    for a in range(m.n_axes):
        dq = np.zeros(m.n_axes)
        dq[a] = h
        fd = (m.predict(q + dq) - m.predict(q - dq)) / (2 * h)
        assert np.allclose(j[:, :, a], fd, rtol=0, atol=1e-7), m.axis_names[a]


def test_inverse_kinematics_reaches_the_predicted_poses():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    q = random_poses(m, 50, seed=8)
    q = 0.5 * q + 0.25 * (m.travels[:, 0] + m.travels[:, 1])
    target = m.predict(q)
    # Tip only, linear axes free, rotary axes kept where they were.
    start_rot = q.copy()
    sol = np.vstack([m.inverse(target[k : k + 1, :3], start=start_rot[k]) for k in range(5)])
    assert np.allclose(m.predict(sol)[:, :3], target[:5, :3], rtol=0, atol=1e-9)
    # Tip and tool axis, every axis free, each from a start 1 mm / 1° away.
    sol = np.vstack([m.inverse(target[k : k + 1], start=q[k] + 1.0) for k in range(20)])
    assert np.allclose(m.predict(sol), target[:20], rtol=0, atol=1e-9)
    # Along a path of nearby targets, each solve starting from the last solution.
    path = q[0] + np.linspace(0.0, 2.0, 30)[:, None] * np.ones(m.n_axes)
    pt = m.predict(path)
    warm = m.inverse(pt, start=path[0] + 0.5, warm=True)
    assert np.allclose(m.predict(warm), pt, rtol=0, atol=1e-9)
    cold = m.inverse(pt, start=path[0] + 0.5)
    assert np.allclose(m.predict(cold), pt, rtol=0, atol=1e-9)
    # From the middle of the travels (A = 0: the C axis is parallel to the tool) the
    # orientation is singular; with on_error="nan" the failures are NaN rows.
    mid = m.inverse(target[:5], on_error="nan")
    bad = np.isnan(mid).any(axis=1)
    assert np.allclose(m.predict(mid[~bad]), target[:5][~bad], rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match="target"):
        m.inverse(np.array([[1e6, 0.0, 0.0]]))


def test_bad_arrays_are_refused_with_a_reason():
    m = mtwin.Machine.example("ac-trunnion")
    with pytest.raises(ValueError, match="5 columns"):
        m.predict(np.zeros((3, 4)))
    q = np.zeros((2, 5))
    q[1, 0] = 1e6
    with pytest.raises(ValueError, match=r"pose 1: axis Y at 1000000(\.0)? mm is outside its travel"):
        m.predict(q)
    q[1, 0] = np.nan
    with pytest.raises(ValueError, match="pose 1"):
        m.predict(q, check_travel=False)
    with pytest.raises(TypeError):
        m.predict(np.zeros((2, 5), dtype=np.int64))


def test_the_first_bad_pose_is_named_though_blocks_run_in_parallel():
    # `predict` checks and computes blocks of 1024 poses on several threads: the error
    # still names the first bad pose of the array, whichever block is checked first.
    m = mtwin.Machine.example("ac-trunnion")
    q = random_poses(m, 10_000, seed=9)
    q[9_999, 1] = 400.0  # X, beyond its travel [-300, 300]
    q[7_000, 4] = np.nan  # C
    q[5_000, 0] = -301.0  # Y
    with pytest.raises(ValueError, match=r"^pose 5000: axis Y at -301(\.0)? mm is outside its travel \[-300(\.0)?, 300(\.0)?\]$"):
        m.predict(q)
    q[5_000, 0] = 0.0
    with pytest.raises(ValueError, match=r"^pose 7000: axis C is NaN$"):
        m.predict(q)
    q[7_000, 4] = 0.0
    with pytest.raises(ValueError, match=r"^pose 9999: axis X at 400(\.0)? mm"):
        m.predict(q)
    # Without the travel check the pose beyond the travel is computed, and is where
    # the nominal machine puts it: 100 mm more of X than at the end of the travel.
    far = m.predict(q, check_travel=False)
    q2 = q.copy()
    q2[9_999, 1] = 300.0
    edge = m.predict(q2)
    assert np.array_equal(far[:9_999], edge[:9_999])
    # (X moves the tool in the machine frame; W turns with the table, so the tip moves
    # 100 mm in some direction of W, and the tool axis does not change.)
    assert abs(np.linalg.norm(far[9_999, :3] - edge[9_999, :3]) - 100.0) < 1e-9
    assert np.allclose(far[9_999, 3:], edge[9_999, 3:], rtol=0, atol=1e-15)


def test_predict_returns_a_new_c_ordered_array_it_owns():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    q = random_poses(m, 2_000, seed=10)
    a = m.predict(q)
    b = m.predict(q)
    assert a.shape == (2_000, 6) and a.dtype == np.float64
    assert a.flags.c_contiguous and a.flags.writeable and a.flags.owndata
    assert not np.shares_memory(a, b) and not np.shares_memory(a, q)
    assert np.array_equal(a, b)
    assert m.predict(np.zeros((0, m.n_axes))).shape == (0, 6)


def test_a_bad_machine_file_raises_input_error_with_file_line_and_column(tmp_path):
    text = (MACHINES / "ac-trunnion.toml").read_text().splitlines()
    k = next(i for i, l in enumerate(text) if l.strip().startswith("kind = \"linear\""))
    col = text[k].index('"linear"') + 1
    text[k] = text[k].replace('"linear"', '"lineer"')
    bad = tmp_path / "bad.toml"
    bad.write_text("\n".join(text) + "\n")
    with pytest.raises(mtwin.InputError) as e:
        mtwin.Machine.from_file(bad)
    err = e.value
    assert isinstance(err, ValueError)
    assert err.file == str(bad)
    assert err.line == k + 1
    # The reader names the line of the value (a column where it has one).
    assert err.column in (None, col)
    assert str(err).startswith(f"{bad}:{k + 1}:")
    assert "kind" in str(err)
    assert err.problems[0][:2] == (str(bad), k + 1)
    with pytest.raises(mtwin.InputError) as e:
        mtwin.Machine.from_str("\n".join(text), path="inline.toml")
    assert (e.value.file, e.value.line) == ("inline.toml", k + 1)
    with pytest.raises(mtwin.InputError) as e:
        mtwin.Machine.from_file(tmp_path / "missing.toml")
    assert e.value.file == str(tmp_path / "missing.toml") and e.value.line == 0
    with pytest.raises(mtwin.InputError, match="no bundled machine"):
        mtwin.Machine.example("no-such")


def test_the_machine_check_document():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    doc = m.check()
    assert isinstance(doc, mtwin.Document)
    d = doc.to_dict()
    assert isinstance(d, dict) and d
    # Attributes are the fields of the dict.
    for k, v in d.items():
        got = getattr(doc, k)
        assert (got.to_dict() if isinstance(got, mtwin.Document) else got) == v or isinstance(v, list)
    assert repr(doc).startswith("ModelCheckDoc(")
