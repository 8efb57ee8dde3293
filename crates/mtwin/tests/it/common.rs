//! Machines shared by the planner test modules.

use mtwin::model::{AxisKind, Machine};

/// The example AC trunnion with the limits of LinuxCNC's xyzac-trt
/// simulation configuration: X Y Z 20 mm/s, A C 30 deg/s, 300 mm/s² (deg/s²)
/// on every axis, trajectory (rapid) 35 mm/s.
pub fn linuxcnc_trunnion() -> Machine {
    let mut m = mtwin::examples::machine("ac-trunnion").unwrap();
    for a in m.axes.iter_mut() {
        let lin = a.kind == AxisKind::Linear;
        a.max_velocity = Some(if lin { 20.0 } else { 30.0 });
        a.max_acceleration = Some(300.0);
    }
    m.rapid_feed = 35.0 * 60.0;
    m
}
