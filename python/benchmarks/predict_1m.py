"""`Machine.predict` on 1 M poses from Python vs the Rust library.

Run with the wheel installed (built with `--release`, as the Rust side):

    python python/benchmarks/predict_1m.py [--rust PATH_TO_examples/predict_1m]

It times `m.predict(q)` on 1 M random poses of ac-trunnion-with-errors (best of
5 runs) and, with `--rust`, the Rust example `cargo run --release -p mtwin
--example predict_1m`, which times `Kinematics::poses` on the same poses the same
way; it prints both and their ratio.
"""

from __future__ import annotations

import argparse
import subprocess
import time

import numpy as np

import mtwin


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--rust", help="the built Rust example binary to compare with")
    a = ap.parse_args()
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    rng = np.random.default_rng(1)
    t = m.travels
    q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((a.n, m.n_axes))
    m.predict(q[:1000])
    best = float("inf")
    for _ in range(a.runs):
        t0 = time.perf_counter()
        p = m.predict(q)
        best = min(best, time.perf_counter() - t0)
        # Freed after the clock stops, as the Rust side drops its result after its
        # clock stops (freeing 48 MB gives the pages back to the kernel: not the call).
        del p
    print(f"python: predict {a.n} poses: {best * 1e3:.1f} ms (best of {a.runs})")
    if a.rust:
        out = subprocess.run([a.rust, str(a.n), str(a.runs)], capture_output=True, text=True, check=True)
        rust = float(out.stdout.split()[-2]) / 1e3
        print(out.stdout.strip())
        print(f"python / rust = {best / rust:.3f}")


if __name__ == "__main__":
    main()
