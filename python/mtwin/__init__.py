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
    Machine,
    __version__,
    ballbar_setup_error,
    example_names,
    gcode_stats,
    thermal_fit,
    thermal_predict,
    tracker_identify,
    tracker_validate,
)

__all__ = [
    "Document",
    "InputError",
    "Machine",
    "__version__",
    "ballbar_setup_error",
    "example_names",
    "gcode_stats",
    "thermal_fit",
    "thermal_predict",
    "tracker_identify",
    "tracker_validate",
]
