//! `TRAIN.csv` (contract): long format `t_min,speed_rpm,z_mm,drift_mm`,
//! optional `run` column, one row per time and height; each run starts cold
//! at `t = 0`. `drift_mm` is the tool's displacement relative to the work in
//! +Z (from probing: the cold pass's touched Z minus this pass's);
//! `probe_shift_mm` (touched minus cold, i.e. `−drift`) may replace it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::io::{Diagnostic, Diagnostics, Table};
use crate::sysid::sampling::{check_sampling, median_positive};

/// The drift series of one height in one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Run label (empty without a `run` column).
    pub run: String,
    /// Drift, mm, every period from the run's start.
    pub drift: Vec<f64>,
    /// Raw inputs (`inputs[i][k]`), in the order of [`TrainingData::input_names`].
    pub inputs: Vec<Vec<f64>>,
    /// File line of every sample.
    pub lines: Vec<usize>,
}

/// All series measured at one height.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightData {
    /// Height, mm.
    pub z_mm: f64,
    /// One series per run, in file order.
    pub series: Vec<Series>,
}

impl HeightData {
    /// Samples over all runs.
    pub fn samples(&self) -> usize {
        self.series.iter().map(|s| s.drift.len()).sum()
    }

    /// File line of the first sample of this height.
    pub fn first_line(&self) -> usize {
        self.series
            .iter()
            .filter_map(|s| s.lines.first().copied())
            .min()
            .unwrap_or(0)
    }
}

/// Training data checked and grouped by height and run.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingData {
    /// The file it came from (for messages).
    pub path: PathBuf,
    /// The sample period, min.
    pub period_min: f64,
    /// Input columns: `speed_rpm` first, then the extra inputs asked for.
    pub input_names: Vec<String>,
    /// Heights ascending.
    pub heights: Vec<HeightData>,
    /// Run labels in file order.
    pub runs: Vec<String>,
}

impl TrainingData {
    /// The same data without run `label` (for held-out checks); heights left
    /// without any series are dropped.
    pub fn without_run(&self, label: &str) -> TrainingData {
        let heights = self
            .heights
            .iter()
            .map(|h| HeightData {
                z_mm: h.z_mm,
                series: h
                    .series
                    .iter()
                    .filter(|s| s.run != label)
                    .cloned()
                    .collect(),
            })
            .filter(|h| !h.series.is_empty())
            .collect();
        TrainingData {
            path: self.path.clone(),
            period_min: self.period_min,
            input_names: self.input_names.clone(),
            heights,
            runs: self.runs.iter().filter(|r| *r != label).cloned().collect(),
        }
    }
}

/// Read and check `TRAIN.csv`; `extra_inputs` names further input columns
/// (temperatures, …) that enter the model beside the speed.
pub fn read_training(path: &Path, extra_inputs: &[String]) -> Result<TrainingData, Diagnostics> {
    training_from_table(&Table::read(path)?, extra_inputs)
}

/// Check and group a `TRAIN.csv` table. Reports, each at its line: missing
/// columns, bad numbers, a time that does not increase within a run and
/// height, uneven sampling, and two speeds for the same run and time.
pub fn training_from_table(
    table: &Table,
    extra_inputs: &[String],
) -> Result<TrainingData, Diagnostics> {
    let path = table.path();
    use crate::io::columns::{DRIFT_MM, PROBE_SHIFT_MM, SPEED_RPM, T_MIN, Z_MM};
    // The drift column, or the probe's shift (touched − cold = −drift).
    let shift = table.column(DRIFT_MM).is_none() && table.column(PROBE_SHIFT_MM).is_some();
    if table.column(DRIFT_MM).is_some() && table.column(PROBE_SHIFT_MM).is_some() {
        return Err(Diagnostic::at_line(
            path,
            table.header_line(),
            format!(
                "both `{DRIFT_MM}` and `{PROBE_SHIFT_MM}` are given: keep one (`{DRIFT_MM}` = cold touched Z \
                 minus touched Z; `{PROBE_SHIFT_MM}` = touched Z minus cold, its negative)"
            ),
        )
        .into());
    }
    let drift_col = if shift { PROBE_SHIFT_MM } else { DRIFT_MM };
    let mut names: Vec<&str> = vec![T_MIN, Z_MM, drift_col, SPEED_RPM];
    names.extend(extra_inputs.iter().map(String::as_str));
    let mut values = table.number_rows(&names)?;
    if shift {
        for v in &mut values {
            v[2] = -v[2];
        }
    }
    if values.is_empty() {
        return Err(
            Diagnostic::at_line(path, table.header_line(), "the file has no data rows").into(),
        );
    }
    let run_col = table.column("run");
    let label = |r: usize| run_col.map_or(String::new(), |c| table.text(r, c).to_string());

    // Group rows by (run, height), in file order.
    let mut runs: Vec<String> = Vec::new();
    let mut groups: Vec<(String, f64, Vec<usize>)> = Vec::new();
    let mut index: HashMap<(String, u64), usize> = HashMap::new();
    for (r, v) in values.iter().enumerate() {
        let run = label(r);
        if !runs.contains(&run) {
            runs.push(run.clone());
        }
        let z = v[1] + 0.0; // −0 and +0 are one height
        let g = *index.entry((run.clone(), z.to_bits())).or_insert_with(|| {
            groups.push((run, z, Vec::new()));
            groups.len() - 1
        });
        groups[g].2.push(r);
    }

    let mut diags = Diagnostics::default();
    // Two different speeds at the same run and time.
    let mut seen: HashMap<(String, u64), usize> = HashMap::new();
    for (r, v) in values.iter().enumerate() {
        if let Some(&first) = seen.get(&(label(r), v[0].to_bits())) {
            for (k, name) in names.iter().enumerate().skip(3) {
                if values[first][k] != v[k] {
                    diags.push(table.row_error(
                        r,
                        format!(
                            "`{name}` is {} here but {} on line {} for the same run and time",
                            v[k],
                            values[first][k],
                            table.line(first)
                        ),
                    ));
                }
            }
        } else {
            seen.insert((label(r), v[0].to_bits()), r);
        }
    }

    let times = |rows: &[usize]| rows.iter().map(|&r| values[r][0]).collect::<Vec<f64>>();
    let mut intervals = Vec::new();
    for (_, _, rows) in &groups {
        let t = times(rows);
        intervals.extend(t.windows(2).map(|w| w[1] - w[0]));
    }
    let period = median_positive(intervals);
    let Some(period) = period else {
        diags.push(Diagnostic::whole(
            path,
            "no height has two samples in time order within a run, so the sample period is unknown",
        ));
        return Err(diags);
    };
    for (run, z, rows) in &groups {
        let within = if run.is_empty() {
            format!("z = {z} mm")
        } else {
            format!("run `{run}` at z = {z} mm")
        };
        check_sampling(
            table,
            rows,
            &times(rows),
            period,
            "min",
            &within,
            &mut diags,
        );
        // A run is simulated from cold at t = 0: a first row later than
        // that would lose the interval before it without a word.
        let t0 = values[rows[0]][0];
        if t0.abs() > 0.01 * period {
            diags.push(table.row_error(
                rows[0],
                format!(
                    "{within} starts at t = {} min: each run starts cold at t = 0 (the reference pass, \
                     drift 0); add the t = 0 row or shift the times",
                    crate::limits::fmt_message_number(t0)
                ),
            ));
        }
    }
    if !diags.is_empty() {
        return Err(diags);
    }

    let mut heights: Vec<HeightData> = Vec::new();
    for (run, z, rows) in groups {
        let series = Series {
            run,
            drift: rows.iter().map(|&r| values[r][2]).collect(),
            inputs: (3..names.len())
                .map(|k| rows.iter().map(|&r| values[r][k]).collect())
                .collect(),
            lines: rows.iter().map(|&r| table.line(r)).collect(),
        };
        match heights.iter_mut().find(|h| h.z_mm == z) {
            Some(h) => h.series.push(series),
            None => heights.push(HeightData {
                z_mm: z,
                series: vec![series],
            }),
        }
    }
    heights.sort_by(|a, b| a.z_mm.total_cmp(&b.z_mm));
    Ok(TrainingData {
        path: path.to_path_buf(),
        period_min: period,
        input_names: names[3..].iter().map(|s| s.to_string()).collect(),
        heights,
        runs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<TrainingData, Diagnostics> {
        training_from_table(
            &Table::from_reader(Path::new("TRAIN.csv"), text.as_bytes()).unwrap(),
            &[],
        )
    }

    #[test]
    fn groups_runs_and_heights_in_either_row_order() {
        let by_time = "run,t_min,speed_rpm,z_mm,drift_mm\n\
                       a,0,1000,-50,0\na,0,1000,-150,0\na,10,1000,-50,0.001\na,10,1000,-150,0.002\n\
                       b,0,2000,-50,0\nb,10,2000,-50,0.003\n";
        let d = parse(by_time).unwrap();
        assert_eq!(d.period_min, 10.0);
        assert_eq!(d.runs, vec!["a", "b"]);
        assert_eq!(d.heights.len(), 2);
        assert_eq!(d.heights[0].z_mm, -150.0);
        assert_eq!(d.heights[1].series.len(), 2);
        assert_eq!(d.heights[1].series[1].drift, vec![0.0, 0.003]);
        assert_eq!(d.heights[1].series[1].inputs, vec![vec![2000.0, 2000.0]]);
        assert_eq!(d.heights[1].first_line(), 2);
        let by_height = "t_min,speed_rpm,z_mm,drift_mm\n0,5,-50,0\n10,5,-50,1\n20,5,-50,2\n0,5,-150,0\n10,5,-150,4\n";
        let d = parse(by_height).unwrap();
        assert_eq!(d.heights[1].samples(), 3);
        assert_eq!(d.heights[0].samples(), 2);
    }

    #[test]
    fn bad_files_name_the_line() {
        let not_increasing =
            "t_min,speed_rpm,z_mm,drift_mm\n0,5,-50,0\n10,5,-50,1\n10,5,-50,2\n20,5,-50,2\n";
        let e = parse(not_increasing).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == 4 && d.message.contains("does not increase")),
            "{e}"
        );
        let uneven = "t_min,speed_rpm,z_mm,drift_mm\n0,5,-50,0\n10,5,-50,1\n20,5,-50,2\n35,5,-50,2\n45,5,-50,2\n";
        let e = parse(uneven).unwrap_err();
        assert_eq!(e.0.len(), 1, "{e}");
        assert!(e.0[0].line == 5 && e.0[0].message.contains("uneven"), "{e}");
        assert!(e.to_string().starts_with("TRAIN.csv:5:"), "{e}");
        let two_speeds =
            "t_min,speed_rpm,z_mm,drift_mm\n0,5,-50,0\n0,6,-150,0\n10,5,-50,1\n10,5,-150,1\n";
        let e = parse(two_speeds).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == 3 && d.message.contains("speed_rpm")),
            "{e}"
        );
        let bad_number = "t_min,speed_rpm,z_mm,drift_mm\n0,5,-50,x\n";
        assert_eq!(parse(bad_number).unwrap_err().0[0].column, Some(4));
        let missing = "t_min,speed_rpm,drift_mm\n0,5,0\n";
        assert!(parse(missing).unwrap_err().to_string().contains("`z_mm`"));
    }

    #[test]
    fn probe_shift_is_the_negative_drift_and_runs_start_at_zero() {
        let d = parse("t_min,speed_rpm,z_mm,probe_shift_mm\n0,5,-50,0\n10,5,-50,-0.016\n").unwrap();
        assert_eq!(d.heights[0].series[0].drift, vec![0.0, 0.016]);
        let both = "t_min,speed_rpm,z_mm,drift_mm,probe_shift_mm\n0,5,-50,0,0\n10,5,-50,1,-1\n";
        let e = parse(both).unwrap_err();
        assert!(e.to_string().starts_with("TRAIN.csv:1:"), "{e}");
        let late = "t_min,speed_rpm,z_mm,drift_mm\n10,5,-50,0\n20,5,-50,1\n30,5,-50,2\n";
        let e = parse(late).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == 2 && d.message.contains("starts at t = 10 min")),
            "{e}"
        );
    }

    proptest::proptest! {
        #[test]
        fn never_panics(rows in proptest::collection::vec(
            ("[ab]?", -5.0f64..50.0, 0.0f64..9000.0, proptest::sample::select(vec![-50.0, -150.0, 0.0, -0.0]), -1.0f64..1.0),
            0..30,
        )) {
            let mut text = String::from("run,t_min,speed_rpm,z_mm,drift_mm\n");
            for (run, t, n, z, e) in rows {
                text.push_str(&format!("{run},{},{n},{z},{e}\n", (t * 0.2).round() * 5.0));
            }
            if let Ok(d) = parse(&text) {
                proptest::prop_assert!(d.period_min > 0.0);
                for h in &d.heights {
                    for s in &h.series {
                        proptest::prop_assert_eq!(s.drift.len(), s.lines.len());
                    }
                }
            }
        }
    }
}
