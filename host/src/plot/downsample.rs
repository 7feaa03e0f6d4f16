//! Fewer points for long series, keeping what the eye must see: per pixel column, the
//! minimum and the maximum, in the order they occur, so that peaks and shocks keep their
//! full height however many samples share a column.

/// At most `2 * columns` points of `(t[k], y[k])`: for each of `columns` equal runs of
/// samples, its minimum and its maximum in time order (one point if they coincide). Series
/// already short enough are returned whole. Non-finite values are skipped.
pub fn min_max(t: &[f64], y: &[f64], columns: usize) -> Vec<(f64, f64)> {
    let n = t.len().min(y.len());
    let mut d = MinMax::new(n, columns);
    for k in 0..n {
        d.push(t[k], y[k]);
    }
    d.finish()
}

/// [`min_max`] of a series given one point at a time, whose length `n` is known before:
/// memory holds the points kept, whatever `n`. Points past the `n`-th join the last run.
#[derive(Clone, Debug)]
pub struct MinMax {
    n: usize,
    columns: usize,
    whole: bool,
    k: usize,
    column: usize,
    column_end: usize,
    lo: Option<(f64, f64)>,
    hi: Option<(f64, f64)>,
    out: Vec<(f64, f64)>,
}

impl MinMax {
    /// For a series of `n` points drawn in `columns` columns.
    pub fn new(n: usize, columns: usize) -> Self {
        let whole = columns == 0 || n <= 2 * columns;
        Self {
            n,
            columns,
            whole,
            k: 0,
            column: 0,
            column_end: if whole { usize::MAX } else { n / columns },
            lo: None,
            hi: None,
            out: Vec::new(),
        }
    }

    /// The next point.
    pub fn push(&mut self, t: f64, y: f64) {
        if self.whole {
            if y.is_finite() {
                self.out.push((t, y));
            }
            return;
        }
        while self.k >= self.column_end && self.column + 1 < self.columns {
            self.flush();
            self.column += 1;
            self.column_end = (self.column + 1) * self.n / self.columns;
        }
        self.k += 1;
        if !y.is_finite() {
            return;
        }
        // Strict comparisons: the first of equal extremes is kept, as a scan would.
        if self.lo.is_none_or(|(_, v)| y < v) {
            self.lo = Some((t, y));
        }
        if self.hi.is_none_or(|(_, v)| y > v) {
            self.hi = Some((t, y));
        }
    }

    fn flush(&mut self) {
        match (self.lo.take(), self.hi.take()) {
            (Some(a), Some(b)) if a == b => self.out.push(a),
            (Some(a), Some(b)) => {
                // In time order; points are given in time order.
                let (first, second) = if a.0 <= b.0 { (a, b) } else { (b, a) };
                self.out.push(first);
                self.out.push(second);
            }
            _ => {}
        }
    }

    /// The points kept.
    pub fn finish(mut self) -> Vec<(f64, f64)> {
        self.flush();
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extremes_survive_and_the_count_is_bounded() {
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.002).collect();
        let mut y: Vec<f64> = (0..n).map(|k| (k as f64 * 0.01).sin()).collect();
        // One-sample spikes, as a shock would give.
        y[12_345] = 17.0;
        y[77_777] = -9.5;
        let d = min_max(&t, &y, 500);
        assert!(d.len() <= 1000, "{} points", d.len());
        let max = d.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let min = d.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        assert_eq!(max, 17.0);
        assert_eq!(min, -9.5);
        // The spikes keep their own times, and time never goes back.
        assert!(d.contains(&(t[12_345], 17.0)) && d.contains(&(t[77_777], -9.5)));
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn every_column_keeps_its_own_min_and_max() {
        let t: Vec<f64> = (0..40).map(f64::from).collect();
        let y: Vec<f64> = (0..40)
            .map(|k| if k % 2 == 0 { k as f64 } else { -(k as f64) })
            .collect();
        let d = min_max(&t, &y, 4);
        // Columns of 10 samples: max at the last even index, min at the last odd one.
        assert_eq!(
            d,
            vec![
                (8.0, 8.0),
                (9.0, -9.0),
                (18.0, 18.0),
                (19.0, -19.0),
                (28.0, 28.0),
                (29.0, -29.0),
                (38.0, 38.0),
                (39.0, -39.0)
            ]
        );
    }

    #[test]
    fn short_series_and_nan_are_handled() {
        assert_eq!(min_max(&[0.0, 1.0], &[1.0, f64::NAN], 10), vec![(0.0, 1.0)]);
        assert!(min_max(&[], &[], 10).is_empty());
    }
}
