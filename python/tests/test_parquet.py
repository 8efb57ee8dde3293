"""`--out X.parquet` of the table-writing commands, read back with pyarrow: the
same column names and the very same numbers as the CSV of the same command; and
the record batches of mtwin.arrow hold them too."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

import mtwin
import mtwin.arrow
from conftest import MACHINES, REPO, read_csv, write_csv

PROGRAM = REPO / "examples" / "programs" / "s-curve-5axis.ngc"


def same_table(parquet_path, csv_path):
    """The Parquet file holds the CSV's columns, in order, as float64, bit for bit."""
    header, values = read_csv(csv_path)
    t = pq.read_table(parquet_path)
    assert t.schema.names == header
    assert all(f.type == pa.float64() and not f.nullable for f in t.schema)
    got = np.column_stack([t.column(c).to_numpy() for c in header])
    assert got.shape == values.shape and np.array_equal(got, values)
    return t


def same_values(batch, table):
    """A record batch of mtwin.arrow holds the file's columns and numbers (the
    batch's columns are nullable, the file's required: only the values compare)."""
    assert batch.schema.names == table.schema.names
    for c in table.schema.names:
        assert np.array_equal(batch.column(c).to_numpy(), table.column(c).to_numpy())


def test_predict_writes_parquet(cli, tmp_path):
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    rng = np.random.default_rng(5)
    t = m.travels
    q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((70_000, m.n_axes))  # two row groups
    write_csv(tmp_path / "poses.csv", m.axis_names, q)
    machine = str(MACHINES / "ac-trunnion-with-errors.toml")
    for out in ("pred.csv", "pred.parquet"):
        cli.run("predict", "--machine", machine, "--data", "poses.csv", "--out", out, cwd=tmp_path)
    table = same_table(tmp_path / "pred.parquet", tmp_path / "pred.csv")
    assert pq.ParquetFile(tmp_path / "pred.parquet").metadata.num_row_groups == 2
    got = np.column_stack([table.column(c).to_numpy() for c in ["x", "y", "z", "i", "j", "k"]])
    assert np.array_equal(got, m.predict(q))


def test_interpolate_and_twin_write_parquet(cli, tmp_path):
    machine = MACHINES / "ac-trunnion-twin.toml"
    m = mtwin.Machine.from_file(machine)
    for out in ("cmd.csv", "cmd.parquet"):
        cli.run("gcode", "interpolate", "--machine", str(machine), str(PROGRAM), "--tcp",
                "--out", out, cwd=tmp_path)
    table = same_table(tmp_path / "cmd.parquet", tmp_path / "cmd.csv")
    same_values(mtwin.arrow.interpolate(PROGRAM, m, tcp=True), table)
    for out in ("pred.csv", "pred.PARQUET"):
        cli.run("twin", "predict", "--machine", str(machine), "--commands", "cmd.csv",
                "--out", out, cwd=tmp_path)
    table = same_table(tmp_path / "pred.PARQUET", tmp_path / "pred.csv")
    assert table.schema.names == mtwin.TWIN_COLUMNS
    batch = mtwin.arrow.twin(m, commands=tmp_path / "cmd.csv")
    same_values(batch, table)
