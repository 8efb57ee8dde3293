"""Type stubs of the extension module (re-exported by ``mtwin``)."""

from os import PathLike
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._document import Document

_Path = Union[str, "PathLike[str]"]
_F64 = npt.NDArray[np.float64]

__version__: str
TWIN_COLUMNS: List[str]

def example_names() -> List[str]: ...

class Machine:
    @staticmethod
    def from_file(path: _Path) -> "Machine": ...
    @staticmethod
    def from_str(text: str, path: str = "<string>") -> "Machine": ...
    @staticmethod
    def from_dict(data: dict, path: str = "<dict>") -> "Machine": ...
    @staticmethod
    def example(name: str) -> "Machine": ...
    @property
    def path(self) -> str: ...
    @property
    def axis_names(self) -> List[str]: ...
    @property
    def n_axes(self) -> int: ...
    @property
    def travels(self) -> _F64: ...
    def to_toml(self) -> str: ...
    def to_dict(self) -> dict: ...
    def check(self) -> Document: ...
    def predict(self, poses: npt.ArrayLike, check_travel: bool = True) -> _F64: ...
    def predict_nominal(self, poses: npt.ArrayLike, check_travel: bool = True) -> _F64: ...
    def jacobian(self, poses: npt.ArrayLike) -> _F64: ...
    def inverse(
        self,
        targets: npt.ArrayLike,
        start: Optional[npt.ArrayLike] = None,
        free: Optional[Sequence[bool]] = None,
        warm: bool = False,
        check_travel: bool = True,
        on_error: str = "raise",
    ) -> _F64: ...

def tracker_identify(
    machine: Machine, data: Union[_Path, _F64], fit: str, registration: bool = False
) -> Tuple[Machine, Document]: ...
def tracker_validate(machine: Machine, data: Union[_Path, _F64]) -> Document: ...
def thermal_fit(
    data: _Path,
    max_order: int = 4,
    speed_model: str = "linear",
    extra_inputs: Sequence[str] = (),
) -> Tuple[str, Document]: ...
def thermal_predict(model: _Path, speed: _Path, z: Sequence[float]) -> Tuple[_F64, Document]: ...
def thermal_fit_log(
    log: _Path,
    drift: Sequence[str],
    inputs: Sequence[str],
    period_min: float = 1.0,
    train_until_min: Optional[float] = None,
    folds: Union[int, Sequence[int]] = 3,
    max_order: int = 2,
    max_inputs: int = 6,
    ambient: Optional[str] = None,
    lags: bool = False,
    input_rule: str = "pooled",
    search: str = "forward",
    start_offset: bool = False,
    also_plain: bool = False,
) -> Tuple[str, Document]: ...
def thermal_predict_log(model: _Path, log: _Path) -> Tuple[_F64, Document]: ...
def gcode_stats(program: _Path, machine: Optional[Machine] = None, tcp: bool = False) -> Document: ...
def ballbar_setup_error(length: float, lmax: float, lmin: float, theta2: float) -> Document: ...
def ballbar_identify(
    mode1: Optional[_Path] = None,
    mode2: Optional[_Path] = None,
    mode3: Optional[_Path] = None,
    mode4: Optional[_Path] = None,
    machine: Optional[Machine] = None,
    length: float = 100.0,
    zb1c: float = 100.0,
    zb1a: float = 100.0,
    ex: float = 0.0,
    ey: float = 0.0,
) -> Tuple[Machine, Document]: ...
def ballbar_circular(
    radius: float,
    cw: Union[_Path, _F64, None] = None,
    ccw: Union[_Path, _F64, None] = None,
    cyclic_pitch: float = 10.0,
    spike_width: float = 3.0,
    plane: str = "xy",
) -> Document: ...
def skiving_setup_error(
    data: _Path,
    h: float,
    l: float,
    rt: float,
    rg: float,
    noise: Optional[float] = None,
    tolerance: float = ...,
) -> Document: ...
def servo_fit(
    data: _Path, max_order: int = 4, max_delay: int = 3, feed: float = 1000.0
) -> Tuple[str, Document]: ...
def positioning_evaluate(
    data: _Path,
    input_format: str = "auto",
    ref_channel: Optional[str] = None,
    cmd_channel: Optional[str] = None,
    ref_gain: float = 1.0,
    ref_offset: float = 0.0,
    targets: Optional[Sequence[float]] = None,
    dwell_band: float = 0.005,
    min_dwell_samples: int = 3,
    min_dwell_s: float = 0.5,
    reach_tol: float = 0.1,
) -> Document: ...
def gcode_interpolate(
    program: _Path,
    machine: Machine,
    ts: float = 0.001,
    tcp: bool = False,
    offsets: Optional[Dict[str, float]] = None,
    check_travel: bool = True,
    planner: str = "exact-stop",
    feed_override: float = 1.0,
) -> Tuple[_F64, Document]: ...
def twin_predict(
    machine: Machine,
    commands: Optional[_Path] = None,
    gcode: Optional[_Path] = None,
    tcp: bool = False,
    ts: float = 0.001,
    offsets: Optional[Dict[str, float]] = None,
    check_travel: bool = True,
    planner: str = "exact-stop",
    feed_override: float = 1.0,
    only: Optional[str] = None,
    breakdown: bool = False,
) -> Tuple[_F64, Document]: ...
def compensate(
    machine: Machine,
    program: str,
    tol: float = 0.001,
    max_correction: float = 0.5,
    tcp: bool = False,
    offsets: Optional[Dict[str, float]] = None,
    path: str = "<string>",
) -> Tuple[str, Document]: ...
