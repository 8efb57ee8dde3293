use crate::sysid::{Arx, ArxStepper};

use super::ThermalError;
use super::predict::Programme;

/// One input of a thermal model: the CSV column it is read from, the scale it
/// is divided by and the power it is raised to before it enters the ARX model.
///
/// A power above 1 makes the model a Hammerstein model (a static nonlinearity
/// before linear dynamics): `speed_rpm` twice, with powers 1 and 2, models a
/// heat input that grows faster than the speed (bearing friction).
#[derive(Debug, Clone, PartialEq)]
pub struct InputChannel {
    /// Column name in `TRAIN.csv` / `SPEED.csv` (`speed_rpm` for the spindle speed).
    pub name: String,
    /// The model sees `(value / scale)^power` (positive; the unit of the column).
    pub scale: f64,
    /// Power of the scaled value, 1 ..= [`InputChannel::MAX_POWER`] (1: linear).
    pub power: u32,
}

impl InputChannel {
    /// Largest power of an input.
    pub const MAX_POWER: u32 = 3;

    /// A linear input.
    pub fn linear(name: impl Into<String>, scale: f64) -> InputChannel {
        InputChannel {
            name: name.into(),
            scale,
            power: 1,
        }
    }

    /// What the ARX model sees of the raw column value `v`.
    pub fn apply(&self, v: f64) -> f64 {
        (v / self.scale).powi(self.power as i32)
    }
}

/// Statistics of the fit of one height (drift in mm).
#[derive(Debug, Clone, PartialEq)]
pub struct HeightStats {
    /// Regression rows.
    pub samples: usize,
    /// Parameters.
    pub params: usize,
    /// Final prediction error, mm².
    pub fpe: f64,
    /// Akaike's information criterion.
    pub aic: f64,
    /// RMS of the one-step residual, mm.
    pub one_step_rms_mm: f64,
    /// RMS of measured minus simulated drift (every run simulated from cold), mm.
    pub simulation_rms_mm: f64,
    /// Largest pole modulus.
    pub spectral_radius: f64,
    /// Standard uncertainties of `a_1..a_na`.
    pub a_std: Vec<f64>,
    /// Standard uncertainties of `b_0..b_nb`, one array per input.
    pub b_std: Vec<Vec<f64>>,
}

/// The drift model at one measured height.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightModel {
    /// Height, mm.
    pub z_mm: f64,
    /// Drift (mm) from the scaled inputs; every input delay `nk ≥ 1`.
    pub model: Arx,
    /// Fit statistics, when the model was fitted (not needed to predict).
    pub stats: Option<HeightStats>,
}

/// Where a requested height lies relative to the measured ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeightRange {
    /// Between the lowest and highest measured heights (inclusive).
    Inside,
    /// Below the lowest measured height: its drift is held.
    Below,
    /// Above the highest measured height: its drift is held.
    Above,
}

/// A drift value at a height, with whether it had to be extrapolated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drift {
    /// Displacement of the tool relative to the workpiece in +Z, mm.
    pub mm: f64,
    /// [`HeightRange::Inside`] unless the height is outside the measured range
    /// (then the nearest end value is held: a warning for the user).
    pub range: HeightRange,
}

impl Drift {
    /// True when the height is outside the measured range.
    pub fn is_extrapolated(&self) -> bool {
        self.range != HeightRange::Inside
    }
}

/// A thermal drift model: one ARX model per measured height, all on the same
/// sample period and inputs. Heights are sorted ascending and distinct.
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalModel {
    period_min: f64,
    inputs: Vec<InputChannel>,
    /// Distinct input column names, in order of first use.
    columns: Vec<String>,
    /// Column of every input channel (index into `columns`).
    column_of: Vec<usize>,
    heights: Vec<HeightModel>,
}

impl ThermalModel {
    /// A model; checks the period, the scales, distinct heights, that every
    /// height model takes every input, and that every input delay is ≥ 1.
    pub fn new(
        period_min: f64,
        inputs: Vec<InputChannel>,
        mut heights: Vec<HeightModel>,
    ) -> Result<Self, ThermalError> {
        let bad = |m: String| Err(ThermalError::Model(m));
        if !(period_min.is_finite() && period_min > 0.0) {
            return bad(format!(
                "the sample period must be positive, not {period_min} min"
            ));
        }
        if inputs.is_empty() {
            return bad("a thermal model needs at least one input (the spindle speed)".into());
        }
        for c in &inputs {
            if !(c.scale.is_finite() && c.scale > 0.0) {
                return bad(format!(
                    "the scale of input `{}` must be positive, not {}",
                    c.name, c.scale
                ));
            }
            if !(1..=InputChannel::MAX_POWER).contains(&c.power) {
                return bad(format!(
                    "the power of input `{}` must be 1 to {}, not {}",
                    c.name,
                    InputChannel::MAX_POWER,
                    c.power
                ));
            }
        }
        for (i, c) in inputs.iter().enumerate() {
            if inputs[..i]
                .iter()
                .any(|d| d.name == c.name && d.power == c.power)
            {
                return bad(format!(
                    "input `{}` with power {} appears twice",
                    c.name, c.power
                ));
            }
        }
        if heights.is_empty() {
            return bad("a thermal model needs at least one height".into());
        }
        for h in &heights {
            if !h.z_mm.is_finite() {
                return bad("a height is not a finite number".into());
            }
            if h.model.n_inputs() != inputs.len() {
                return bad(format!(
                    "the model at z = {} mm has {} inputs but the thermal model has {}",
                    h.z_mm,
                    h.model.n_inputs(),
                    inputs.len()
                ));
            }
            if !h.model.orders().is_strictly_proper() {
                return bad(format!(
                    "the model at z = {} mm lets an input act without delay (nk = 0); an input given \
                     at t holds over [t, t+T) and acts from t+T on, so nk >= 1",
                    h.z_mm
                ));
            }
        }
        heights.sort_by(|a, b| a.z_mm.total_cmp(&b.z_mm));
        if let Some(w) = heights.windows(2).find(|w| w[0].z_mm == w[1].z_mm) {
            return bad(format!("the height z = {} mm appears twice", w[0].z_mm));
        }
        let mut columns: Vec<String> = Vec::new();
        let mut column_of = Vec::with_capacity(inputs.len());
        for c in &inputs {
            let i = match columns.iter().position(|n| *n == c.name) {
                Some(i) => i,
                None => {
                    columns.push(c.name.clone());
                    columns.len() - 1
                }
            };
            column_of.push(i);
        }
        Ok(ThermalModel {
            period_min,
            inputs,
            columns,
            column_of,
            heights,
        })
    }

    /// The distinct input columns (`speed_rpm` first for models fitted by
    /// mtwin), in the order a [`Programme`] sample gives their values.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// Sample period, min.
    pub fn period_min(&self) -> f64 {
        self.period_min
    }

    /// The inputs, in the order every height model takes them (a column can
    /// feed several inputs, with different powers).
    pub fn inputs(&self) -> &[InputChannel] {
        &self.inputs
    }

    /// The height models, ascending in z.
    pub fn heights(&self) -> &[HeightModel] {
        &self.heights
    }

    /// Interpolate per-height values (in the order of [`ThermalModel::heights`])
    /// at `z_mm`: piecewise linear, the end values held outside the range.
    pub fn interpolate(&self, values: &[f64], z_mm: f64) -> Drift {
        let zs = &self.heights;
        let last = zs.len() - 1;
        if z_mm < zs[0].z_mm {
            return Drift {
                mm: values[0],
                range: HeightRange::Below,
            };
        }
        if z_mm > zs[last].z_mm {
            return Drift {
                mm: values[last],
                range: HeightRange::Above,
            };
        }
        // First index with z > z_mm, in 1..=last+1.
        let i = zs.partition_point(|h| h.z_mm <= z_mm);
        let mm = if i > last {
            values[last]
        } else {
            let (z0, z1) = (zs[i - 1].z_mm, zs[i].z_mm);
            let w = (z_mm - z0) / (z1 - z0);
            values[i - 1] + w * (values[i] - values[i - 1])
        };
        Drift {
            mm,
            range: HeightRange::Inside,
        }
    }

    /// A streaming predictor from cold at `t = 0`.
    pub fn predictor(&self) -> ThermalPredictor<'_> {
        let steppers = self
            .heights
            .iter()
            .map(|h| {
                h.model
                    .advanced()
                    .expect("thermal models are strictly proper")
                    .stepper()
            })
            .collect();
        ThermalPredictor {
            model: self,
            steppers,
            drift: vec![0.0; self.heights.len()],
            sample: 0,
        }
    }

    /// Drift at every measured height at the samples `t = kT`,
    /// `k = 0..=programme.len()` (one more than the programme's samples: the
    /// last one is the drift at the end of the last period).
    pub fn drift_history(&self, programme: &Programme) -> Vec<Vec<f64>> {
        let mut p = self.predictor();
        let mut out = Vec::with_capacity(programme.len() + 1);
        out.push(p.drifts().to_vec());
        for k in 0..programme.len() {
            p.advance(programme.sample(k));
            out.push(p.drifts().to_vec());
        }
        out
    }

    /// The drift at time `t_min ≥ 0` and height `z_mm` for a programme
    /// starting cold at `t = 0`, linear in time between samples. Past the
    /// programme's end its last inputs hold (none: the inputs are zero).
    pub fn drift_at(&self, programme: &Programme, t_min: f64, z_mm: f64) -> Drift {
        let pos = (t_min / self.period_min).max(0.0);
        let k = pos.floor() as usize;
        let frac = pos - k as f64;
        let zero = vec![0.0; self.columns.len()];
        let input = |j: usize| {
            if j < programme.len() {
                programme.sample(j)
            } else if programme.is_empty() {
                &zero[..]
            } else {
                programme.sample(programme.len() - 1)
            }
        };
        let mut p = self.predictor();
        for j in 0..k {
            p.advance(input(j));
        }
        let here = p.drift(z_mm);
        if frac == 0.0 {
            return here;
        }
        p.advance(input(k));
        let next = p.drift(z_mm);
        Drift {
            mm: here.mm + frac * (next.mm - here.mm),
            range: here.range,
        }
    }
}

/// Sample-by-sample drift prediction, for compensation: at sample `k`
/// (time `kT`) it knows the drift at every height; [`ThermalPredictor::advance`]
/// applies the inputs of `[kT, (k+1)T)` and moves to `k + 1`.
#[derive(Debug, Clone)]
pub struct ThermalPredictor<'m> {
    model: &'m ThermalModel,
    /// Steppers of the models advanced by one sample: pushing the inputs of
    /// sample k returns the drift at k + 1.
    steppers: Vec<ArxStepper>,
    drift: Vec<f64>,
    sample: usize,
}

impl ThermalPredictor<'_> {
    /// Current sample index `k`.
    pub fn sample(&self) -> usize {
        self.sample
    }

    /// Current time `kT`, min.
    pub fn time_min(&self) -> f64 {
        self.sample as f64 * self.model.period_min
    }

    /// Drift at the measured heights now (order of [`ThermalModel::heights`]), mm.
    pub fn drifts(&self) -> &[f64] {
        &self.drift
    }

    /// Drift now at height `z_mm` (interpolated across heights).
    pub fn drift(&self, z_mm: f64) -> Drift {
        self.model.interpolate(&self.drift, z_mm)
    }

    /// Apply the raw column values (rev/min for the speed) held over the next
    /// period, in the order of [`ThermalModel::columns`], and move one sample on.
    ///
    /// # Panics
    /// If `values.len()` differs from the model's number of columns.
    pub fn advance(&mut self, values: &[f64]) {
        assert_eq!(
            values.len(),
            self.model.columns.len(),
            "one value per input column is needed"
        );
        let scaled: Vec<f64> = self
            .model
            .inputs
            .iter()
            .zip(&self.model.column_of)
            .map(|(c, &col)| c.apply(values[col]))
            .collect();
        for (d, s) in self.drift.iter_mut().zip(&mut self.steppers) {
            *d = s.push(&scaled);
        }
        self.sample += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_order(z: f64, gain: f64) -> HeightModel {
        // e(k) = 0.8 e(k−1) + gain·0.2·n(k−1)/scale: static gain `gain` per unit scaled speed.
        HeightModel {
            z_mm: z,
            model: Arx::new(vec![1.0, -0.8], vec![(vec![0.2 * gain], 1)]).unwrap(),
            stats: None,
        }
    }

    fn model() -> ThermalModel {
        let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
        ThermalModel::new(
            10.0,
            inputs,
            vec![first_order(-50.0, 0.01), first_order(-150.0, 0.03)],
        )
        .unwrap()
    }

    #[test]
    fn interpolation_is_linear_and_held_outside() {
        let m = model();
        let v = [1.0, 3.0]; // at z = -150 and -50 after sorting: heights sorted ascending
        assert_eq!(m.heights()[0].z_mm, -150.0);
        assert_eq!(
            m.interpolate(&v, -100.0),
            Drift {
                mm: 2.0,
                range: HeightRange::Inside
            }
        );
        assert_eq!(m.interpolate(&v, -150.0).mm, 1.0);
        assert_eq!(
            m.interpolate(&v, -50.0),
            Drift {
                mm: 3.0,
                range: HeightRange::Inside
            }
        );
        assert_eq!(
            m.interpolate(&v, -400.0),
            Drift {
                mm: 1.0,
                range: HeightRange::Below
            }
        );
        assert_eq!(
            m.interpolate(&v, 10.0),
            Drift {
                mm: 3.0,
                range: HeightRange::Above
            }
        );
    }

    #[test]
    fn predictor_starts_cold_and_follows_the_closed_form() {
        // Constant speed 2000 rpm from t = 0: e(k) = g·2·(1 − 0.8^k) at each height.
        let m = model();
        let mut p = m.predictor();
        assert_eq!(p.drifts(), &[0.0, 0.0]);
        for k in 1..=30 {
            p.advance(&[2000.0]);
            let want = 0.03 * 2.0 * (1.0 - 0.8f64.powi(k));
            assert!((p.drifts()[0] - want).abs() < 1e-15);
            assert_eq!(p.sample(), k as usize);
        }
        assert_eq!(p.time_min(), 300.0);
        let prog = Programme::speeds(&[2000.0; 5]);
        let h = m.drift_history(&prog);
        assert_eq!(h.len(), 6);
        let at = m.drift_at(&prog, 25.0, -150.0);
        let e2 = 0.06 * (1.0 - 0.64);
        let e3 = 0.06 * (1.0 - 0.512);
        assert!((at.mm - (e2 + 0.5 * (e3 - e2))).abs() < 1e-15);
        // Past the end the last speed holds.
        let far = m.drift_at(&prog, 100.0, -150.0);
        assert!((far.mm - 0.06 * (1.0 - 0.8f64.powi(10))).abs() < 1e-15);
    }

    #[test]
    fn invariants() {
        let inputs = vec![InputChannel::linear("speed_rpm", 1000.0)];
        let direct = HeightModel {
            z_mm: 0.0,
            model: Arx::new(vec![1.0], vec![(vec![1.0], 0)]).unwrap(),
            stats: None,
        };
        assert!(ThermalModel::new(10.0, inputs.clone(), vec![direct]).is_err());
        assert!(
            ThermalModel::new(
                10.0,
                inputs.clone(),
                vec![first_order(1.0, 1.0), first_order(1.0, 2.0)]
            )
            .is_err()
        );
        assert!(ThermalModel::new(0.0, inputs.clone(), vec![first_order(1.0, 1.0)]).is_err());
        assert!(ThermalModel::new(10.0, inputs, vec![]).is_err());
    }
}
