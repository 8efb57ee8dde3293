"""A fleet of machines on Spark: simulated laser-tracker measurements of N
machines, grouped by machine, identified with mtwin in `applyInArrow`, written
as a Parquet table of identified errors, fit and held-out residuals and
warnings per machine; then the same machines one by one in this process, and
the two results compared.

    pip install pyspark "pandas<3"  # Java 17 on the machine
    python python/examples/spark_fleet.py --machines 500 --cores 2 --out fleet.parquet

The job is plain Spark: on a cluster, the same script runs unchanged with
`spark-submit --master <cluster URL> spark_fleet.py --cluster` when `mtwin` is installed on the executors (`pip install` of the wheel
in the cluster's Python environment); the input and output paths then name
shared storage.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

import mtwin

NOMINAL = "afp-gantry"
TRUTH = "afp-gantry-with-errors"
FIT = "location"
POINTS = 60
HELD_OUT = 15
MEASURED = ["mx", "my", "mz"]


def simulate(n_machines: int, path: str) -> None:
    """POINTS tracker measurements per machine: random poses, the truth machine's
    tool tips with 1 µm noise, a machine-specific seed."""
    nominal = mtwin.Machine.example(NOMINAL)
    truth = mtwin.Machine.example(TRUTH)
    t = nominal.travels
    # Spark's column names are case-insensitive: the measured tips are mx, my, mz
    # beside the axis columns X, Y, Z.
    cols = {n: [] for n in ["machine", "point"] + nominal.axis_names + MEASURED}
    for k in range(n_machines):
        rng = np.random.default_rng(1000 + k)
        q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((POINTS, nominal.n_axes))
        tips = truth.predict(q)[:, :3] + rng.normal(0.0, 0.001, (POINTS, 3))
        cols["machine"] += [f"m{k:04d}"] * POINTS
        cols["point"] += list(range(POINTS))
        for a, n in enumerate(nominal.axis_names):
            cols[n] += list(q[:, a])
        for c, n in enumerate(MEASURED):
            cols[n] += list(tips[:, c])
    pq.write_table(pa.table(cols), path)


RESULT_SCHEMA = pa.schema(
    [
        ("machine", pa.string()),
        ("points", pa.int64()),
        ("rms_before", pa.float64()),
        ("rms_after", pa.float64()),
        ("held_out_rms", pa.float64()),
        ("rank", pa.int64()),
        ("parameter", pa.list_(pa.string())),
        ("value", pa.list_(pa.float64())),
        ("warnings", pa.list_(pa.string())),
    ]
)


def identify_one(table: pa.Table) -> pa.Table:
    """One machine's rows → one result row: identify on all but the last HELD_OUT
    points, the RMS tool-tip distance (mm) on those held out."""
    nominal = mtwin.Machine.example(NOMINAL)
    table = table.sort_by("point")
    names = nominal.axis_names
    cols = lambda t, ns: np.column_stack([t.column(n).to_numpy() for n in ns])
    fit, held = table.slice(0, table.num_rows - HELD_OUT), table.slice(table.num_rows - HELD_OUT)
    identified, doc = mtwin.tracker_identify(nominal, np.ascontiguousarray(cols(fit, names + MEASURED)), FIT)
    d = doc.to_dict()
    dd = identified.predict(cols(held, names), check_travel=False)[:, :3] - cols(held, MEASURED)
    return pa.Table.from_pydict(
        {
            "machine": [table.column("machine")[0].as_py()],
            "points": [fit.num_rows],
            "rms_before": [d["rms_before"]],
            "rms_after": [d["rms_after"]],
            "held_out_rms": [float(np.sqrt(np.mean(np.sum(dd * dd, axis=1))))],
            "rank": [d["rank"]],
            "parameter": [[e["name"] for e in d["estimates"]]],
            "value": [[e["value"] for e in d["estimates"]]],
            "warnings": [[w if isinstance(w, str) else json.dumps(w) for w in d["warnings"]]],
        },
        schema=RESULT_SCHEMA,
    )


def run_spark(inp: str, out: str, cores: int, cluster: bool = False) -> float:
    from pyspark.sql import SparkSession

    builder = SparkSession.builder
    if not cluster:
        # Local workers run this Python (the one with mtwin installed).
        os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
        builder = builder.master(f"local[{cores}]")
    spark = (
        builder.appName("mtwin-fleet")
        .config("spark.sql.shuffle.partitions", str(2 * cores))
        .config("spark.ui.enabled", "false")
        .getOrCreate()
    )
    try:
        # The workers import this module when identify_one comes from an import.
        spark.sparkContext.addPyFile(os.path.abspath(__file__))
        t0 = time.perf_counter()
        df = spark.read.parquet(inp)
        res = df.groupBy("machine").applyInArrow(identify_one, schema=_ddl())
        res.write.mode("overwrite").parquet(out)
        return time.perf_counter() - t0
    finally:
        spark.stop()


def _ddl() -> str:
    return (
        "machine string, points long, rms_before double, rms_after double, "
        "held_out_rms double, rank long, parameter array<string>, value array<double>, "
        "warnings array<string>"
    )


def run_one_by_one(inp: str) -> pa.Table:
    t = pq.read_table(inp)
    machines = sorted(set(t.column("machine").to_pylist()))
    import pyarrow.compute as pc

    parts = [identify_one(t.filter(pc.equal(t.column("machine"), m))) for m in machines]
    return pa.concat_tables(parts)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--machines", type=int, default=500)
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--work", default="fleet-work")
    ap.add_argument("--cluster", action="store_true",
                    help="use the master spark-submit gives (a cluster), not local[cores]")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    inp = os.path.join(a.work, "measurements.parquet")
    out = os.path.join(a.work, "identified.parquet")
    simulate(a.machines, inp)
    wall = run_spark(inp, out, a.cores, a.cluster)
    spark_result = pq.read_table(out).sort_by("machine")
    t0 = time.perf_counter()
    local = run_one_by_one(inp).sort_by("machine")
    local_wall = time.perf_counter() - t0
    same = spark_result.select(local.schema.names).equals(local)
    print(f"spark local[{a.cores}]: {a.machines} machines in {wall:.1f} s; one by one: {local_wall:.1f} s; identical: {same}")
    if not same:
        raise SystemExit("Spark and one-by-one results differ")


if __name__ == "__main__":
    main()
