"""mtwin — exact, fast machine-tool accuracy, from Python.

The machine model (``Machine``), forward and inverse kinematics and Jacobians on
NumPy arrays, and the measurement methods of the ``mtwin`` command-line tool.
Units everywhere: mm, degrees for rotary axis positions, rad for angular errors,
s, rev/min. Results are ``Document`` objects (the CLI's ``--format json``
documents, with attributes); a problem with an input raises ``InputError``
carrying ``file``, ``line`` and ``column``. See docs/python.md.
"""

from ._errors import InputError
from ._document import Document
from ._mtwin import (
    TWIN_COLUMNS,
    Machine,
    __version__,
    ballbar_circular,
    ballbar_identify,
    ballbar_setup_error,
    compensate,
    example_names,
    gcode_interpolate,
    gcode_stats,
    positioning_evaluate,
    servo_fit,
    skiving_setup_error,
    thermal_fit,
    thermal_fit_log,
    thermal_predict,
    thermal_predict_log,
    tracker_identify,
    tracker_validate,
    twin_predict,
)

__all__ = [
    "Document",
    "InputError",
    "Machine",
    "TWIN_COLUMNS",
    "__version__",
    "ballbar_circular",
    "ballbar_identify",
    "ballbar_setup_error",
    "compensate",
    "example_names",
    "gcode_interpolate",
    "gcode_stats",
    "positioning_evaluate",
    "servo_fit",
    "skiving_setup_error",
    "thermal_fit",
    "thermal_fit_log",
    "thermal_predict",
    "thermal_predict_log",
    "tracker_identify",
    "tracker_validate",
    "twin_predict",
]
