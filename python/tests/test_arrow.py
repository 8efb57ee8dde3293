"""Arrow record batches in and out (mtwin.arrow)."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

import mtwin
import mtwin.arrow


def test_predict_on_a_record_batch_equals_predict_on_the_array():
    m = mtwin.Machine.example("ac-trunnion-with-errors")
    rng = np.random.default_rng(2)
    t = m.travels
    q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((300, m.n_axes))
    # Columns in another order, and one the machine does not have.
    names = list(reversed(m.axis_names))
    cols = {n: q[:, m.axis_names.index(n)] for n in names}
    cols["note"] = np.arange(300.0)
    batch = pa.RecordBatch.from_pydict(cols)
    out = mtwin.arrow.predict(m, batch)
    assert out.schema.names == m.axis_names + ["x", "y", "z", "i", "j", "k"]
    got = np.column_stack([out.column(c).to_numpy() for c in ["x", "y", "z", "i", "j", "k"]])
    assert np.array_equal(got, m.predict(q))
    # A table works as well as a batch.
    out2 = mtwin.arrow.predict(m, pa.Table.from_batches([batch]))
    assert out2.equals(out)
    with pytest.raises(ValueError, match="no column C"):
        mtwin.arrow.predict(m, pa.RecordBatch.from_pydict({n: q[:, 0] for n in m.axis_names[:-1]}))


def test_one_machines_tracker_measurements_in_one_result_row_out():
    nominal = mtwin.Machine.example("afp-gantry")
    truth = mtwin.Machine.example("afp-gantry-with-errors")
    rng = np.random.default_rng(5)
    t = nominal.travels
    q = t[:, 0] + (t[:, 1] - t[:, 0]) * rng.random((80, nominal.n_axes))
    tips = truth.predict(q)[:, :3]
    cols = {n: q[:, a] for a, n in enumerate(nominal.axis_names)}
    cols.update(x=tips[:, 0], y=tips[:, 1], z=tips[:, 2], machine=["m7"] * 80)
    batch = pa.RecordBatch.from_pydict(cols)
    row = mtwin.arrow.tracker_identify_batch(nominal, batch, "location", key="machine")
    assert row.num_rows == 1
    assert row.column("machine")[0].as_py() == "m7"
    _, doc = mtwin.tracker_identify(nominal, np.column_stack([q, tips]), "location")
    assert row.column("doc_json")[0].as_py() == doc.to_json()
    assert row.column("rms_after")[0].as_py() == doc.rms_after
    assert row.column("parameter")[0].as_py() == [e.name for e in doc.estimates]
    # Noise-free measurements of the same kinematics: the fit explains them better
    # than the nominal machine does.
    assert doc.rms_after < doc.rms_before
