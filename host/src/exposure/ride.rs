//! Realistic litter-frame accelerations for demos and tests: ground ambulance on a paved
//! road, a rough road with potholes and speed bumps, a helicopter, and the laboratory's
//! random input. Every number comes from `docs/exposure.md#realistic-rides` or the paper's
//! experiment (`docs/model.md#laboratory-experiment`), and is a named constant below.
//!
//! # How a ride is made
//! - Stationary part, per axis: white Gaussian noise shaped in the frequency domain. Every
//!   FFT bin of the whole ride gets a complex Gaussian coefficient whose variance is the
//!   profile's power spectral density there (a sum of shaped components, each weighted so
//!   that it carries its own mean square); one inverse real FFT gives the time history,
//!   which is then scaled to the axis' exact rms. DC and the Nyquist bin stay zero.
//! - Shocks (rough road only): deterministic pulses added on top at the arrivals of a
//!   Poisson process of rate [`ROUGH_ROAD_SHOCKS_PER_S`], so that a short ride can have
//!   shocks too and their count varies as it does on a road: potholes (a damped sine at
//!   the wheel-hop frequency) and speed bumps (a half-sine up, then a longer half-sine
//!   down of equal area, so the frame ends at rest).
//! - Everything random comes from ChaCha8 seeded with `seed`, one stream per axis and one
//!   for the shocks: the same seed, duration and rate give the same file, byte for byte.
//!
//! Axes are the litter's: x longitudinal (along the litter, the vehicle's fore-aft when
//! the litter is mounted lengthwise), y lateral, z vertical.
//!
//! # File
//! [`write_ride`] writes the time and the three platform columns only
//! ([`PLATFORM_HEADER_LINE`]): a generated ride has no sensor data, and
//! the recording reader requires every one of its 13 cells to be a number, so the sensor
//! columns are absent rather than empty or invented. `supine exposure` reads such a file.

use std::f64::consts::PI;
use std::io::Write as _;
use std::path::Path;

use anyhow::{Result, anyhow, bail};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::RealFftPlanner;
use realfft::num_complex::Complex;
use serde::Serialize;
use supine_core::sample_rate::{SampleRate, SampleRateError};

use crate::io::output::write_atomically;
use crate::io::recording::{PLATFORM_HEADER_LINE, device_samples};

// ---- Ground ambulance, paved road -------------------------------------------------------

/// Vertical rms of the litter frame in a ground ambulance on a smooth paved road, m/s^2.
/// exposure.md: 0.3-1 m/s^2 rms on paved roads; a smooth road sits at the low end.
pub const AMBULANCE_VERTICAL_RMS_M_S2: f64 = 0.3;
/// Lateral and fore-aft rms as a fraction of the vertical (exposure.md: about 0.3-0.6).
pub const AMBULANCE_HORIZONTAL_RATIO: f64 = 0.35;
/// Peak of the floor's acceleration spectrum (vehicle body bounce), Hz. exposure.md: the
/// most critical band is 1.5-4 Hz.
pub const AMBULANCE_PEAK_HZ: f64 = 2.5;
/// Damping ratio of that resonance (a broad peak, half-power band about 1.7-3.3 Hz).
pub const AMBULANCE_DAMPING_RATIO: f64 = 0.35;
/// Above this frequency the spectrum falls by a further f^-8, Hz. exposure.md: energy mostly
/// below 10 Hz.
pub const AMBULANCE_ROLLOFF_HZ: f64 = 10.0;

// ---- Rough or field road -------------------------------------------------------------------

/// Vertical rms of the stationary (broadband) part on a rough road, m/s^2, before shocks.
/// exposure.md: 0.6-5.9 m/s^2 rms measured on supine subjects in army medical vehicles.
pub const ROUGH_ROAD_VERTICAL_RMS_M_S2: f64 = 1.0;
/// Lateral and fore-aft rms as a fraction of the vertical (rolling and pitching on an
/// uneven road: the upper end of the 0.3-0.6 in exposure.md).
pub const ROUGH_ROAD_HORIZONTAL_RATIO: f64 = 0.55;
/// Body-bounce peak on a rough road, Hz (within the 1.5-4 Hz band of ground vehicles).
pub const ROUGH_ROAD_PEAK_HZ: f64 = 2.0;
/// Damping ratio of the body bounce on a rough road.
pub const ROUGH_ROAD_DAMPING_RATIO: f64 = 0.4;
/// Roll-off corner of the body-bounce component, Hz (rough roads carry energy higher up).
pub const ROUGH_ROAD_ROLLOFF_HZ: f64 = 20.0;
/// Wheel-hop resonance excited by a rough surface, Hz.
pub const ROUGH_ROAD_WHEEL_HOP_HZ: f64 = 11.0;
/// Damping ratio of the wheel hop.
pub const ROUGH_ROAD_WHEEL_HOP_DAMPING_RATIO: f64 = 0.2;
/// Share of the stationary rms in the wheel hop (its rms over the body bounce's).
pub const ROUGH_ROAD_WHEEL_HOP_RATIO: f64 = 0.35;
/// Rate of shocks (potholes and speed bumps) on a rough road, per second: six a minute.
/// exposure.md says shocks give crest factors above 9 but gives no rate; this is the
/// project's choice for a field road, often enough that a 10 s ride has one in about 60 %
/// of seeds and that a minute carries several. Arrivals are a Poisson process counted
/// from the end of the previous pulse (pulses never overlap), so the mean spacing is
/// `1 / rate` plus a pulse (about 0.43 s).
pub const ROUGH_ROAD_SHOCKS_PER_S: f64 = 0.1;
/// Probability that a shock is a pothole (otherwise a speed bump).
pub const POTHOLE_PROBABILITY: f64 = 0.5;
/// Pothole: amplitude `A` of the vertical damped sine `-A exp(-t/tau) sin(2 pi f t)`,
/// m/s^2 (its largest excursion is about 0.64 A = 16 m/s^2, 1.6 g: a wheel dropping into
/// and striking out of a hole, as seen on the frame).
pub const POTHOLE_AMPLITUDE_M_S2: f64 = 25.0;
/// Pothole ringing frequency (the wheel hop), Hz.
pub const POTHOLE_FREQUENCY_HZ: f64 = 10.0;
/// Pothole decay time constant `tau`, s.
pub const POTHOLE_DECAY_S: f64 = 0.05;
/// Speed bump: peak of the upward half-sine as the wheel climbs, m/s^2 (1.4 g).
pub const SPEED_BUMP_PEAK_M_S2: f64 = 14.0;
/// Speed bump: duration of the upward half-sine, s.
pub const SPEED_BUMP_RISE_S: f64 = 0.1;
/// Speed bump: duration of the downward half-sine as the frame settles, s (its peak is
/// `SPEED_BUMP_PEAK_M_S2 * RISE / SETTLE`, so the two areas cancel: no net velocity).
pub const SPEED_BUMP_SETTLE_S: f64 = 0.3;
/// Fore-aft (x) shock as a fraction of the vertical (pitch of the vehicle on the impact).
pub const SHOCK_FORE_AFT_RATIO: f64 = 0.3;
/// Lateral (y) shock as a fraction of the vertical (one wheel at a time rolls the body).
pub const SHOCK_LATERAL_RATIO: f64 = 0.15;

// ---- Helicopter ------------------------------------------------------------------------

/// Main-rotor blade-passage frequency, Hz. exposure.md: peaks at 17-17.5 Hz (HH-60M: four
/// blades at about 4.3 rev/s).
pub const HELICOPTER_BLADE_PASSAGE_HZ: f64 = 17.25;
/// Main-rotor blades (HH-60M): the rotor turns at blade passage / blades.
pub const HELICOPTER_BLADES: u32 = 4;
/// Vertical rms of the once-per-revolution line (4.31 Hz: rotor imbalance and blade
/// tracking), m/s^2. exposure.md names only blade passage and its harmonics; a small 1/rev
/// line is the project's choice of a typical main-rotor signature, kept well below the
/// blade-passage line. It lies in the body's sensitive 4-8 Hz band.
pub const HELICOPTER_ONCE_PER_REV_RMS_M_S2: f64 = 0.1;
/// Width (standard deviation) of each blade-passage line, Hz (rotor speed wander).
pub const HELICOPTER_LINE_WIDTH_HZ: f64 = 0.05;
/// Vertical rms of the blade-passage line and its 2nd and 3rd harmonics, m/s^2
/// ("harmonics over a broadband floor", falling with order).
pub const HELICOPTER_LINE_RMS_M_S2: [f64; 3] = [0.45, 0.2, 0.1];
/// Vertical rms of the broadband floor, m/s^2. With the lines, the vertical rms is
/// sqrt(0.1^2 + 0.45^2 + 0.2^2 + 0.1^2 + 0.25^2) = 0.57 m/s^2: exposure.md gives 0.2-1 m/s^2.
pub const HELICOPTER_FLOOR_RMS_M_S2: f64 = 0.25;
/// Band of the broadband floor (second-order edges), Hz.
pub const HELICOPTER_FLOOR_BAND_HZ: (f64, f64) = (1.0, 80.0);
/// Lateral and fore-aft rms as a fraction of the vertical.
pub const HELICOPTER_HORIZONTAL_RATIO: f64 = 0.5;

// ---- Laboratory ----------------------------------------------------------------------------

/// The paper's laboratory input: white random vibration in this band, Hz
/// (docs/model.md#laboratory-experiment).
pub const LAB_BAND_HZ: (f64, f64) = (0.5, 16.0);
/// The laboratory input's rms, m/s^2, of the vector magnitude (0.5 m/s^2,
/// docs/model.md#laboratory-experiment), so each of the three independent axes carries
/// 0.5 / sqrt 3.
pub const LAB_VECTOR_RMS_M_S2: f64 = 0.5;

// ---- Common ----------------------------------------------------------------------------------

/// Ground vehicles: below this the floor spectrum falls as f^4 (second-order high-pass),
/// Hz: the slow heave of driving over hills is not vibration and not what the litter feels.
pub const ROAD_HIGHPASS_HZ: f64 = 0.5;
/// Longest ride in samples (2^24: 9.3 h at 500 Hz).
pub const MAX_SAMPLES: usize = 1 << 24;
/// Shortest ride, s.
pub const MIN_DURATION_S: f64 = 1.0;

/// The ride profiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Profile {
    /// Ground ambulance on a paved road: 1.5-4 Hz, vertical dominant, 0.3 m/s^2 vertical.
    Ambulance,
    /// Rough or field road: broadband 1 m/s^2 vertical plus potholes and speed bumps.
    RoughRoad,
    /// Helicopter: 1/rev at 4.31 Hz, blade passage at 17.25 Hz and its 2nd and 3rd
    /// harmonics over a broadband floor.
    Helicopter,
    /// The laboratory's 0.5-16 Hz white random input, 0.5 m/s^2 vector rms.
    Lab,
}

impl Profile {
    /// All profiles.
    pub const ALL: [Profile; 4] = [
        Profile::Ambulance,
        Profile::RoughRoad,
        Profile::Helicopter,
        Profile::Lab,
    ];

    /// The name the command line uses.
    pub const fn name(self) -> &'static str {
        match self {
            Profile::Ambulance => "ambulance",
            Profile::RoughRoad => "rough-road",
            Profile::Helicopter => "helicopter",
            Profile::Lab => "lab",
        }
    }

    /// The stationary part's components, each with its rms per axis (x, y, z), m/s^2.
    pub fn components(self) -> Vec<Component> {
        let axes = |vertical: f64, ratio: f64| [ratio * vertical, ratio * vertical, vertical];
        match self {
            Profile::Ambulance => vec![Component {
                shape: Shape::Road {
                    peak_hz: AMBULANCE_PEAK_HZ,
                    damping_ratio: AMBULANCE_DAMPING_RATIO,
                    rolloff_hz: AMBULANCE_ROLLOFF_HZ,
                },
                rms_m_s2: axes(AMBULANCE_VERTICAL_RMS_M_S2, AMBULANCE_HORIZONTAL_RATIO),
            }],
            Profile::RoughRoad => {
                // Body bounce and wheel hop share the stationary mean square.
                let r = ROUGH_ROAD_WHEEL_HOP_RATIO;
                let body = ROUGH_ROAD_VERTICAL_RMS_M_S2 / (1.0 + r * r).sqrt();
                vec![
                    Component {
                        shape: Shape::Road {
                            peak_hz: ROUGH_ROAD_PEAK_HZ,
                            damping_ratio: ROUGH_ROAD_DAMPING_RATIO,
                            rolloff_hz: ROUGH_ROAD_ROLLOFF_HZ,
                        },
                        rms_m_s2: axes(body, ROUGH_ROAD_HORIZONTAL_RATIO),
                    },
                    Component {
                        shape: Shape::Road {
                            peak_hz: ROUGH_ROAD_WHEEL_HOP_HZ,
                            damping_ratio: ROUGH_ROAD_WHEEL_HOP_DAMPING_RATIO,
                            rolloff_hz: ROUGH_ROAD_ROLLOFF_HZ,
                        },
                        rms_m_s2: axes(body * r, ROUGH_ROAD_HORIZONTAL_RATIO),
                    },
                ]
            }
            Profile::Helicopter => {
                let mut c: Vec<Component> = HELICOPTER_LINE_RMS_M_S2
                    .iter()
                    .enumerate()
                    .map(|(h, &rms)| Component {
                        shape: Shape::Line {
                            centre_hz: HELICOPTER_BLADE_PASSAGE_HZ * (h + 1) as f64,
                            width_hz: HELICOPTER_LINE_WIDTH_HZ,
                        },
                        rms_m_s2: axes(rms, HELICOPTER_HORIZONTAL_RATIO),
                    })
                    .collect();
                c.push(Component {
                    shape: Shape::Line {
                        centre_hz: HELICOPTER_BLADE_PASSAGE_HZ / f64::from(HELICOPTER_BLADES),
                        width_hz: HELICOPTER_LINE_WIDTH_HZ,
                    },
                    rms_m_s2: axes(
                        HELICOPTER_ONCE_PER_REV_RMS_M_S2,
                        HELICOPTER_HORIZONTAL_RATIO,
                    ),
                });
                c.push(Component {
                    shape: Shape::Floor {
                        band_hz: HELICOPTER_FLOOR_BAND_HZ,
                    },
                    rms_m_s2: axes(HELICOPTER_FLOOR_RMS_M_S2, HELICOPTER_HORIZONTAL_RATIO),
                });
                c
            }
            Profile::Lab => vec![Component {
                shape: Shape::Band {
                    band_hz: LAB_BAND_HZ,
                },
                rms_m_s2: [LAB_VECTOR_RMS_M_S2 / 3f64.sqrt(); 3],
            }],
        }
    }
}

/// The spectral shape of one component (relative power spectral density).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Shape {
    /// A vehicle floor: second-order high-pass at [`ROAD_HIGHPASS_HZ`], a resonance at
    /// `peak_hz` (`1 / ((1 - r^2)^2 + (2 zeta r)^2)`, `r = f / peak_hz`), and a further
    /// `1 / (1 + (f / rolloff_hz)^8)`.
    Road {
        /// Resonance frequency, Hz.
        peak_hz: f64,
        /// Damping ratio zeta.
        damping_ratio: f64,
        /// Roll-off corner, Hz.
        rolloff_hz: f64,
    },
    /// A narrow line: a Gaussian of standard deviation `width_hz` about `centre_hz`.
    Line {
        /// Centre, Hz.
        centre_hz: f64,
        /// Standard deviation, Hz.
        width_hz: f64,
    },
    /// A broadband floor with second-order edges (high-pass and low-pass) at `band_hz`.
    Floor {
        /// Edges, Hz.
        band_hz: (f64, f64),
    },
    /// Flat inside `band_hz`, nothing outside (the laboratory's white random input).
    Band {
        /// Edges, Hz.
        band_hz: (f64, f64),
    },
}

impl Shape {
    /// Relative power spectral density at `f_hz` (any scale; only ratios matter).
    pub fn psd(&self, f_hz: f64) -> f64 {
        let hp2 = |f: f64, fc: f64| {
            let r4 = (f / fc).powi(4);
            r4 / (1.0 + r4)
        };
        match *self {
            Shape::Road {
                peak_hz,
                damping_ratio,
                rolloff_hz,
            } => {
                let r = f_hz / peak_hz;
                let resonance = 1.0 / ((1.0 - r * r).powi(2) + (2.0 * damping_ratio * r).powi(2));
                hp2(f_hz, ROAD_HIGHPASS_HZ) * resonance / (1.0 + (f_hz / rolloff_hz).powi(8))
            }
            Shape::Line {
                centre_hz,
                width_hz,
            } => (-0.5 * ((f_hz - centre_hz) / width_hz).powi(2)).exp(),
            Shape::Floor { band_hz: (lo, hi) } => hp2(f_hz, lo) / (1.0 + (f_hz / hi).powi(4)),
            Shape::Band { band_hz: (lo, hi) } => {
                if (lo..=hi).contains(&f_hz) {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// One spectral component of a profile, with its rms on each axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Component {
    /// Its spectral shape.
    pub shape: Shape,
    /// Its rms on x, y, z, m/s^2.
    pub rms_m_s2: [f64; 3],
}

/// Which kind of shock.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShockKind {
    /// A damped sine at the wheel hop, downward first.
    Pothole,
    /// A half-sine up, then a half-sine down of equal area.
    SpeedBump,
}

/// A shock event in a ride.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Shock {
    /// Start time, s.
    pub time_s: f64,
    /// Kind.
    pub kind: ShockKind,
}

impl ShockKind {
    /// How long the pulse lasts (a pothole: until its envelope is below 0.01 %), s.
    pub fn duration_s(self) -> f64 {
        match self {
            ShockKind::Pothole => 9.2 * POTHOLE_DECAY_S,
            ShockKind::SpeedBump => SPEED_BUMP_RISE_S + SPEED_BUMP_SETTLE_S,
        }
    }

    /// The vertical pulse at `t_s` after its start, m/s^2 (0 outside the pulse).
    pub fn vertical_m_s2(self, t_s: f64) -> f64 {
        if !(0.0..self.duration_s()).contains(&t_s) {
            return 0.0;
        }
        match self {
            ShockKind::Pothole => {
                -POTHOLE_AMPLITUDE_M_S2
                    * (-t_s / POTHOLE_DECAY_S).exp()
                    * (2.0 * PI * POTHOLE_FREQUENCY_HZ * t_s).sin()
            }
            ShockKind::SpeedBump => {
                if t_s < SPEED_BUMP_RISE_S {
                    SPEED_BUMP_PEAK_M_S2 * (PI * t_s / SPEED_BUMP_RISE_S).sin()
                } else {
                    let u = t_s - SPEED_BUMP_RISE_S;
                    -SPEED_BUMP_PEAK_M_S2 * SPEED_BUMP_RISE_S / SPEED_BUMP_SETTLE_S
                        * (PI * u / SPEED_BUMP_SETTLE_S).sin()
                }
            }
        }
    }
}

/// A generated ride: the litter frame's acceleration, uniformly sampled from t = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Ride {
    /// The profile.
    pub profile: Profile,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Seed of the random draws.
    pub seed: u64,
    /// Litter-frame acceleration x, y, z, m/s^2.
    pub platform_m_s2: [Vec<f64>; 3],
    /// The stationary part's rms per axis (before shocks), m/s^2.
    pub stationary_rms_m_s2: [f64; 3],
    /// Shock events, in time order.
    pub shocks: Vec<Shock>,
}

impl Ride {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.platform_m_s2[2].len()
    }

    /// Whether the ride has no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The samples a device is streamed ([`device_samples`]).
    pub fn samples(&self) -> Vec<[f32; 3]> {
        device_samples(&self.platform_m_s2)
    }

    /// Unweighted rms of each axis, m/s^2.
    pub fn rms_m_s2(&self) -> [f64; 3] {
        self.platform_m_s2
            .each_ref()
            .map(|x| (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt())
    }

    /// Largest |z| over the rms of z (0 for a still ride): shocks raise it above 9.
    pub fn vertical_crest_factor(&self) -> f64 {
        let rms_z = self.rms_m_s2()[2];
        let peak_z = self.platform_m_s2[2]
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        if rms_z > 0.0 { peak_z / rms_z } else { 0.0 }
    }
}

/// One axis' stationary part: `n` samples at `fs_hz` with the components' rms on `axis`.
/// Components with no FFT bin in their band (e.g. a line above Nyquist) are left out.
fn stationary_axis(
    components: &[Component],
    axis: usize,
    n: usize,
    fs_hz: f64,
    rng: &mut ChaCha8Rng,
) -> Result<(Vec<f64>, f64)> {
    let bins = n / 2 + 1;
    let df_hz = fs_hz / n as f64;
    // Inside bins: 1..n/2 without the Nyquist bin (it must be real).
    let inside = |k: usize| k > 0 && 2 * k != n;
    let mut variance = vec![0.0f64; bins];
    let mut target_ms = 0.0;
    for c in components {
        let shape: Vec<f64> = (0..bins)
            .map(|k| {
                if inside(k) {
                    c.shape.psd(k as f64 * df_hz)
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = shape.iter().sum();
        let rms = c.rms_m_s2[axis];
        if total > 0.0 && rms > 0.0 {
            let w = rms * rms / total;
            for (v, s) in variance.iter_mut().zip(&shape) {
                *v += w * s;
            }
            target_ms += rms * rms;
        }
    }
    if target_ms == 0.0 {
        bail!("the ride is too short or too coarsely sampled for any of its spectrum");
    }
    let mut spectrum: Vec<Complex<f64>> = variance
        .iter()
        .map(|&v| {
            let s = v.sqrt();
            let re: f64 = StandardNormal.sample(rng);
            let im: f64 = StandardNormal.sample(rng);
            Complex::new(s * re, s * im)
        })
        .collect();
    let inverse = RealFftPlanner::<f64>::new().plan_fft_inverse(n);
    let mut signal = vec![0.0; n];
    inverse
        .process(&mut spectrum, &mut signal)
        .map_err(|e| anyhow!("inverse FFT: {e}"))?;
    let ms = signal.iter().map(|x| x * x).sum::<f64>() / n as f64;
    let target = target_ms.sqrt();
    let scale = if ms > 0.0 { target / ms.sqrt() } else { 0.0 };
    for x in &mut signal {
        *x *= scale;
    }
    Ok((signal, target))
}

/// Shock times and kinds for a ride of `duration_s`: a Poisson process of rate
/// [`ROUGH_ROAD_SHOCKS_PER_S`] (exponential waits, each from the end of the previous
/// pulse), a pothole with [`POTHOLE_PROBABILITY`], else a speed bump. Only shocks whose
/// whole pulse fits in the ride are kept.
pub fn draw_shocks(duration_s: f64, rng: &mut ChaCha8Rng) -> Vec<Shock> {
    let mut shocks = Vec::new();
    let mut free_from_s = 0.0;
    loop {
        // Inverse transform: -ln(U) / rate for U in (0, 1].
        let u = 1.0 - rng.random::<f64>();
        let time_s = free_from_s - u.ln() / ROUGH_ROAD_SHOCKS_PER_S;
        let kind = if rng.random_bool(POTHOLE_PROBABILITY) {
            ShockKind::Pothole
        } else {
            ShockKind::SpeedBump
        };
        if time_s + kind.duration_s() > duration_s {
            return shocks;
        }
        shocks.push(Shock { time_s, kind });
        free_from_s = time_s + kind.duration_s();
    }
}

/// Generates a ride of `duration_s` at `sample_rate_hz` (a rate the device supports) for
/// `seed`.
pub fn generate(profile: Profile, duration_s: f64, sample_rate_hz: f64, seed: u64) -> Result<Ride> {
    if !SampleRate::supports_hz(sample_rate_hz) {
        bail!("--fs {sample_rate_hz}: {SampleRateError}");
    }
    if !(duration_s.is_finite() && duration_s >= MIN_DURATION_S) {
        bail!("--duration-s {duration_s}: expected at least {MIN_DURATION_S} s");
    }
    let n_f = (duration_s * sample_rate_hz).round();
    if n_f > MAX_SAMPLES as f64 {
        bail!(
            "--duration-s {duration_s} at {sample_rate_hz} Hz: {n_f} samples, expected at most {MAX_SAMPLES}"
        );
    }
    let n = n_f as usize;
    let components = profile.components();
    let mut platform: [Vec<f64>; 3] = Default::default();
    let mut stationary_rms_m_s2 = [0.0; 3];
    for (axis, out) in platform.iter_mut().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(axis as u64);
        let (signal, rms) = stationary_axis(&components, axis, n, sample_rate_hz, &mut rng)?;
        *out = signal;
        stationary_rms_m_s2[axis] = rms;
    }
    let shocks = if profile == Profile::RoughRoad {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(3);
        draw_shocks(n as f64 / sample_rate_hz, &mut rng)
    } else {
        Vec::new()
    };
    let ratios = [SHOCK_FORE_AFT_RATIO, SHOCK_LATERAL_RATIO, 1.0];
    for shock in &shocks {
        let first = (shock.time_s * sample_rate_hz).ceil() as usize;
        let last = ((shock.time_s + shock.kind.duration_s()) * sample_rate_hz).ceil() as usize;
        for k in first..last.min(n) {
            let a = shock
                .kind
                .vertical_m_s2(k as f64 / sample_rate_hz - shock.time_s);
            for (axis, ratio) in platform.iter_mut().zip(ratios) {
                axis[k] += ratio * a;
            }
        }
    }
    Ok(Ride {
        profile,
        sample_rate_hz,
        seed,
        platform_m_s2: platform,
        stationary_rms_m_s2,
        shocks,
    })
}

/// Writes `ride` as CSV ([`PLATFORM_HEADER_LINE`]; time as `k / fs` in shortest
/// round-trip form, accelerations to 1e-6 m/s^2), complete or not at all.
pub fn write_ride(path: &Path, ride: &Ride) -> Result<()> {
    write_atomically(path, |w| {
        writeln!(w, "{PLATFORM_HEADER_LINE}")?;
        let [x, y, z] = &ride.platform_m_s2;
        for k in 0..ride.len() {
            writeln!(
                w,
                "{},{:.6},{:.6},{:.6}",
                k as f64 / ride.sample_rate_hz,
                x[k],
                y[k],
                z[k]
            )?;
        }
        Ok(())
    })
}
