//! From a logger's clock to a uniform grid: which rows are kept ([`Cleaner`]), where the
//! ride breaks ([`Cleaner::max_gap_s`]), and the samples on a uniform grid within each
//! unbroken stretch ([`GridSamples`]).
//!
//! # Rows dropped, and why
//! A row whose time is not after the last kept row's (a duplicated timestamp, a step
//! backwards) is dropped and counted: two values for one instant, or an instant out of
//! order, cannot both be placed, and the rows around it still carry the ride. A row whose
//! three values repeat the previous row's bit for bit is a logger polling faster than its
//! sensor (sample-and-hold): it is no new sample, and is dropped and counted as repeated,
//! so that the kept rows are the sensor's own samples at the times they were first seen.
//! A step longer than the gap bound is never bridged: the ride is split there, and the
//! stretches are evaluated one after the other (the exposure pauses across the gap).
//!
//! # The grid
//! Within a stretch, the grid's samples are interpolated from the kept rows at their own
//! times by a Lagrange polynomial through the 8 nearest rows (4 on each side), the local
//! form of band-limited interpolation for unevenly spaced samples: its error for a sine of
//! `w` rad/s on steps of `h` s is about `1e-3 (w h)^8`, so 0.1 % at 80 Hz on a 500 Hz
//! clock (measured in `ride_clocks`). Where the rows bunch up (bursts), the polynomial
//! through 8 of them can swing far between them; so the interpolation falls back to 4 and
//! then 2 rows while the sum of the absolute weights (the Lebesgue function, how much the
//! rows' noise can be amplified) exceeds [`MAX_LEBESGUE`]. A grid time that is a row's
//! time (to a millionth of a step) takes that row's values exactly, so a uniform ride on
//! its own grid comes through unchanged.
//!
//! No crate interpolates unevenly spaced samples onto a grid in a stream; the method is
//! the textbook barycentric-free Lagrange form (8 terms), tested against closed forms.

use std::collections::VecDeque;

/// Largest sum of absolute interpolation weights accepted before fewer rows are used.
pub const MAX_LEBESGUE: f64 = 3.0;
/// Rows on each side of a grid time used by the interpolation, at most.
pub const HALF_WIDTH_ROWS: usize = 4;
/// Default longest step bridged by interpolation, s.
pub const DEFAULT_MAX_GAP_S: f64 = 0.25;

/// What became of a row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowFate {
    /// Kept, continuing the current stretch.
    Kept,
    /// Kept, starting a new stretch after a gap (or the first row).
    KeptAfterGap,
    /// Dropped: its time is not after the last kept row's.
    NotIncreasing,
    /// Dropped: its values repeat the previous row's (sample-and-hold).
    Repeated,
}

/// Decides, row by row, which rows are kept and where the ride breaks.
#[derive(Clone, Debug)]
pub struct Cleaner {
    /// Longest step bridged, s.
    pub max_gap_s: f64,
    last_kept_s: Option<f64>,
    last_values: Option<[f64; 3]>,
}

impl Cleaner {
    /// A cleaner that breaks the ride at steps longer than `max_gap_s`.
    pub fn new(max_gap_s: f64) -> Self {
        Self {
            max_gap_s,
            last_kept_s: None,
            last_values: None,
        }
    }

    /// The fate of the row at `time_s` with `values`.
    pub fn take(&mut self, time_s: f64, values: [f64; 3]) -> RowFate {
        if let Some(last) = self.last_kept_s
            && time_s <= last
        {
            return RowFate::NotIncreasing;
        }
        let repeated = self.last_values.is_some_and(|v| {
            v.iter()
                .zip(&values)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        });
        self.last_values = Some(values);
        if repeated {
            return RowFate::Repeated;
        }
        let fate = match self.last_kept_s {
            Some(last) if time_s - last <= self.max_gap_s => RowFate::Kept,
            _ => RowFate::KeptAfterGap,
        };
        self.last_kept_s = Some(time_s);
        fate
    }
}

/// Grid samples of one stretch at `rate_hz` from its kept rows `(time_s, values)`: the
/// first at the first row's time, the last at or before the last row's, `grid_len`
/// samples ([`grid_len`]).
pub struct GridSamples<I> {
    rows: I,
    /// Kept rows around the grid time: `window[pos]` is the last row at or before it.
    window: VecDeque<(f64, [f64; 3])>,
    pos: usize,
    exhausted: bool,
    start_s: f64,
    step_s: f64,
    next: usize,
    len: usize,
}

/// Grid samples at `rate_hz` in a stretch from `first_s` to `last_s`.
pub fn grid_len(first_s: f64, last_s: f64, rate_hz: f64) -> usize {
    ((last_s - first_s) * rate_hz + 1e-6).floor() as usize + 1
}

impl<I: Iterator<Item = (f64, [f64; 3])>> GridSamples<I> {
    /// The grid of the stretch whose kept rows `rows` gives, from `first_s` to `last_s`.
    pub fn new(rows: I, first_s: f64, last_s: f64, rate_hz: f64) -> Self {
        Self {
            rows,
            window: VecDeque::with_capacity(2 * HALF_WIDTH_ROWS + 2),
            pos: 0,
            exhausted: false,
            start_s: first_s,
            step_s: 1.0 / rate_hz,
            next: 0,
            len: grid_len(first_s, last_s, rate_hz),
        }
    }

    fn pull(&mut self) -> bool {
        if self.exhausted {
            return false;
        }
        match self.rows.next() {
            Some(row) => {
                self.window.push_back(row);
                true
            }
            None => {
                self.exhausted = true;
                false
            }
        }
    }
}

/// The value at `t` from `nodes` (times and values), by Lagrange interpolation through
/// `count` of them around `at` (the last node at or before `t`), fewer while the weights'
/// absolute sum exceeds [`MAX_LEBESGUE`].
fn interpolate(nodes: &[(f64, [f64; 3])], at: usize, t: f64) -> [f64; 3] {
    let n = nodes.len();
    let mut weights = [0.0f64; 2 * HALF_WIDTH_ROWS];
    for half in [HALF_WIDTH_ROWS, 2, 1] {
        let lo = (at + 1)
            .saturating_sub(half)
            .min(n.saturating_sub(2 * half));
        let hi = (lo + 2 * half).min(n);
        let used = &nodes[lo..hi];
        let mut lebesgue = 0.0;
        for (i, (weight, &(ti, _))) in weights.iter_mut().zip(used).enumerate() {
            let mut w = 1.0;
            for (j, &(tj, _)) in used.iter().enumerate() {
                if j != i {
                    w *= (t - tj) / (ti - tj);
                }
            }
            *weight = w;
            lebesgue += w.abs();
        }
        if lebesgue <= MAX_LEBESGUE || half == 1 {
            let mut y = [0.0; 3];
            for (w, (_, v)) in weights.iter().zip(used) {
                for (c, v) in y.iter_mut().zip(v) {
                    *c += w * v;
                }
            }
            return y;
        }
    }
    unreachable!("the two-row interpolation always returns")
}

impl<I: Iterator<Item = (f64, [f64; 3])>> Iterator for GridSamples<I> {
    type Item = [f64; 3];

    fn next(&mut self) -> Option<[f64; 3]> {
        if self.next >= self.len {
            return None;
        }
        let t = self.start_s + self.next as f64 * self.step_s;
        self.next += 1;
        if self.window.is_empty() && !self.pull() {
            return None;
        }
        // Advance to the last row at or before t.
        loop {
            while self.pos + 1 >= self.window.len() && self.pull() {}
            match self.window.get(self.pos + 1) {
                Some(&(tn, _)) if tn <= t => self.pos += 1,
                _ => break,
            }
        }
        while self.window.len() < self.pos + 1 + HALF_WIDTH_ROWS && self.pull() {}
        while self.pos > HALF_WIDTH_ROWS {
            self.window.pop_front();
            self.pos -= 1;
        }
        let tolerance = 1e-6 * self.step_s;
        if let Some((tn, v)) = self.window.get(self.pos)
            && (t - tn).abs() <= tolerance
        {
            return Some(*v);
        }
        if let Some((tn, v)) = self.window.get(self.pos + 1)
            && (t - tn).abs() <= tolerance
        {
            return Some(*v);
        }
        if self.window.len() == 1 {
            return Some(self.window[0].1);
        }
        Some(interpolate(self.window.make_contiguous(), self.pos, t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cleaner_drops_backward_duplicate_and_held_rows_and_breaks_at_gaps() {
        let mut c = Cleaner::new(0.25);
        let rows = [
            (0.0, [1.0, 0.0, 0.0]),
            (0.01, [2.0, 0.0, 0.0]),
            (0.01, [3.0, 0.0, 0.0]),
            (0.005, [4.0, 0.0, 0.0]),
            (0.02, [4.0, 0.0, 0.0]),
            (0.03, [4.0, 0.0, 0.0]),
            (0.5, [5.0, 0.0, 0.0]),
        ];
        let fates: Vec<RowFate> = rows.iter().map(|(t, v)| c.take(*t, *v)).collect();
        use RowFate::*;
        assert_eq!(
            fates,
            [
                KeptAfterGap,
                Kept,
                NotIncreasing,
                NotIncreasing,
                Kept,
                Repeated,
                KeptAfterGap
            ]
        );
    }

    #[test]
    fn a_uniform_stretch_on_its_own_grid_comes_through_unchanged_and_a_cubic_exactly() {
        let rows: Vec<(f64, [f64; 3])> = (0..50)
            .map(|k| {
                let t = k as f64 * 0.004;
                (t, [t.sin(), k as f64, -1.0])
            })
            .collect();
        let grid: Vec<[f64; 3]> =
            GridSamples::new(rows.iter().copied(), 0.0, rows[49].0, 250.0).collect();
        assert_eq!(grid.len(), 50);
        for (g, r) in grid.iter().zip(&rows) {
            assert_eq!(g, &r.1);
        }
        // A cubic through uneven rows is reproduced at any grid time.
        let cubic = |t: f64| 1.0 + t - 3.0 * t * t + 2.0 * t * t * t;
        let times = [
            0.0, 0.011, 0.019, 0.032, 0.04, 0.051, 0.058, 0.071, 0.08, 0.092, 0.1, 0.111, 0.123,
        ];
        let rows = times.iter().map(|&t| (t, [cubic(t), 0.0, 0.0]));
        let grid: Vec<[f64; 3]> = GridSamples::new(rows, 0.0, 0.123, 100.0).collect();
        assert_eq!(grid.len(), 13);
        for (m, g) in grid.iter().enumerate() {
            let t = m as f64 * 0.01;
            assert!(
                (g[0] - cubic(t)).abs() < 1e-9,
                "{t}: {} vs {}",
                g[0],
                cubic(t)
            );
        }
    }
}
