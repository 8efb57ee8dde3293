"""The Spark fleet example on a few machines: Spark (local[2], applyInArrow) and
one-by-one give identical tables (runs only where pyspark is installed)."""

from __future__ import annotations

import sys

import pyarrow.parquet as pq

from conftest import REPO

sys.path.insert(0, str(REPO / "python" / "examples"))
import spark_fleet  # noqa: E402


def test_spark_fleet_equals_one_by_one(tmp_path):
    inp = str(tmp_path / "m.parquet")
    out = str(tmp_path / "id.parquet")
    spark_fleet.simulate(12, inp)
    spark_fleet.run_spark(inp, out, cores=2)
    spark = pq.read_table(out).sort_by("machine")
    local = spark_fleet.run_one_by_one(inp).sort_by("machine")
    assert spark.num_rows == 12
    assert spark.select(local.schema.names).equals(local)
    # Every machine's identification explains its own points better than the nominal model.
    rows = local.to_pylist()
    assert all(r["rms_after"] < r["rms_before"] for r in rows)
