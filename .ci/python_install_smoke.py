"""Smoke test of `pip install .` (run by .ci/run in a fresh virtual environment,
outside the repository so that `import mtwin` finds the installed package, not
the source folder).

Checks the installed package against closed forms of the nominal example
machine `ac-trunnion` (docs/machine-model.md): the tool tip is at the origin
of M at the zero pose, the workpiece origin at (0, 0, -150) mm in M, the
rotary axes A (about +x) and C (about +z) pass through the origin of M, so
the tool pose in the workpiece frame W is

    tip_W = (0, 0, 150) + Rz(-C)·Rx(-A)·(X, Y, Z),  axis_W = Rz(-C)·Rx(-A)·(0, 0, 1).
"""

import sys

import numpy as np

import mtwin


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


m = mtwin.Machine.example("ac-trunnion")
assert m.axis_names == ["Y", "X", "Z", "A", "C"], m.axis_names

home = m.predict(np.zeros((1, 5)))
assert np.array_equal(home, np.array([[0.0, 0.0, 150.0, 0.0, 0.0, 1.0]])), home

rng = np.random.default_rng(7)
t = m.travels
q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((1000, 5))
p = m.predict(q)
for (y, x, z, a, c), row in zip(q, p):
    r = rz(-np.radians(c)) @ rx(-np.radians(a))
    tip = np.array([0.0, 0.0, 150.0]) + r @ np.array([x, y, z])
    axis = r @ np.array([0.0, 0.0, 1.0])
    assert np.allclose(row[:3], tip, rtol=0, atol=1e-9), (row, tip)
    assert np.allclose(row[3:], axis, rtol=0, atol=1e-12), (row, axis)

print(f"mtwin installed from {mtwin.__file__} (Python {sys.version.split()[0]}): "
      f"home pose and 1000 random poses of ac-trunnion equal the closed form")
