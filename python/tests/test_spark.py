"""The Spark fleet examples on a few machines: Spark (local[2], applyInArrow)
and the same function machine by machine give identical tables (runs only
where pyspark is installed; `.ci/run` installs it and requires these tests)."""

from __future__ import annotations

import sys

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq

from conftest import REPO

sys.path.insert(0, str(REPO / "python" / "examples"))
import spark_fleet  # noqa: E402
import spark_thermal_fleet  # noqa: E402


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


def test_spark_thermal_fleet_equals_one_by_one(tmp_path):
    n = 8
    inp = str(tmp_path / "logs.parquet")
    out = str(tmp_path / "thermal.parquet")
    spark_thermal_fleet.simulate(n, inp)
    spark_thermal_fleet.run_spark(inp, out, cores=2)
    spark = pq.read_table(out).sort_by("machine")
    local = spark_thermal_fleet.run_one_by_one(inp).sort_by("machine")
    assert spark.num_rows == n
    assert spark.select(local.schema.names).equals(local)
    assert local.column("machine").to_pylist() == [f"m{k:04d}" for k in range(n)]

    # Against the known truth of the simulation: the held-out run's drift is tens
    # of µm, and every machine's fitted model predicts it from cold to within a
    # few times the 0.5 µm probing noise (the noise alone gives 0.5 µm).
    logs = pq.read_table(inp)
    noise = spark_thermal_fleet.NOISE
    for r in local.to_pylist():
        check = logs.filter(pc.and_(pc.equal(logs.column("machine"), r["machine"]),
                                    pc.equal(logs.column("part"), "check")))
        drift = check.column("drift_mm").to_numpy()
        assert np.sqrt(np.mean(drift * drift)) > 20 * noise
        assert r["stable"]
        assert r["z_mm"] == spark_thermal_fleet.HEIGHTS
        assert r["samples"] == 2 * 36
        assert r["held_out_rms_mm"] < 3 * noise, r
        assert r["model_toml"].count("[[heights]]") == 2
