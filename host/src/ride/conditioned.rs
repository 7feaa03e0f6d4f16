//! A ride from any clock, as the evaluations take it: one pass over the file gathers the
//! data-quality account and the stretches between gaps ([`Conditioned::scan`]), and
//! keeps the rows it parsed in a scratch file ([`crate::ride::scratch_rows`]); each
//! later pass reads the rows again (from there, or the text where no scratch file could
//! be written) and gives the levelled samples on a uniform grid at
//! the evaluation's rate ([`Conditioned::samples`]), stretch after stretch, so the
//! exposure pauses across each gap. Memory holds a line, the interpolation's 9 rows, the
//! resampling kernel's width and the step histogram, whatever the ride's length.
//!
//! The grid: a stretch's kept rows are interpolated onto a grid at the sensor's effective
//! rate ([`crate::ride::regular`]), then converted to the evaluation's rate by the
//! band-limited, zero-phase [`Resampler`]; when the two rates are within
//! [`SAME_RATE_TOLERANCE`], the rows are interpolated onto the evaluation's grid
//! directly (a uniform ride at that rate comes through unchanged).

use std::cell::RefCell;
use std::rc::Rc;

use anyhow::Result;
use supine_core::calibration::SensorFrame;

use crate::ride::level::Levelling;
use crate::ride::quality::{DataQuality, Scan};
use crate::ride::regular::{Cleaner, GridSamples, RowFate, grid_len};
use crate::ride::resample::Resampler;
use crate::ride::scratch_rows::ScratchWriter;

/// Rates closer than this (relative) are taken as the same: no rate conversion.
pub const SAME_RATE_TOLERANCE: f64 = 0.01;

/// A stream of timed samples: time (s), x, y, z (m/s^2).
pub type TimedSamples<'a> = Box<dyn Iterator<Item = Result<(f64, [f64; 3])>> + 'a>;

/// A stream of a file's rows: the line it is on (1-based), time (s), x, y, z (m/s^2,
/// the file's axes).
pub type FileRows<'a> = Box<dyn Iterator<Item = Result<(u64, f64, [f64; 3])>> + 'a>;

/// A source of raw rows, opened anew for each pass.
pub trait RawRows {
    /// The rows in the time window, in file order.
    fn open_rows(&self) -> Result<FileRows<'_>>;
}

/// What the conditioning does with a ride.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioning {
    /// The evaluation's rate, Hz.
    pub rate_hz: f64,
    /// Longest step bridged, s.
    pub max_gap_s: f64,
    /// The levelling conversion (sensor axes with gravity to litter axes without: the
    /// device's, or a rotation by the ride's own gravity).
    pub levelling: Option<SensorFrame>,
}

/// A scanned ride and how its samples are made.
#[derive(Clone, Debug)]
pub struct Conditioned {
    conditioning: Conditioning,
    /// Kept rows, first and last time of each stretch.
    stretches: Vec<(usize, f64, f64)>,
    /// The grid's rate, Hz (the effective rate, or the evaluation's when they agree).
    grid_hz: f64,
    /// The sensor's effective rate, Hz.
    effective_hz: f64,
    resampler: Option<Resampler>,
    samples: usize,
}

impl Conditioned {
    /// One pass over `rows`: the scan, from which the rest is decided.
    pub fn scan(rows: &dyn RawRows, max_gap_s: f64) -> Result<Scan> {
        Self::scan_keeping(rows, max_gap_s, &mut ScratchWriter::nowhere())
    }

    /// [`scan`](Self::scan), each row written to `keep` as it is read, for the passes
    /// after.
    pub fn scan_keeping(
        rows: &dyn RawRows,
        max_gap_s: f64,
        keep: &mut ScratchWriter,
    ) -> Result<Scan> {
        let mut cleaner = Cleaner::new(max_gap_s);
        let mut scan = Scan::new();
        for row in rows.open_rows()? {
            let (line, t, v) = row?;
            keep.push(line, t, v);
            let fate = cleaner.take(t, v);
            scan.take(line, t, v, fate);
        }
        Ok(scan)
    }

    /// The samples' plan for a ride whose scan is `scan`.
    pub fn new(scan: &Scan, conditioning: Conditioning) -> Result<Self> {
        let effective = scan.effective_rate_hz();
        let rate = conditioning.rate_hz;
        let same = (effective - rate).abs() <= SAME_RATE_TOLERANCE * rate;
        let grid_hz = if same { rate } else { effective };
        let resampler = (!same).then(|| Resampler::new(grid_hz, rate)).transpose()?;
        let samples = scan
            .stretches
            .iter()
            .map(|&(_, first, last)| {
                let grid = grid_len(first, last, grid_hz);
                resampler.as_ref().map_or(grid, |r| r.output_len(grid))
            })
            .sum();
        Ok(Self {
            conditioning,
            stretches: scan.stretches.clone(),
            grid_hz,
            effective_hz: effective,
            resampler,
            samples,
        })
    }

    /// Samples at the evaluation's rate.
    pub fn len(&self) -> usize {
        self.samples
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.samples == 0
    }

    /// The evaluation's rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        self.conditioning.rate_hz
    }

    /// The sensor's effective rate when the evaluation's differs from it (to 1 ppm), Hz.
    pub fn converted_from_hz(&self) -> Option<f64> {
        let rate = self.conditioning.rate_hz;
        ((self.effective_hz - rate).abs() > 1e-6 * rate).then_some(self.effective_hz)
    }

    /// The first kept row's time, s.
    pub fn start_s(&self) -> f64 {
        self.stretches.first().map_or(0.0, |s| s.1)
    }

    /// The account of `scan` for this plan.
    pub fn account(
        &self,
        scan: &Scan,
        format: String,
        levelling: Option<Levelling>,
    ) -> DataQuality {
        scan.account(
            format,
            self.conditioning.rate_hz,
            self.conditioning.max_gap_s,
            levelling,
        )
    }

    /// Every sample: time (s, the stretch's start plus the sample's place), litter x, y, z
    /// (m/s^2), read from `rows` as they are taken.
    pub fn samples<'a>(&'a self, rows: &'a dyn RawRows) -> Result<TimedSamples<'a>> {
        let kept = Rc::new(RefCell::new(KeptRows {
            rows: rows.open_rows()?,
            cleaner: Cleaner::new(self.conditioning.max_gap_s),
            levelling: self.conditioning.levelling,
            pending: None,
            error: None,
        }));
        let rate = self.conditioning.rate_hz;
        let shared = Rc::clone(&kept);
        let stretches = self.stretches.iter().map(move |&(_, first, last)| {
            let kept = &shared;
            let grid = GridSamples::new(
                Stretch {
                    kept: Rc::clone(kept),
                    started: false,
                },
                first,
                last,
                self.grid_hz,
            );
            let values: Box<dyn Iterator<Item = Result<[f64; 3]>>> = match &self.resampler {
                None => Box::new(grid.map(Ok)),
                Some(r) => resample(r, grid_len(first, last, self.grid_hz), grid),
            };
            let rest = Rc::clone(kept);
            let drained = std::iter::from_fn(move || {
                rest.borrow_mut().finish_stretch();
                None
            });
            let kept = Rc::clone(kept);
            values.chain(drained).enumerate().map(move |(j, v)| {
                if let Some(e) = kept.borrow_mut().error.take() {
                    return Err(e);
                }
                v.map(|v| (first + j as f64 / rate, v))
            })
        });
        let last = Rc::clone(&kept);
        let error = std::iter::from_fn(move || last.borrow_mut().error.take().map(Err));
        Ok(Box::new(stretches.flatten().chain(error)))
    }
}

/// `grid` (of `n` samples) converted by `resampler`: as a stream, or whole when too
/// short for one (a short stretch fits in memory).
fn resample<'a>(
    resampler: &'a Resampler,
    n: usize,
    grid: impl Iterator<Item = [f64; 3]> + 'a,
) -> Box<dyn Iterator<Item = Result<[f64; 3]>> + 'a> {
    let streams = resampler
        .stream(n, std::iter::empty::<Result<[f64; 3]>>())
        .is_ok();
    if streams {
        match resampler.stream(n, grid.map(Ok)) {
            Ok(stream) => return Box::new(stream),
            Err(e) => return Box::new(std::iter::once(Err(e))),
        }
    }
    let whole: Vec<[f64; 3]> = grid.collect();
    let columns: [Vec<f64>; 3] =
        std::array::from_fn(|c| resampler.process(&whole.iter().map(|v| v[c]).collect::<Vec<_>>()));
    let len = columns[0].len();
    Box::new((0..len).map(move |k| Ok([columns[0][k], columns[1][k], columns[2][k]])))
}

/// The kept, levelled rows of one pass, shared by its stretches.
struct KeptRows<'a> {
    rows: FileRows<'a>,
    cleaner: Cleaner,
    levelling: Option<SensorFrame>,
    /// The first row of the next stretch, read past the end of this one.
    pending: Option<(f64, [f64; 3])>,
    error: Option<anyhow::Error>,
}

impl KeptRows<'_> {
    /// Reads past the rows of the current stretch a grid did not need, up to the next
    /// stretch's first row.
    fn finish_stretch(&mut self) {
        while self.pending.is_none() {
            match self.next_kept() {
                Some((t, v, true)) => self.pending = Some((t, v)),
                Some(_) => {}
                None => return,
            }
        }
    }

    /// The next kept row and whether it starts a stretch.
    fn next_kept(&mut self) -> Option<(f64, [f64; 3], bool)> {
        loop {
            let (_, t, v) = match self.rows.next()? {
                Ok(row) => row,
                Err(e) => {
                    self.error = Some(e);
                    return None;
                }
            };
            let starts = match self.cleaner.take(t, v) {
                RowFate::Kept => false,
                RowFate::KeptAfterGap => true,
                RowFate::NotIncreasing | RowFate::Repeated => continue,
            };
            let v = match &self.levelling {
                None => v,
                Some(m) => m.to_litter_m_s2(v.map(|c| c as f32)).map(f64::from),
            };
            return Some((t, v, starts));
        }
    }
}

/// The rows of one stretch.
struct Stretch<'a> {
    kept: Rc<RefCell<KeptRows<'a>>>,
    started: bool,
}

impl Iterator for Stretch<'_> {
    type Item = (f64, [f64; 3]);

    fn next(&mut self) -> Option<(f64, [f64; 3])> {
        let mut kept = self.kept.borrow_mut();
        if !self.started {
            self.started = true;
            if let Some(row) = kept.pending.take() {
                return Some(row);
            }
            return kept.next_kept().map(|(t, v, _)| (t, v));
        }
        if kept.pending.is_some() {
            return None;
        }
        let (t, v, starts) = kept.next_kept()?;
        if starts {
            kept.pending = Some((t, v));
            return None;
        }
        Some((t, v))
    }
}

/// Raw rows already in memory (tests, and rides made by the host): row `k` is on line
/// `k + 1`.
impl RawRows for Vec<(f64, [f64; 3])> {
    fn open_rows(&self) -> Result<FileRows<'_>> {
        Ok(Box::new(
            (1u64..)
                .zip(self.iter())
                .map(|(line, (t, v))| Ok((line, *t, *v))),
        ))
    }
}
