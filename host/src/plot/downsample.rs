//! Fewer points for long series, keeping what the eye must see: per pixel column, the
//! minimum and the maximum, in the order they occur, so that peaks and shocks keep their
//! full height however many samples share a column.

/// At most `2 * columns` points of `(t[k], y[k])`: for each of `columns` equal runs of
/// samples, its minimum and its maximum in time order (one point if they coincide). Series
/// already short enough are returned whole. Non-finite values are skipped.
pub fn min_max(t: &[f64], y: &[f64], columns: usize) -> Vec<(f64, f64)> {
    let n = t.len().min(y.len());
    if columns == 0 || n <= 2 * columns {
        return (0..n)
            .filter(|&k| y[k].is_finite())
            .map(|k| (t[k], y[k]))
            .collect();
    }
    let mut out = Vec::with_capacity(2 * columns);
    for c in 0..columns {
        let start = c * n / columns;
        let end = (c + 1) * n / columns;
        let mut lo: Option<usize> = None;
        let mut hi: Option<usize> = None;
        for k in start..end {
            if !y[k].is_finite() {
                continue;
            }
            if lo.is_none_or(|i| y[k] < y[i]) {
                lo = Some(k);
            }
            if hi.is_none_or(|i| y[k] > y[i]) {
                hi = Some(k);
            }
        }
        match (lo, hi) {
            (Some(a), Some(b)) if a == b => out.push((t[a], y[a])),
            (Some(a), Some(b)) => {
                let (first, second) = if a < b { (a, b) } else { (b, a) };
                out.push((t[first], y[first]));
                out.push((t[second], y[second]));
            }
            _ => {}
        }
    }
    out
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
