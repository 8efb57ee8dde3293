"""Arrow in and out: ``pyarrow`` record batches (or tables) of poses in,
predictions out; one machine's tracker measurements in, one result row out;
the samples of a G-code program and the twin's prediction as record batches.

Needs ``pyarrow`` (``pip install 'mtwin[arrow]'``). Columns are named as in the
CLI's CSV files: one per axis (the machine file's names; mm, degrees), then
``x, y, z`` (mm) and ``i, j, k`` of the tool in W. Float64 columns without nulls
are read without a copy into NumPy and stacked into the (N, axes) array the
kinematics read.
"""

from __future__ import annotations

import json
from typing import Any, Union

import numpy as np

from ._mtwin import TWIN_COLUMNS, Machine, gcode_interpolate, tracker_identify, twin_predict

PREDICT_COLUMNS = ["x", "y", "z", "i", "j", "k"]


def _pa():
    import pyarrow

    return pyarrow


def _matrix(batch: Any, names) -> np.ndarray:
    missing = [n for n in names if n not in batch.schema.names]
    if missing:
        raise ValueError(
            f"the batch has no column {', '.join(missing)} (columns: {', '.join(batch.schema.names)})"
        )
    cols = []
    for n in names:
        c = batch.column(n)
        if c.null_count:
            raise ValueError(f"column {n} has {c.null_count} null(s)")
        cols.append(np.asarray(c.to_numpy(), dtype=np.float64))
    if not cols:
        return np.zeros((batch.num_rows, 0))
    return np.column_stack(cols)


def predict(machine: Machine, batch: Any, check_travel: bool = True) -> Any:
    """Actual tool poses (``Machine.predict``) for a record batch or table with one
    float column per axis: a record batch of the axis columns then ``x, y, z, i, j, k``
    (the columns and numbers of ``mtwin predict``'s CSV)."""
    pa = _pa()
    q = _matrix(batch, machine.axis_names)
    p = machine.predict(q, check_travel=check_travel)
    arrays = [pa.array(q[:, a]) for a in range(q.shape[1])]
    arrays += [pa.array(p[:, c]) for c in range(6)]
    return pa.RecordBatch.from_arrays(arrays, names=machine.axis_names + PREDICT_COLUMNS)


def tracker_identify_batch(
    machine: Machine, batch: Any, fit: str, registration: bool = False, key: Union[str, None] = None
) -> Any:
    """``tracker_identify`` on one machine's measurements (a batch with the axis
    columns and measured ``x, y, z``): a one-row record batch with the number of
    points, the RMS residuals before and after (mm), the rank, the identified
    parameters (``parameter`` names and ``value`` lists, mm and rad) and the warnings;
    the whole ``TrackerIdentifyDoc`` as JSON in ``doc_json``. With
    ``key``, the first value of that column is carried into the result (the group key
    of a grouped job)."""
    pa = _pa()
    names = machine.axis_names + ["x", "y", "z"]
    data = np.ascontiguousarray(_matrix(batch, names))
    _, doc = tracker_identify(machine, data, fit, registration=registration)
    out = {}
    if key is not None:
        out[key] = [batch.column(key)[0].as_py()]
    d = doc.to_dict()
    out["points"] = [int(data.shape[0])]
    out["rms_before"] = [d["rms_before"]]
    out["rms_after"] = [d["rms_after"]]
    out["rank"] = [d["rank"]]
    out["parameter"] = [[e["name"] for e in d["estimates"]]]
    out["value"] = [[e["value"] for e in d["estimates"]]]
    out["warnings"] = [[w if isinstance(w, str) else json.dumps(w) for w in d["warnings"]]]
    out["doc_json"] = [doc.to_json()]
    return pa.RecordBatch.from_pydict(out)


def _batch(table: np.ndarray, names) -> Any:
    pa = _pa()
    return pa.RecordBatch.from_arrays(
        [pa.array(table[:, c]) for c in range(table.shape[1])], names=list(names)
    )


def interpolate(program: Any, machine: Machine, **options: Any) -> Any:
    """``gcode_interpolate`` as a record batch of ``t_s`` and one column per axis
    (the columns and numbers of ``mtwin gcode interpolate``'s CMD.csv); the
    options are those of ``gcode_interpolate``."""
    samples, _ = gcode_interpolate(program, machine, **options)
    return _batch(samples, ["t_s"] + machine.axis_names)


def twin(machine: Machine, **options: Any) -> Any:
    """``twin_predict`` as a record batch of the ``TWIN_COLUMNS`` (the columns and
    numbers of ``mtwin twin predict``'s PRED.csv); the options are those of
    ``twin_predict``."""
    table, _ = twin_predict(machine, **options)
    return _batch(table, TWIN_COLUMNS)
