//! Live thermal compensation on LinuxCNC: a thermal drift model (`mtwin
//! thermal fit`) written as a userspace HAL component in Python that drives
//! the Z external offset (`axis.z.eoffset-*`).
//!
//! `halcompile` (realtime components) is not part of Debian's
//! `linuxcnc-uspace`, but its Python module `hal` is: the component
//! (`mtwin_thermal.py`, the model's coefficients built in) runs beside the
//! servo thread. Every poll it reads its input pins (`in.<column>`: the
//! spindle speed and any other model input), holds each value until the next
//! poll and averages it over every model period `[kT, (k+1)T)` from its
//! start; at the end of a period it steps the ARX model of every measured
//! height once with the means, exactly as [`ThermalPredictor::advance`]
//! does, and holds the drift `e(kT)` (interpolated at the tool height) over
//! the next period. The Z correction is `−e`, sent as
//! `axis.z.eoffset-counts` with `axis.z.eoffset-scale` =
//! [`RESOLUTION_MM`]. Its clock is the servo thread's time ([`CLOCK_NAME`],
//! an `integ` of 1 on the servo thread, which `thermal.hal` loads): a
//! period is a fixed number of servo periods, the wall clock on a realtime
//! machine and the motion time in the simulator. `thermal.hal` loads and connects it;
//! `thermal-README.txt` lists the ini lines (`[AXIS_Z] OFFSET_AV_RATIO`).
//!
//! [`ThermalPredictor::advance`]: crate::methods::thermal::ThermalPredictor::advance

use super::ExportError;
use crate::methods::thermal::ThermalModel;

/// The Z offset resolution, mm per count of `axis.z.eoffset-counts`
/// (`axis.z.eoffset-scale`): 1 nm.
pub const RESOLUTION_MM: f64 = 1e-6;

/// File name of the component.
pub const COMPONENT_FILE: &str = "mtwin_thermal.py";
/// File name of the HAL file that loads and connects it.
pub const HAL_FILE: &str = "thermal.hal";
/// File name of the instructions.
pub const README_FILE: &str = "thermal-README.txt";
/// HAL name of the component.
pub const COMPONENT_NAME: &str = "mtwin-thermal";
/// HAL name of the model's clock (LinuxCNC's `integ` of 1 on the servo
/// thread: seconds of servo time) and of its signal.
pub const CLOCK_NAME: &str = "mtwin-thermal-clock";

/// The component's source with `@MODEL@` and `@RESOLUTION@` to fill in.
const TEMPLATE: &str = include_str!("mtwin_thermal.py");

/// The model's input column names become HAL pin names (`in.<column>`):
/// letters, digits, `_`, `-` and `.` only, at most 40 characters (HAL names
/// are limited to 47 with the component's prefix).
fn check_column(name: &str) -> Result<(), ExportError> {
    let ok = !name.is_empty()
        && name.len() <= 40
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
    if ok {
        Ok(())
    } else {
        Err(ExportError::Unsupported {
            format: "linuxcnc",
            reason: format!(
                "the thermal model's input `{name}` cannot name a HAL pin (letters, digits, `_`, `-`, `.`, at most 40 characters)"
            ),
        })
    }
}

/// The model as the JSON document the component reads (`columns`, `inputs`
/// with their column index, `heights` with `a`, `b`, `nk`), numbers in full.
pub fn model_json(model: &ThermalModel) -> serde_json::Value {
    let columns = model.columns();
    let inputs: Vec<serde_json::Value> = model
        .inputs()
        .iter()
        .map(|c| {
            let column = columns.iter().position(|n| *n == c.name).unwrap_or(0);
            serde_json::json!({
                "name": c.name, "column": column, "scale": c.scale, "power": c.power,
            })
        })
        .collect();
    let heights: Vec<serde_json::Value> = model
        .heights()
        .iter()
        .map(|h| {
            let m = &h.model;
            let b: Vec<&[f64]> = (0..m.n_inputs()).map(|i| m.b(i)).collect();
            let nk: Vec<usize> = (0..m.n_inputs()).map(|i| m.nk(i)).collect();
            serde_json::json!({ "z_mm": h.z_mm, "a": m.a(), "b": b, "nk": nk })
        })
        .collect();
    serde_json::json!({
        "period_min": model.period_min(),
        "columns": columns,
        "inputs": inputs,
        "heights": heights,
    })
}

/// The HAL lines of `thermal.hal`.
fn hal_text(model: &ThermalModel) -> String {
    let mut s = String::new();
    s += "# mtwin live thermal compensation: loads mtwin_thermal.py (beside this file)\n";
    s += "# and drives the Z external offset with it. Source it after the machine's own\n";
    s += "# HAL files ([HAL] HALFILE = thermal.hal) and see thermal-README.txt.\n";
    s += &format!("loadusr -Wn {COMPONENT_NAME} /usr/bin/python3 {COMPONENT_FILE} --clock-pin\n");
    s += "# The model's clock: the servo thread's time (an integ of 1, s), the wall\n";
    s += "# clock on a realtime machine. A configuration that loads integ already:\n";
    s += &format!("# add {CLOCK_NAME} to its names= list and delete the loadrt line below.\n");
    s += &format!("loadrt integ names={CLOCK_NAME}\n");
    s += &format!("addf {CLOCK_NAME} servo-thread\n");
    s += &format!("setp {CLOCK_NAME}.in 1\n");
    s += &format!("net {CLOCK_NAME} {CLOCK_NAME}.out => {COMPONENT_NAME}.clock-s\n");
    for col in model.columns() {
        if col == "speed_rpm" {
            s += "# The commanded spindle speed; connect the measured one instead where the\n";
            s += "# machine has it.\n";
            s += &format!(
                "net mtwin-thermal-speed spindle.0.speed-out-abs => {COMPONENT_NAME}.in.{col}\n"
            );
        } else {
            s += &format!(
                "# Connect the sensor of `{col}` (units of the training data):\n# net mtwin-thermal-{col} <sensor pin> => {COMPONENT_NAME}.in.{col}\n"
            );
        }
    }
    s += &format!(
        "setp axis.z.eoffset-scale {}\n",
        crate::io::fmt_f64(RESOLUTION_MM)
    );
    s += &format!("net mtwin-thermal-counts {COMPONENT_NAME}.counts => axis.z.eoffset-counts\n");
    s += "setp axis.z.eoffset-enable 1\n";
    s
}

/// The instructions (`thermal-README.txt`).
fn readme(model: &ThermalModel) -> String {
    let heights: Vec<String> = model
        .heights()
        .iter()
        .map(|h| crate::io::fmt_f64(h.z_mm))
        .collect();
    let pins: Vec<String> = model
        .columns()
        .iter()
        .map(|c| format!("{COMPONENT_NAME}.in.{c}"))
        .collect();
    format!(
        "mtwin live thermal compensation for LinuxCNC 2.9

Files:
  {COMPONENT_FILE}   userspace HAL component (Python 3, LinuxCNC's `hal` module),
                     the thermal model built in
  {HAL_FILE}         loads it and connects it to the Z external offset

Add to the ini file:

[HAL]
HALFILE = {HAL_FILE}

[AXIS_Z]
OFFSET_AV_RATIO = 0.1

OFFSET_AV_RATIO (0 to 0.9) is the share of the Z axis' velocity and
acceleration given to the external offset; planned motion keeps the rest.

The model: period {period} min, inputs {inputs}, heights {heights} mm.
Input pins: {pins}. Every model period the component steps the model with
the period means of its inputs and holds the drift at the tool height
(axis.z.pos-cmd) until the next period; the Z correction is minus the drift,
sent as axis.z.eoffset-counts with axis.z.eoffset-scale {res} mm. The
model's clock is the servo thread's time ({clock}: LinuxCNC's integ of 1 on
servo-thread, loaded by {HAL_FILE}; if the configuration loads integ
already, add {clock} to its names= list and delete that loadrt line).
Time 0 of the model is the start of LinuxCNC: start it with the machine
cold. LinuxCNC applies changes of the counts only while the machine is on
and every joint is homed: the counts are 0 while the machine is off and
hold their value while a joint is not homed, so the whole correction is
applied once it is on and homed. Output pins: drift-mm, offset-mm, counts,
sample, time-s, z-mm.
",
        clock = CLOCK_NAME,
        period = crate::io::fmt_f64(model.period_min()),
        inputs = model.columns().join(", "),
        heights = heights.join(", "),
        pins = pins.join(", "),
        res = crate::io::fmt_f64(RESOLUTION_MM),
    )
}

/// The files of the live thermal compensation: (name, contents) of
/// [`COMPONENT_FILE`], [`HAL_FILE`] and [`README_FILE`].
///
/// # Errors
/// An input column name that cannot name a HAL pin.
pub fn export(model: &ThermalModel) -> Result<Vec<(String, String)>, ExportError> {
    for c in model.columns() {
        check_column(c)?;
    }
    let json = serde_json::to_string(&model_json(model)).expect("finite numbers serialise");
    let component = TEMPLATE
        .replace("@MODEL@", &json)
        .replace("@RESOLUTION@", &crate::io::fmt_f64(RESOLUTION_MM));
    Ok(vec![
        (COMPONENT_FILE.to_string(), component),
        (HAL_FILE.to_string(), hal_text(model)),
        (README_FILE.to_string(), readme(model)),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::thermal::{HeightModel, InputChannel, ThermalModel};
    use crate::sysid::Arx;

    fn model() -> ThermalModel {
        let h = |z: f64, b0: f64| HeightModel {
            z_mm: z,
            model: Arx::new(
                vec![1.0, -1.605827, 0.627089],
                vec![(vec![b0, 0.0057508], 1), (vec![0.001], 2)],
            )
            .unwrap(),
            stats: None,
        };
        ThermalModel::new(
            10.0,
            vec![
                InputChannel::linear("speed_rpm", 8000.0),
                InputChannel {
                    name: "speed_rpm".into(),
                    scale: 8000.0,
                    power: 2,
                },
            ],
            vec![h(-50.0, -0.0070963), h(-350.0, -0.0062836)],
        )
        .unwrap()
    }

    #[test]
    fn the_component_carries_the_model_coefficients_exactly() {
        let m = model();
        let files = export(&m).unwrap();
        let names: Vec<&str> = files.iter().map(|f| f.0.as_str()).collect();
        assert_eq!(names, [COMPONENT_FILE, HAL_FILE, README_FILE]);
        let py = &files[0].1;
        assert!(!py.contains("@MODEL@") && !py.contains("@RESOLUTION@"));
        // The JSON between the markers reads back to the same numbers.
        let start = py.find("r\"\"\"").unwrap() + 4;
        let end = start + py[start..].find("\"\"\"").unwrap();
        let v: serde_json::Value = serde_json::from_str(&py[start..end]).unwrap();
        assert_eq!(v["period_min"], 10.0);
        assert_eq!(v["columns"], serde_json::json!(["speed_rpm"]));
        assert_eq!(v["inputs"][1]["power"], 2);
        assert_eq!(v["inputs"][1]["column"], 0);
        // Heights ascending, as the model holds them.
        assert_eq!(v["heights"][0]["z_mm"], -350.0);
        assert_eq!(v["heights"][0]["b"][0][0], -0.0062836);
        assert_eq!(v["heights"][1]["a"][1], -1.605827);
        assert_eq!(v["heights"][1]["nk"], serde_json::json!([1, 2]));
        assert!(py.contains("RESOLUTION_MM = 1e-6\n"));
        let hal = &files[1].1;
        assert!(hal.contains(
            "net mtwin-thermal-speed spindle.0.speed-out-abs => mtwin-thermal.in.speed_rpm\n"
        ));
        assert!(hal.contains("setp axis.z.eoffset-scale 1e-6\n"));
        // The clock: an integ of 1 on the servo thread into clock-s, read
        // with --clock-pin.
        assert!(hal.contains("/usr/bin/python3 mtwin_thermal.py --clock-pin\n"));
        for line in [
            "loadrt integ names=mtwin-thermal-clock\n",
            "addf mtwin-thermal-clock servo-thread\n",
            "setp mtwin-thermal-clock.in 1\n",
            "net mtwin-thermal-clock mtwin-thermal-clock.out => mtwin-thermal.clock-s\n",
        ] {
            assert!(hal.contains(line), "{line}");
        }
        assert!(files[2].1.contains("HALFILE = thermal.hal\n"));
        assert!(
            hal.contains(
                "net mtwin-thermal-counts mtwin-thermal.counts => axis.z.eoffset-counts\n"
            )
        );
        assert!(files[2].1.contains("OFFSET_AV_RATIO = 0.1"));
    }

    #[test]
    fn a_column_that_cannot_name_a_pin_is_refused() {
        let h = HeightModel {
            z_mm: 0.0,
            model: Arx::new(vec![1.0, -0.5], vec![(vec![0.1], 1)]).unwrap(),
            stats: None,
        };
        let m = ThermalModel::new(10.0, vec![InputChannel::linear("t ambient", 20.0)], vec![h])
            .unwrap();
        let e = export(&m).unwrap_err().to_string();
        assert!(e.contains("`t ambient` cannot name a HAL pin"), "{e}");
    }
}
