"""Thermal drift of a fleet on Spark: per-machine probing logs (the training
run and a held-out check run of every machine) in one Parquet table, grouped
by machine, each machine's drift model fitted with `mtwin.thermal_fit` and
checked with `mtwin.thermal_predict` on its held-out run inside
`applyInArrow`, written as a Parquet table (orders, fit and held-out RMS,
stability, warnings and the model file text per machine); then the same
machines one by one in this process, and the two results compared.

    pip install pyspark "pandas<3"  # Java 17 on the machine
    python python/examples/spark_thermal_fleet.py --machines 500 --cores 2 --work thermal-work
    python python/examples/spark_thermal_fleet.py --machines 500 --cores 1,2   # timed on 1, then 2 cores

On a cluster the same script runs unchanged with `spark-submit --master
<cluster URL> spark_thermal_fleet.py --cluster --work <shared storage>` when
`mtwin` is installed in the executors' Python environment.

The logs are simulated here with a known model per machine (docs/thermal.md:
drift in +Z at two heights, a two-time-constant ARX model driven by the
spindle speed / 8000 rpm, one period's delay, probing every 10 min, 0.5 µm
probing noise), so that the held-out error can be read against the noise.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

import mtwin

PERIOD = 10.0  # min
HEIGHTS = [-350.0, -50.0]  # mm
SCALE = 8000.0  # rpm
NOISE = 0.0005  # mm
MAX_ORDER = 2
# The held-out run: the same speed programme for every machine (`speed.csv` of
# docs/thermal.md, section 3, extended to 4 hours).
CHECK_SPEEDS = [7500.0] * 6 + [2500.0] * 6 + [0.0] * 4 + [6000.0] * 8


def _truth(rng: np.random.Generator):
    """One machine's drift model per height: time constants 20–30 min (spindle)
    and 120–180 min (column), steady-state drift at full speed of -20 to -30 µm
    (low ball) and -28 to -42 µm (high ball), the zero of B at 0.90–0.94."""
    p1 = np.exp(-PERIOD / rng.uniform(20.0, 30.0))
    p2 = np.exp(-PERIOD / rng.uniform(120.0, 180.0))
    a = np.array([1.0, -(p1 + p2), p1 * p2])
    zero = rng.uniform(0.90, 0.94)
    models = []
    for gain in (rng.uniform(-0.030, -0.020), rng.uniform(-0.042, -0.028)):
        # B(q) = b0 (1 - zero q^-1), scaled so that B(1)/A(1) = gain.
        b0 = gain * a.sum() / (1.0 - zero)
        models.append((a, np.array([b0, -b0 * zero])))
    return models


def _simulate(models, speeds):
    """Drift (mm) at each probing time t_k = k·PERIOD from cold, speeds[k] held
    over [t_k, t_k + PERIOD): e_k + a1 e_{k-1} + a2 e_{k-2} = b0 u_{k-1} + b1 u_{k-2}."""
    u = np.asarray(speeds) / SCALE
    out = []
    for a, b in models:
        e = np.zeros(len(u))
        for k in range(1, len(u)):
            acc = b[0] * u[k - 1] - a[1] * e[k - 1]
            if k >= 2:
                acc += b[1] * u[k - 2] - a[2] * e[k - 2]
            e[k] = acc
        out.append(e)
    return out


def simulate(n_machines: int, path: str) -> None:
    """Per machine: a 6-hour training run (speed steps of 20–40 min from
    0–8000 rpm, its own sequence) and the held-out check run, both probed at
    the two heights with noise; one Parquet table of rows `machine, part,
    t_min, speed_rpm, z_mm, drift_mm` (`part` is `train` or `check`)."""
    cols = {n: [] for n in ["machine", "part", "t_min", "speed_rpm", "z_mm", "drift_mm"]}
    for k in range(n_machines):
        rng = np.random.default_rng(5000 + k)
        models = _truth(rng)
        train = []
        while len(train) < 36:
            train += [float(rng.choice([0, 1000, 2000, 4000, 6000, 8000]))] * int(rng.integers(2, 5))
        train = train[:36]
        for part, speeds in (("train", train), ("check", CHECK_SPEEDS)):
            drift = _simulate(models, speeds)
            for z, e in zip(HEIGHTS, drift):
                measured = e + rng.normal(0.0, NOISE, len(e))
                measured[0] = 0.0  # the cold pass: the reference of the later ones
                for i, (n, d) in enumerate(zip(speeds, measured)):
                    cols["machine"].append(f"m{k:04d}")
                    cols["part"].append(part)
                    cols["t_min"].append(i * PERIOD)
                    cols["speed_rpm"].append(n)
                    cols["z_mm"].append(z)
                    cols["drift_mm"].append(float(d))
    pq.write_table(pa.table(cols), path)


RESULT_SCHEMA = pa.schema(
    [
        ("machine", pa.string()),
        ("samples", pa.int64()),
        ("z_mm", pa.list_(pa.float64())),
        ("orders", pa.list_(pa.string())),
        ("simulation_rms_mm", pa.list_(pa.float64())),
        ("stable", pa.bool_()),
        ("held_out_rms_mm", pa.float64()),
        ("warnings", pa.list_(pa.string())),
        ("model_toml", pa.string()),
    ]
)

DDL = (
    "machine string, samples long, z_mm array<double>, orders array<string>, "
    "simulation_rms_mm array<double>, stable boolean, held_out_rms_mm double, "
    "warnings array<string>, model_toml string"
)


def _write_csv(path: str, header, columns) -> None:
    # repr: the shortest text that reads back to the same float64.
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in zip(*columns):
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def fit_one(table: pa.Table) -> pa.Table:
    """One machine's rows → one result row: `thermal_fit` on the training run,
    `thermal_predict` of the check run's speed programme at the probed heights,
    the RMS difference from the check run's probed drift (mm)."""
    machine = table.column("machine")[0].as_py()
    train = table.filter(pc.equal(table.column("part"), "train")).sort_by([("z_mm", "ascending"), ("t_min", "ascending")])
    check = table.filter(pc.equal(table.column("part"), "check")).sort_by([("z_mm", "ascending"), ("t_min", "ascending")])
    col = lambda t, n: t.column(n).to_numpy()
    with tempfile.TemporaryDirectory(prefix="mtwin-thermal-") as d:
        data = os.path.join(d, "train.csv")
        _write_csv(data, ["t_min", "speed_rpm", "z_mm", "drift_mm"],
                   [col(train, n) for n in ("t_min", "speed_rpm", "z_mm", "drift_mm")])
        model_toml, doc = mtwin.thermal_fit(data, max_order=MAX_ORDER)
        model = os.path.join(d, "thermal.toml")
        with open(model, "w") as f:
            f.write(model_toml)
        # The check run's programme: one row per probing time.
        t, first = np.unique(col(check, "t_min"), return_index=True)
        speed = os.path.join(d, "speed.csv")
        _write_csv(speed, ["t_min", "speed_rpm"], [t, col(check, "speed_rpm")[first]])
        heights = sorted(set(col(check, "z_mm").tolist()))
        rows, _ = mtwin.thermal_predict(model, speed, heights)
    predicted = {(r[0], r[1]): r[2] for r in rows}
    diff = np.array([predicted[(tm, z)] - e for tm, z, e in
                     zip(col(check, "t_min"), col(check, "z_mm"), col(check, "drift_mm"))])
    d = doc.to_dict()
    hs = d["heights"]
    return pa.Table.from_pydict(
        {
            "machine": [machine],
            "samples": [train.num_rows],
            "z_mm": [[h["z_mm"] for h in hs]],
            # k (a coefficients after a_0) and m (b coefficients minus one) of docs/thermal.md
            "orders": [[f"k={h['orders']['na']},m={h['orders']['nb'][0]}" for h in hs]],
            "simulation_rms_mm": [[h["simulation_rms_mm"] for h in hs]],
            "stable": [all(h["stable"] for h in hs)],
            "held_out_rms_mm": [float(np.sqrt(np.mean(diff * diff)))],
            "warnings": [[str(w) for w in d["warnings"]]],
            "model_toml": [model_toml],
        },
        schema=RESULT_SCHEMA,
    )


def run_spark(inp: str, out: str, cores: int, cluster: bool = False) -> float:
    """The Spark job (local[cores], or the master spark-submit gives): read
    Parquet → groupBy(machine).applyInArrow(fit_one) → write Parquet. Returns
    the job's wall time (s), session start-up excluded."""
    from pyspark.sql import SparkSession

    builder = SparkSession.builder
    if not cluster:
        # Local workers run this Python (the one with mtwin installed).
        os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
        builder = builder.master(f"local[{cores}]")
    spark = (
        builder.appName("mtwin-thermal-fleet")
        .config("spark.sql.shuffle.partitions", str(2 * cores))
        .config("spark.ui.enabled", "false")
        .getOrCreate()
    )
    try:
        # The workers import this module for fit_one.
        spark.sparkContext.addPyFile(os.path.abspath(__file__))
        t0 = time.perf_counter()
        df = spark.read.parquet(inp)
        df.groupBy("machine").applyInArrow(fit_one, schema=DDL).write.mode("overwrite").parquet(out)
        return time.perf_counter() - t0
    finally:
        spark.stop()


def run_one_by_one(inp: str) -> pa.Table:
    """fit_one on every machine in turn, in this process (the reference)."""
    t = pq.read_table(inp)
    machines = sorted(set(t.column("machine").to_pylist()))
    return pa.concat_tables([fit_one(t.filter(pc.equal(t.column("machine"), m))) for m in machines])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--machines", type=int, default=500)
    ap.add_argument("--cores", default="2",
                    help="local cores (local[N]); several, comma-separated (e.g. 1,2), "
                         "run the job once per count on the same logs")
    ap.add_argument("--work", default="thermal-work")
    ap.add_argument("--cluster", action="store_true",
                    help="use the master spark-submit gives (a cluster), not local[cores]")
    a = ap.parse_args()
    cores = [int(c) for c in a.cores.split(",")]
    os.makedirs(a.work, exist_ok=True)
    inp = os.path.join(a.work, "logs.parquet")
    simulate(a.machines, inp)
    t0 = time.perf_counter()
    local = run_one_by_one(inp).sort_by("machine")
    local_wall = time.perf_counter() - t0
    held = np.array(local.column("held_out_rms_mm").to_pylist()) * 1e3
    print(f"one by one in this process: {a.machines} machines in {local_wall:.1f} s; "
          f"held-out RMS {held.min():.2f}–{held.max():.2f} µm", flush=True)
    for c in cores:
        out = os.path.join(a.work, f"thermal-{c}.parquet")
        wall = run_spark(inp, out, c, a.cluster)
        spark_result = pq.read_table(out).sort_by("machine")
        same = spark_result.select(local.schema.names).equals(local)
        where = "the cluster" if a.cluster else f"local[{c}]"
        print(f"spark {where}: {a.machines} machines in {wall:.1f} s; "
              f"identical to one by one: {same}", flush=True)
        if not same:
            raise SystemExit("Spark and one-by-one results differ")


if __name__ == "__main__":
    main()
