//! Renishaw XL-80 dynamic captures (`.rtx`). The vendor does not publish the
//! layout; open converters agree on: the line `HEADER::`, then `Key: value`
//! lines (Owner, Version no, File Type, Velocity, Sample rate, Sample no,
//! Trigger point, Trigger interval, Actual sample rate, Flags, Machine,
//! Serial No, Date, By, Axis, Location), the line `Data:`, the samples as
//! little-endian 64-bit floats, and `EOF::` (lines end in CR LF). The samples
//! are taken as the laser reading in mm (scale with the `gain` of
//! [`LogOptions`] otherwise).
//!
//! A capture has no command channel, so the approaches are found in the
//! signal: it is averaged over blocks of 50 ms, a dwell is a run of blocks
//! lasting at least `min_dwell_s` whose means stay within `dwell_band_mm`; its
//! value is the mean of its samples, its direction the side the axis came
//! from (the block before the dwell above or below it), its target the
//! nearest of `targets_mm` (required) within `reach_tol_mm`. Dwells near no
//! target (overruns) are dropped and listed in the notes.

use std::collections::BTreeMap;
use std::path::Path;

use super::iso230_2::Run;
use super::read_log::{LogOptions, Move, approaches};
use crate::io::{Diagnostic, Diagnostics, fmt_f64};

/// The content of a capture.
#[derive(Debug, Clone, PartialEq)]
pub struct RtxCapture {
    /// Header entries as written (`Key` → `value`).
    pub header: BTreeMap<String, String>,
    /// Samples per second (`Actual sample rate`, else `Sample rate`).
    pub sample_rate_hz: f64,
    /// The samples, as stored.
    pub samples: Vec<f64>,
}

fn find(hay: &[u8], needle: &[u8], from: usize) -> Option<usize> {
    hay.get(from..)?
        .windows(needle.len())
        .position(|w| w == needle)
        .map(|p| p + from)
}

/// Read a capture (layout in the module documentation).
pub fn read_rtx(path: &Path) -> Result<RtxCapture, Diagnostics> {
    let bytes = std::fs::read(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
    if !bytes.starts_with(b"HEADER::") {
        return Err(Diagnostic::at(
            path,
            1,
            1,
            "not a capture: it does not start with `HEADER::`",
        )
        .into());
    }
    let Some(data) = find(&bytes, b"\nData:", 0) else {
        return Err(Diagnostic::whole(path, "the header does not end with a `Data:` line").into());
    };
    let head = String::from_utf8_lossy(&bytes[..data]);
    let mut header = BTreeMap::new();
    for l in head.lines().skip(1) {
        if let Some((k, v)) = l.split_once(": ") {
            header.insert(k.trim().to_string(), v.trim().to_string());
        }
    }
    let data_line = head.lines().count() + 1;
    let mut start = data + b"\nData:".len();
    for nl in [b'\r', b'\n'] {
        if bytes.get(start) == Some(&nl) {
            start += 1;
        }
    }
    let end = if bytes.ends_with(b"EOF::\r\n") {
        bytes.len() - 7
    } else if bytes.ends_with(b"EOF::\n") {
        bytes.len() - 6
    } else if bytes.ends_with(b"EOF::") {
        bytes.len() - 5
    } else {
        return Err(
            Diagnostic::whole(path, "the capture does not end with `EOF::` (truncated?)").into(),
        );
    };
    if end < start || !(end - start).is_multiple_of(8) {
        return Err(Diagnostic::at(
            path,
            data_line,
            1,
            format!(
                "the data block is {} bytes, not a whole number of 8-byte samples",
                end.saturating_sub(start)
            ),
        )
        .into());
    }
    let samples: Vec<f64> = bytes[start..end]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect();
    if let Some(k) = samples.iter().position(|v| !v.is_finite()) {
        return Err(Diagnostic::at(
            path,
            data_line,
            1,
            format!("sample {} is not a number", k + 1),
        )
        .into());
    }
    let rate = ["Actual sample rate", "Sample rate"]
        .iter()
        .filter_map(|k| header.get(*k)?.parse::<f64>().ok())
        .find(|r| r.is_finite() && *r > 0.0);
    let Some(sample_rate_hz) = rate else {
        return Err(Diagnostic::whole(
            path,
            "the header gives no positive `Actual sample rate` or `Sample rate`",
        )
        .into());
    };
    Ok(RtxCapture {
        header,
        sample_rate_hz,
        samples,
    })
}

/// Read a capture and find its approaches (see the module documentation).
pub fn read_rtx_run(path: &Path, opts: &LogOptions) -> Result<Run, Diagnostics> {
    let cap = read_rtx(path)?;
    let Some(targets) = opts.targets_mm.as_ref().filter(|t| !t.is_empty()) else {
        return Err(Diagnostic::whole(
            path,
            "a capture has no command channel: give the target positions (--targets)",
        )
        .into());
    };
    let x: Vec<f64> = cap
        .samples
        .iter()
        .map(|v| opts.gain * v + opts.offset)
        .collect();
    let block = ((cap.sample_rate_hz * 0.05).round() as usize).max(1);
    let means: Vec<f64> = x
        .chunks(block)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect();
    let min_blocks = ((opts.min_dwell_s / 0.05).ceil() as usize)
        .max(opts.min_dwell_samples.min(3))
        .max(1);
    let mut moves = Vec::new();
    let mut i = 0;
    while i < means.len() {
        let (mut lo, mut hi) = (means[i], means[i]);
        let mut j = i + 1;
        while j < means.len() {
            lo = lo.min(means[j]);
            hi = hi.max(means[j]);
            if hi - lo > opts.dwell_band_mm {
                break;
            }
            j += 1;
        }
        if j - i >= min_blocks {
            let raw = &x[i * block..(j * block).min(x.len())];
            let mean = raw.iter().sum::<f64>() / raw.len() as f64;
            let near = targets
                .iter()
                .copied()
                .min_by(|a, b| (a - mean).abs().total_cmp(&(b - mean).abs()))
                .filter(|t| (t - mean).abs() <= opts.reach_tol_mm);
            let up = (i > 0).then(|| means[i - 1] < mean);
            moves.push(Move {
                command_mm: near.unwrap_or(mean),
                line: 0,
                col: 0,
                up: if near.is_some() { up } else { Some(true) },
                // one value: the whole dwell is already averaged
                reference_mm: vec![mean; opts.min_dwell_samples.max(1)],
            });
            i = j;
        } else {
            i += 1;
        }
    }
    let o = LogOptions {
        targets_mm: Some(targets.clone()),
        dwell_band_mm: f64::INFINITY,
        ..opts.clone()
    };
    let notes = vec![format!(
        "{} samples at {} Hz; {} dwell(s) of at least {} s found",
        x.len(),
        fmt_f64(cap.sample_rate_hz),
        moves.len(),
        fmt_f64(opts.min_dwell_s)
    )];
    approaches(path, &moves, &o, 0, notes)
}
