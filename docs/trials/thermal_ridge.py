"""Trial recorded in docs/thermal.md ("Regularisation instead of selection"):
ridge-penalised ARX(1) models of the five drift channels of the shared real
record, the penalty chosen by blocked cross-validation on the training span.

Not part of mtwin. Run from the repository root with NumPy installed:

    python3 docs/trials/thermal_ridge.py

It reads ../shared/data/real/fl-thermal-first60.csv, averages it to 1-min
periods, takes the sixteen temperatures as rises since the first row (and,
in the second variant, the speed / 5000 rev/min and its square), fits on the
first 1 110 min and predicts the rest from the start with the inputs alone.
The cross-validation cuts the training span into four blocks; each of the
last three is predicted from the start by a model fitted on the blocks
before it, and the errors are pooled (the layout of `thermal fit --log`).
"""
import csv
import pathlib

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
CSV = HERE.parents[1] / ".." / "shared" / "data" / "real" / "fl-thermal-first60.csv"
N_TRAIN = 1110
PENALTIES = [10.0 ** e for e in np.arange(-4, 4.01, 0.5)]


def periods():
    with open(CSV) as f:
        rows = np.array([[float(x) for x in r] for r in list(csv.reader(f))[1:]])
    minute = (rows[:, 0] / 60.0 // 1).astype(int)
    n = int(rows[-1, 0] / 60.0 // 1)
    return np.array([rows[minute == k].mean(axis=0) for k in range(n)])


def fit(x, y, penalty, end):
    """y(k) = a y(k-1) + x(k) b + x(k-1) c on samples 1..end, ridge on b, c."""
    k = np.arange(1, end)
    z = np.hstack([y[k - 1, None], x[k], x[k - 1]])
    p = penalty * np.eye(z.shape[1])
    p[0, 0] = 0.0
    return np.linalg.solve(z.T @ z + p, z.T @ y[k])


def simulate(theta, x):
    n_in = x.shape[1]
    a, b, c = theta[0], theta[1 : 1 + n_in], theta[1 + n_in :]
    out = np.zeros(len(x))
    out[0] = x[0] @ b
    for k in range(1, len(x)):
        out[k] = a * out[k - 1] + x[k] @ b + x[k - 1] @ c
    return out


def cross_validation_rms(x, y, penalty):
    edges = np.linspace(0, N_TRAIN, 5).astype(int)
    errors = []
    for f in range(1, 4):
        p = simulate(fit(x, y, penalty, edges[f]), x)
        errors.append(y[edges[f] : edges[f + 1]] - p[edges[f] : edges[f + 1]])
    e = np.concatenate(errors)
    return float(np.sqrt(np.mean(e * e)))


def main():
    m = periods()
    speed = m[:, 1:2] / 5000.0
    drift = m[:, 2:7]
    rises = m[:, 7:23] - m[0, 7:23]
    for name, x in [
        ("ridge on the sixteen rises", rises),
        ("ridge on speed, speed² and the rises", np.hstack([rises, speed, speed**2])),
    ]:
        cv, mae = [], []
        for ch in range(5):
            y = drift[:, ch]
            best = min(PENALTIES, key=lambda p: cross_validation_rms(x, y, p))
            cv.append(cross_validation_rms(x, y, best))
            pred = simulate(fit(x, y, best, N_TRAIN), x)
            mae.append(float(np.mean(np.abs(y[N_TRAIN:] - pred[N_TRAIN:]))))
        print(f"| {name}, cross-validation RMS | " + " | ".join(f"{v:.3f}" for v in cv) + " |")
        print(f"| {name}, test MAE | " + " | ".join(f"{v:.3f}" for v in mae) + " |")


if __name__ == "__main__":
    main()
