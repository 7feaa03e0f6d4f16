//! The geometric mean of complex transmissibilities across subjects (the paper's Eq. 2):
//! magnitude the geometric mean of the magnitudes, phase the arithmetic mean of the phases.
//!
//! The phase mean needs a branch for each subject's phase. Unwrapping each subject along
//! frequency and averaging breaks where a component passes near zero magnitude (the
//! unwrapped phase of one subject jumps by 2 pi); instead, per frequency, each subject's
//! phase is taken on the 2 pi branch nearest the circular mean c = arg(sum z/|z|), so the
//! mean phase is c + mean(wrap(phi_s - c)). Two subjects at +179 and -179 degrees average
//! to 180 degrees, not to 0.

use std::f64::consts::PI;

use nalgebra::Complex;
use supine_core::model::Transmissibility;

/// Wraps an angle into (-pi, pi], rad.
#[inline]
pub fn wrap_pi(angle_rad: f64) -> f64 {
    let wrapped = angle_rad - 2.0 * PI * (angle_rad / (2.0 * PI)).round();
    if wrapped <= -PI {
        wrapped + 2.0 * PI
    } else {
        wrapped
    }
}

/// The geometric mean of complex values: exp(mean ln|z|) at the mean phase on the branch
/// nearest the circular mean. Zero magnitudes give zero; an empty slice gives NaN.
///
/// When the unit phasors cancel exactly (no circular mean), the first value's phase is
/// the reference.
pub fn geometric_mean(values: &[Complex<f64>]) -> Complex<f64> {
    if values.is_empty() {
        return Complex::new(f64::NAN, f64::NAN);
    }
    let n = values.len() as f64;
    let log_magnitude = values.iter().map(|z| z.norm().ln()).sum::<f64>() / n;
    let phasor_sum: Complex<f64> = values
        .iter()
        .filter(|z| z.norm() > 0.0)
        .map(|z| z / z.norm())
        .sum();
    let reference = if phasor_sum.norm() > 1e-12 * n {
        phasor_sum.arg()
    } else {
        values[0].arg()
    };
    let phase = reference
        + values
            .iter()
            .map(|z| wrap_pi(z.arg() - reference))
            .sum::<f64>()
            / n;
    Complex::from_polar(log_magnitude.exp(), phase)
}

/// The component-wise geometric mean of several subjects' H on one frequency grid.
///
/// `subjects[s][f]` is subject s's H at frequency index f; every subject must have the same
/// number of frequencies (the caller checks).
pub fn geometric_mean_h(subjects: &[Vec<Transmissibility>]) -> Vec<Transmissibility> {
    let nf = subjects.first().map_or(0, Vec::len);
    let mut values = Vec::with_capacity(subjects.len());
    (0..nf)
        .map(|f| {
            Transmissibility::from_fn(|i, j| {
                values.clear();
                values.extend(subjects.iter().map(|s| s[f][(i, j)]));
                geometric_mean(&values)
            })
        })
        .collect()
}
