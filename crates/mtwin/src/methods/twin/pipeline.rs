//! The digital-twin pipeline (after \[R5\], docs/twin.md), streaming.
//!
//! **Stage 1** ([`Predictor::push`], one command sample at a time, in chunks):
//! nominal forward kinematics of the command (command tip and axis in W), the
//! per-axis servo models (predicted encoder positions), forward kinematics with
//! the geometric errors of those positions (actual tip `P_a` and axis `O_a`).
//! The command polyline is kept (it is searched globally); the actual samples
//! are spooled (in memory up to [`SPILL_SAMPLES`], then to an anonymous
//! temporary file).
//!
//! **Stage 2** ([`Predictor::finish`]): the exact global nearest point `P_c` of
//! every actual sample on the command polyline, in parallel chunks, handed to a
//! sink in sample order with `ε_p = |P_a − P_c|` and `ε_o = ∠(O_a, O_c)`.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Seek, Write};

use nalgebra::Vector3;

use super::TwinError;
use super::nearest::{CommandPath, angle_between};
use crate::kinematics::Kinematics;
use crate::model::Machine;
use crate::sysid::{Servo, ServoStepper};

/// Command samples processed together in stage 1 (parallel kinematics per chunk).
pub(super) const CHUNK: usize = 4096;

/// Actual samples queried together in stage 2.
const QUERY_CHUNK: usize = 16384;

/// Actual samples kept in memory before the spool moves to a temporary file.
pub const SPILL_SAMPLES: usize = 1 << 17;

/// `f64` values per spooled actual sample: `t`, `P_a` (3), `O_a` (3).
const RECORD: usize = 7;

/// Bins of the per-stretch summary ([`TwinSummary::bins`]).
pub const BINS: usize = 10;

/// Which error sources the actual machine has (`--only`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Sources {
    /// Servo models and geometric errors (the full twin).
    #[default]
    All,
    /// Servo models on the nominal geometry.
    Servo,
    /// Geometric errors only: the axes follow their commands exactly.
    Geometry,
}

impl Sources {
    /// Lower-case name (`all`, `servo`, `geometry`).
    pub fn as_str(self) -> &'static str {
        match self {
            Sources::All => "all",
            Sources::Servo => "servo",
            Sources::Geometry => "geometry",
        }
    }
}

/// The twin of one machine: nominal and actual kinematics and the axis servos.
#[derive(Debug, Clone)]
pub struct Twin {
    nominal: Kinematics,
    actual: Kinematics,
    servos: Vec<Option<Servo>>,
    names: Vec<String>,
    sources: Sources,
    par: crate::par::Par,
}

/// One predicted sample (a row of PRED.csv plus where it lies).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwinSample {
    /// 0-based sample index.
    pub index: u64,
    /// Time, s (the command sample's).
    pub t: f64,
    /// Command tool tip in W, mm (nominal kinematics of the command sample).
    pub cmd_tip: Vector3<f64>,
    /// Command tool axis in W (unit).
    pub cmd_axis: Vector3<f64>,
    /// Actual tool tip `P_a` in W, mm.
    pub tip: Vector3<f64>,
    /// Actual tool axis `O_a` in W (unit).
    pub axis: Vector3<f64>,
    /// The nearest point `P_c` on the command polyline, mm in W.
    pub nearest: Vector3<f64>,
    /// Where `P_c` lies, in samples: segment `k` plus parameter `u` (`k + u`).
    pub nearest_at: f64,
    /// `ε_p = |P_a − P_c|`, mm.
    pub tip_error: f64,
    /// `ε_o`: angle between `O_a` and the command axis at `P_c`, rad.
    pub axis_error: f64,
    /// Command path length from the first sample to this one, mm.
    pub path_length: f64,
}

/// Where a maximum occurs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct At {
    /// Sample index.
    pub index: u64,
    /// Time, s.
    pub t: f64,
    /// Command path length, mm.
    pub path_length: f64,
}

/// Error statistics over one stretch of the run (one tenth of the samples).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bin {
    /// Samples in the stretch.
    pub samples: u64,
    /// First and last time, s.
    pub t: [f64; 2],
    /// Command path length at the first and last sample, mm.
    pub path_length: [f64; 2],
    /// Largest `ε_p`, mm.
    pub tip_error_max: f64,
    /// RMS of `ε_p`, mm.
    pub tip_error_rms: f64,
    /// Largest `ε_o`, rad.
    pub axis_error_max: f64,
}

/// What a run predicted, in summary.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TwinSummary {
    /// Samples.
    pub samples: u64,
    /// Error sources of the run.
    pub sources: Sources,
    /// Time of the first and the last sample, s.
    pub t: [f64; 2],
    /// Command path length, mm.
    pub path_length: f64,
    /// Largest `ε_p`, mm.
    pub tip_error_max: f64,
    /// RMS of `ε_p`, mm.
    pub tip_error_rms: f64,
    /// Where the largest `ε_p` occurs.
    pub tip_error_max_at: At,
    /// Largest `ε_o`, rad.
    pub axis_error_max: f64,
    /// RMS of `ε_o`, rad.
    pub axis_error_rms: f64,
    /// Where the largest `ε_o` occurs.
    pub axis_error_max_at: At,
    /// The run cut into [`BINS`] stretches of equal sample count, in order.
    pub bins: Vec<Bin>,
}

/// Progress of a run, for a progress bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Stage 1: command samples read so far (total unknown while streaming).
    Commands(u64),
    /// Stage 2: samples whose errors are computed, of `total`.
    Errors {
        /// Samples done.
        done: u64,
        /// Samples in all.
        total: u64,
    },
}

impl Twin {
    /// The twin of `machine` with the error `sources`: its nominal kinematics for the
    /// commands, its geometric errors (unless `Sources::Servo`) and its `[axes.servo]`
    /// models (unless `Sources::Geometry`; axes without one follow their commands).
    pub fn new(machine: &Machine, sources: Sources) -> Result<Twin, TwinError> {
        let nominal = Kinematics::nominal(machine);
        let actual = match sources {
            Sources::Servo => nominal.clone(),
            _ => Kinematics::new(machine),
        };
        let servos = machine
            .axes
            .iter()
            .map(|a| match (&a.servo, sources) {
                (Some(s), Sources::All | Sources::Servo) => {
                    Servo::new(s.ts, s.b.clone(), s.a.clone(), s.nk)
                        .map(Some)
                        .map_err(|source| TwinError::Servo {
                            axis: a.name.clone(),
                            source,
                        })
                }
                _ => Ok(None),
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Twin {
            nominal,
            actual,
            servos,
            names: machine.axes.iter().map(|a| a.name.clone()).collect(),
            sources,
            par: crate::par::Par::rayon(0),
        })
    }

    /// The same twin with the parallelism `par` for its kinematics and its
    /// nearest-point search: [`Par::Seq`](crate::par::Par::Seq) on the
    /// calling thread only, `Par::rayon(_)` (the default, `Par::rayon(0)`)
    /// on the rayon pool the run is in (choose its size with
    /// [`crate::par::install`]). Both give bit-identical samples.
    pub fn with_par(mut self, par: crate::par::Par) -> Twin {
        self.par = par;
        self
    }

    /// Axis names in command order.
    pub fn axis_names(&self) -> &[String] {
        &self.names
    }

    /// Error sources of this twin.
    pub fn sources(&self) -> Sources {
        self.sources
    }

    /// Start a run on commands sampled every `ts` s. Every servo model must have this
    /// sample period (within 1 %).
    pub fn start(&self, ts: f64) -> Result<Predictor<'_>, TwinError> {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(TwinError::Period(ts));
        }
        for (name, s) in self.names.iter().zip(&self.servos) {
            if let Some(s) = s
                && (s.ts() - ts).abs() > 0.01 * ts
            {
                return Err(TwinError::ServoPeriod {
                    axis: name.clone(),
                    servo: s.ts(),
                    commands: ts,
                });
            }
        }
        let n = self.names.len();
        Ok(Predictor {
            twin: self,
            steppers: self
                .servos
                .iter()
                .map(|s| s.as_ref().map(Servo::stepper))
                .collect(),
            chunk_t: Vec::with_capacity(CHUNK),
            chunk_q: Vec::with_capacity(CHUNK * n),
            chunk_qa: Vec::with_capacity(CHUNK * n),
            tips: Vec::new(),
            axes: Vec::new(),
            spool: Spool::Memory(Vec::new()),
        })
    }

    /// A whole run in memory: commands `qs` (`n_axes` values per sample, row after row)
    /// at times `t0 + k·ts`. For tests and benchmarks; the CLI streams.
    pub fn predict_slice(
        &self,
        t0: f64,
        ts: f64,
        qs: &[f64],
    ) -> Result<(Vec<TwinSample>, TwinSummary), TwinError> {
        let n = self.names.len().max(1);
        if !qs.len().is_multiple_of(n) {
            return Err(TwinError::AxisCount {
                expected: n,
                found: qs.len() % n,
            });
        }
        let mut p = self.start(ts)?;
        for (k, q) in qs.chunks_exact(n).enumerate() {
            p.push(t0 + k as f64 * ts, q).map_err(TwinError::Spool)?;
        }
        let mut out = Vec::with_capacity(qs.len() / n);
        let summary = p.finish(
            |s| {
                out.push(*s);
                Ok(())
            },
            &mut |_| {},
        )?;
        Ok((out, summary))
    }
}

/// Actual samples waiting for stage 2: in memory, then in a temporary file.
#[derive(Debug)]
enum Spool {
    Memory(Vec<f64>),
    File(BufWriter<File>),
}

impl Spool {
    fn push(&mut self, rec: &[f64; RECORD]) -> io::Result<()> {
        match self {
            Spool::Memory(v) => {
                v.extend_from_slice(rec);
                if v.len() >= SPILL_SAMPLES * RECORD {
                    let mut w = BufWriter::with_capacity(1 << 20, tempfile::tempfile()?);
                    write_f64s(&mut w, v)?;
                    *self = Spool::File(w);
                }
                Ok(())
            }
            Spool::File(w) => write_f64s(w, rec),
        }
    }
}

fn write_f64s(w: &mut impl Write, v: &[f64]) -> io::Result<()> {
    for x in v {
        w.write_all(&x.to_le_bytes())?;
    }
    Ok(())
}

/// A run in progress: push the command samples, then [`finish`](Predictor::finish).
#[derive(Debug)]
pub struct Predictor<'t> {
    twin: &'t Twin,
    steppers: Vec<Option<ServoStepper>>,
    chunk_t: Vec<f64>,
    chunk_q: Vec<f64>,
    chunk_qa: Vec<f64>,
    tips: Vec<Vector3<f64>>,
    axes: Vec<Vector3<f64>>,
    spool: Spool,
}

impl Predictor<'_> {
    /// The next command sample: time `t` (s) and axis positions `q` in machine axis
    /// order (mm, deg). Samples must come in time order at the period given to
    /// [`Twin::start`]. Fails only on the spool file.
    pub fn push(&mut self, t: f64, q: &[f64]) -> io::Result<()> {
        debug_assert_eq!(q.len(), self.twin.names.len());
        self.chunk_t.push(t);
        self.chunk_q.extend_from_slice(q);
        for (i, s) in self.steppers.iter_mut().enumerate() {
            self.chunk_qa.push(match s {
                Some(s) => s.push(q[i]),
                None => q[i],
            });
        }
        if self.chunk_t.len() == CHUNK {
            self.flush()?;
        }
        Ok(())
    }

    /// Command samples pushed so far.
    pub fn samples(&self) -> u64 {
        (self.tips.len() + self.chunk_t.len()) as u64
    }

    /// Kinematics of the buffered chunk, in parallel.
    fn flush(&mut self) -> io::Result<()> {
        crate::par::here(self.twin.par, || self.flush_here())
    }

    fn flush_here(&mut self) -> io::Result<()> {
        let tw = self.twin;
        let (commanded, actual) = crate::par::join(
            || tw.nominal.poses(&self.chunk_q),
            || tw.actual.poses(&self.chunk_qa),
        );
        for ((t, c), a) in self.chunk_t.iter().zip(&commanded).zip(&actual) {
            self.tips.push(c.tip);
            self.axes.push(c.axis);
            self.spool
                .push(&[*t, a.tip.x, a.tip.y, a.tip.z, a.axis.x, a.axis.y, a.axis.z])?;
        }
        self.chunk_t.clear();
        self.chunk_q.clear();
        self.chunk_qa.clear();
        Ok(())
    }

    /// Stage 2: the errors of every sample, handed to `sink` in order; `progress` is
    /// told how far it got after every chunk.
    pub fn finish<F>(
        self,
        mut sink: F,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<TwinSummary, TwinError>
    where
        F: FnMut(&TwinSample) -> io::Result<()>,
    {
        let par = self.twin.par;
        crate::par::here(par, || self.finish_here(&mut sink, progress))
    }

    /// [`Predictor::finish`] for a `dyn` sink: compiled once, whatever the
    /// callers' sink types.
    fn finish_here(
        mut self,
        sink: &mut dyn FnMut(&TwinSample) -> io::Result<()>,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<TwinSummary, TwinError> {
        self.flush().map_err(TwinError::Spool)?;
        let total = self.tips.len() as u64;
        if total == 0 {
            return Err(TwinError::Empty);
        }
        progress(Progress::Commands(total));
        let path = CommandPath::new(
            std::mem::take(&mut self.tips),
            std::mem::take(&mut self.axes),
        );
        let mut source = SpoolReader::new(self.spool).map_err(TwinError::Spool)?;
        let mut acc = Accumulator::new(total, self.twin.sources);
        let mut records = Vec::new();
        let mut first = 0usize;
        while source.read(&mut records).map_err(TwinError::Spool)? {
            let rows: Vec<TwinSample> =
                crate::par::map_chunks_init(&records, RECORD, 512, Vec::new, |scratch, i, r| {
                    let j = first + i;
                    let tip = Vector3::new(r[1], r[2], r[3]);
                    let axis = Vector3::new(r[4], r[5], r[6]);
                    let near = path.nearest(&tip, j, scratch);
                    TwinSample {
                        index: j as u64,
                        t: r[0],
                        cmd_tip: path.tip(j),
                        cmd_axis: path.axis(j),
                        tip,
                        axis,
                        nearest: near.point,
                        nearest_at: near.segment as f64 + near.u,
                        tip_error: near.distance,
                        axis_error: angle_between(&axis, &near.axis),
                        path_length: 0.0,
                    }
                });
            for mut row in rows {
                acc.add(&mut row);
                sink(&row).map_err(TwinError::Sink)?;
            }
            first += records.len() / RECORD;
            progress(Progress::Errors {
                done: first as u64,
                total,
            });
        }
        Ok(acc.finish())
    }
}

/// Reads the spool back in chunks of [`QUERY_CHUNK`] records.
enum SpoolReader {
    Memory(Vec<f64>, usize),
    File(BufReader<File>),
}

impl SpoolReader {
    fn new(spool: Spool) -> io::Result<SpoolReader> {
        Ok(match spool {
            Spool::Memory(v) => SpoolReader::Memory(v, 0),
            Spool::File(w) => {
                let mut f = w.into_inner().map_err(|e| e.into_error())?;
                f.rewind()?;
                SpoolReader::File(BufReader::with_capacity(1 << 20, f))
            }
        })
    }

    /// The next chunk into `out`; `false` at the end.
    fn read(&mut self, out: &mut Vec<f64>) -> io::Result<bool> {
        out.clear();
        match self {
            SpoolReader::Memory(v, pos) => {
                let end = (*pos + QUERY_CHUNK * RECORD).min(v.len());
                out.extend_from_slice(&v[*pos..end]);
                *pos = end;
            }
            SpoolReader::File(r) => {
                let mut bytes = Vec::with_capacity(QUERY_CHUNK * RECORD * 8);
                r.by_ref()
                    .take((QUERY_CHUNK * RECORD * 8) as u64)
                    .read_to_end(&mut bytes)?;
                if bytes.len() % (RECORD * 8) != 0 {
                    return Err(io::Error::other("the spool file is truncated"));
                }
                out.extend(
                    bytes
                        .chunks_exact(8)
                        .map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8]))),
                );
            }
        }
        Ok(!out.is_empty())
    }
}

/// Running statistics of stage 2 (and the path length of each sample).
struct Accumulator {
    total: u64,
    summary: TwinSummary,
    tip_sq: f64,
    axis_sq: f64,
    bin_sq: Vec<f64>,
    prev_tip: Option<Vector3<f64>>,
    length: f64,
}

impl Accumulator {
    fn new(total: u64, sources: Sources) -> Self {
        let bins = (total as usize).min(BINS);
        Accumulator {
            total,
            summary: TwinSummary {
                sources,
                bins: vec![Bin::default(); bins],
                ..TwinSummary::default()
            },
            tip_sq: 0.0,
            axis_sq: 0.0,
            bin_sq: vec![0.0; bins],
            prev_tip: None,
            length: 0.0,
        }
    }

    fn add(&mut self, row: &mut TwinSample) {
        if let Some(p) = self.prev_tip {
            self.length += (row.cmd_tip - p).norm();
        }
        self.prev_tip = Some(row.cmd_tip);
        row.path_length = self.length;
        let s = &mut self.summary;
        let at = At {
            index: row.index,
            t: row.t,
            path_length: row.path_length,
        };
        if s.samples == 0 {
            s.t[0] = row.t;
        }
        s.t[1] = row.t;
        s.samples += 1;
        if row.tip_error > s.tip_error_max || s.samples == 1 {
            s.tip_error_max = row.tip_error;
            s.tip_error_max_at = at;
        }
        if row.axis_error > s.axis_error_max || s.samples == 1 {
            s.axis_error_max = row.axis_error;
            s.axis_error_max_at = at;
        }
        self.tip_sq += row.tip_error * row.tip_error;
        self.axis_sq += row.axis_error * row.axis_error;
        let nb = s.bins.len() as u64;
        let b = (row.index * nb / self.total.max(1)) as usize;
        if let Some(bin) = s.bins.get_mut(b) {
            if bin.samples == 0 {
                bin.t[0] = row.t;
                bin.path_length[0] = row.path_length;
            }
            bin.samples += 1;
            bin.t[1] = row.t;
            bin.path_length[1] = row.path_length;
            bin.tip_error_max = bin.tip_error_max.max(row.tip_error);
            bin.axis_error_max = bin.axis_error_max.max(row.axis_error);
            self.bin_sq[b] += row.tip_error * row.tip_error;
        }
    }

    fn finish(mut self) -> TwinSummary {
        let s = &mut self.summary;
        let n = s.samples.max(1) as f64;
        s.tip_error_rms = (self.tip_sq / n).sqrt();
        s.axis_error_rms = (self.axis_sq / n).sqrt();
        s.path_length = self.length;
        for (bin, sq) in s.bins.iter_mut().zip(&self.bin_sq) {
            bin.tip_error_rms = (sq / bin.samples.max(1) as f64).sqrt();
        }
        self.summary
    }
}
