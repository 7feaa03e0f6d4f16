//! The fleet view's statistics: quantiles, a distribution-free interval for a group's
//! median, and the Mann-Whitney test of whether two groups differ by more than chance.
//!
//! Exposures across missions are skewed (a few rough rides), so the view describes a
//! group by its median and quartiles and compares groups by ranks, not by means and a t
//! test. The median's interval comes from order statistics (the number of missions below
//! the true median is binomial, n and 1/2), so it holds whatever the distribution. The
//! Mann-Whitney U test is written here because no maintained crate offers it (`statrs`,
//! used for the binomial and normal distributions, has no hypothesis tests); it is checked
//! against SciPy's `mannwhitneyu` on two published-style samples below.

use serde::Serialize;
use statrs::distribution::{Binomial, ContinuousCDF as _, DiscreteCDF as _, Normal};

/// The `q`-quantile (0..=1) of sorted `values`, linear between order statistics (the
/// definition of R's type 7 and NumPy's default). `None` when empty.
pub fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let h = q.clamp(0.0, 1.0) * last as f64;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(last);
    Some(sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo]))
}

/// A group's distribution of one quantity over its missions, each number in the
/// quantity's unit (the key it is written under carries it: `"vdv_per_hour_m_s175": {..}`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Distribution {
    /// The missions (values) it is over.
    pub missions: usize,
    /// Smallest.
    pub min: f64,
    /// 10th percentile.
    pub p10: f64,
    /// First quartile.
    pub p25: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub p75: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
    /// The median's 95 % interval `[low, high]` (order statistics; at least 95 %
    /// coverage), null with fewer than 6 values (no pair of order statistics reaches 95 %).
    pub median_ci95: Option<[f64; 2]>,
}

impl Distribution {
    /// Of `values` (any order); `None` when empty or when a value is not finite.
    pub fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut s = values.to_vec();
        s.sort_by(f64::total_cmp);
        let q = |p| quantile(&s, p).unwrap_or(f64::NAN);
        Some(Self {
            missions: s.len(),
            min: s[0],
            p10: q(0.10),
            p25: q(0.25),
            median: q(0.5),
            p75: q(0.75),
            p90: q(0.90),
            max: s[s.len() - 1],
            mean: s.iter().sum::<f64>() / s.len() as f64,
            median_ci95: median_interval(&s, 0.95),
        })
    }
}

/// The ranks `(k, n + 1 - k)` (1-based) of the narrowest symmetric pair of order statistics
/// that covers the median with probability at least `level`; `None` when even the smallest
/// and largest do not.
pub fn median_interval_ranks(n: usize, level: f64) -> Option<(usize, usize)> {
    if n == 0 {
        return None;
    }
    let b = Binomial::new(0.5, n as u64).ok()?;
    // P(X_(k) <= median <= X_(n+1-k)) = P(k <= B <= n - k), B ~ Bin(n, 1/2).
    let coverage =
        |k: usize| b.cdf((n - k) as u64) - if k == 0 { 0.0 } else { b.cdf(k as u64 - 1) };
    let mut best = None;
    for k in 1..=n.div_ceil(2) {
        if n < 2 * k {
            break;
        }
        if coverage(k) >= level {
            best = Some((k, n + 1 - k));
        } else {
            break;
        }
    }
    best
}

/// The median's interval of sorted `values` at `level`.
pub fn median_interval(sorted: &[f64], level: f64) -> Option<[f64; 2]> {
    let (lo, hi) = median_interval_ranks(sorted.len(), level)?;
    Some([sorted[lo - 1], sorted[hi - 1]])
}

/// The Mann-Whitney U test of two samples.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MannWhitney {
    /// U of the first sample (the number of pairs in which its value is the larger, ties
    /// counting a half).
    pub u_statistic: f64,
    /// The normal approximation's z (tie-corrected variance, continuity correction).
    pub z_score: f64,
    /// Two-sided p-value.
    pub p_value: f64,
}

/// The two-sided Mann-Whitney U test of `a` against `b` (normal approximation with tie
/// correction and continuity correction, as SciPy's `mannwhitneyu(..., method=
/// "asymptotic")`). `None` when a sample is empty or every value is tied.
pub fn mann_whitney(a: &[f64], b: &[f64]) -> Option<MannWhitney> {
    let (n1, n2) = (a.len(), b.len());
    if n1 == 0 || n2 == 0 {
        return None;
    }
    let mut all: Vec<(f64, bool)> = a
        .iter()
        .map(|&v| (v, true))
        .chain(b.iter().map(|&v| (v, false)))
        .collect();
    all.sort_by(|x, y| x.0.total_cmp(&y.0));
    let n = all.len();
    let mut rank_sum_a = 0.0;
    let mut tie_term = 0.0;
    let mut i = 0;
    while i < n {
        let mut j = i + 1;
        while j < n && all[j].0 == all[i].0 {
            j += 1;
        }
        let t = (j - i) as f64;
        // Ranks i+1 ..= j share their mean.
        let rank = (i + 1 + j) as f64 / 2.0;
        rank_sum_a += rank * all[i..j].iter().filter(|(_, in_a)| *in_a).count() as f64;
        tie_term += t * t * t - t;
        i = j;
    }
    let (n1f, n2f, nf) = (n1 as f64, n2 as f64, n as f64);
    let u = rank_sum_a - n1f * (n1f + 1.0) / 2.0;
    let mean = n1f * n2f / 2.0;
    let variance = n1f * n2f / 12.0 * ((nf + 1.0) - tie_term / (nf * (nf - 1.0)));
    if variance <= 0.0 {
        return None;
    }
    let diff = (u - mean).abs();
    let z = ((diff - 0.5).max(0.0)) / variance.sqrt();
    let normal = Normal::standard();
    let p_value = (2.0 * (1.0 - normal.cdf(z))).min(1.0);
    Some(MannWhitney {
        u_statistic: u,
        z_score: if u >= mean { z } else { -z },
        p_value,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_numpys_default() {
        // numpy.percentile(d, [10, 25, 50, 75, 90]) = [0.9, 1.6, 2.8, 3.85, 5.9].
        let d = [3.1, 0.7, 2.2, 5.9, 1.4, 4.4, 2.8, 0.9, 3.3, 6.1, 1.8];
        let s = Distribution::of(&d).unwrap();
        for (got, want) in [s.p10, s.p25, s.median, s.p75, s.p90]
            .into_iter()
            .zip([0.9, 1.6, 2.8, 3.85, 5.9])
        {
            assert!((got - want).abs() < 1e-12, "{got} {want}");
        }
        // Coverage for n = 11 (scipy.stats.binom): k = 2 gives 0.98828125, k = 3 gives
        // 0.9345703125 < 0.95: the interval is the 2nd and the 10th values.
        assert_eq!(median_interval_ranks(11, 0.95), Some((2, 10)));
        assert_eq!(s.median_ci95, Some([0.9, 5.9]));
        // Five values cannot give 95 % (1 - 2/32 = 0.9375); six can (1 - 2/64).
        assert_eq!(median_interval_ranks(5, 0.95), None);
        assert_eq!(median_interval_ranks(6, 0.95), Some((1, 6)));
    }

    #[test]
    fn mann_whitney_matches_scipy() {
        // scipy.stats.mannwhitneyu(x, y, alternative="two-sided", method="asymptotic",
        // use_continuity=True): U = 58.0, p = 0.13291945818531892.
        let x = [1.83, 0.50, 1.62, 2.48, 1.68, 1.88, 1.55, 3.06, 1.30];
        let y = [0.878, 0.647, 0.598, 2.05, 1.06, 1.29, 1.06, 3.17, 1.29];
        let t = mann_whitney(&x, &y).unwrap();
        assert_eq!(t.u_statistic, 58.0);
        assert!((t.p_value - 0.132_919_458_185_318_92).abs() < 1e-9, "{t:?}");
        // With ties: U = 7.5, p = 0.006373133838085873.
        let x = [1.0, 2.0, 2.0, 3.0, 3.0, 3.0, 4.0, 5.0];
        let y = [3.0, 4.0, 4.0, 5.0, 5.0, 6.0, 7.0, 7.0, 8.0];
        let t = mann_whitney(&x, &y).unwrap();
        assert_eq!(t.u_statistic, 7.5);
        assert!(
            (t.p_value - 0.006_373_133_838_085_873).abs() < 1e-9,
            "{t:?}"
        );
        assert!(t.z_score < 0.0);
        assert!(mann_whitney(&[1.0], &[]).is_none());
        assert!(mann_whitney(&[1.0, 1.0], &[1.0]).is_none());
    }
}
