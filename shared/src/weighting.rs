//! ISO 2631-1 / ISO 8041 frequency weightings Wk, Wd and Wj as cascaded second-order
//! sections, for any supported sample rate ([`SampleRate`]: 100 Hz to 2 kHz).
//!
//! # The analog definition
//! Each weighting is the product of four sections (`s = j 2 pi f`, `w_i = 2 pi f_i`):
//! - band-limiting high-pass `s^2 / (s^2 + s w1/Q1 + w1^2)`,
//! - band-limiting low-pass `w2^2 / (s^2 + s w2/Q2 + w2^2)`,
//! - acceleration-velocity transition `K (1 + s/w3) / (1 + s/(Q4 w4) + s^2/w4^2)`,
//! - upward step `(s^2 + s w5/Q5 + w5^2) / (s^2 + s w6/Q6 + w6^2)`, whose
//!   gain is `1` at high frequency and `(w5/w6)^2` at DC.
//!
//! [`analog_response`] evaluates that product in f64; it is the authority that the
//! discrete filters are tested against.
//!
//! # The discretization (the choice, and why)
//! - The 0.4 Hz high-pass is the bilinear transform prewarped at `f1`, realized as a
//!   topology-preserving state-variable filter ([`HighPassSvf`]). In f32 a direct-form
//!   biquad cannot hold a 0.4 Hz pole pair at 2 kHz: its `a1` is `-2 + 1.6e-6`, so one
//!   f32 rounding step of `a1` (1.2e-7) moves the pole angle squared by about 15 %. The SVF
//!   stores `g = tan(pi f1/fs)` (6.3e-4 at 2 kHz) with full relative precision instead,
//!   and its states do not amplify rounding noise by `1/(1 + a1 + a2)`.
//! - The other sections (low-pass, transition, upward step) are "magnitude-matched"
//!   biquads (M. Vicanek, *Matched second order digital filters*, 2016): the poles are
//!   the exact images `z = exp(p / fs)` of the analog poles, and the numerator is the
//!   minimum-phase quadratic whose squared magnitude equals the analog one at DC, at the
//!   Nyquist frequency and at one frequency in between (the section's own frequency,
//!   capped at fs/4; for the low-pass, capped at fs/3). Unlike the bilinear transform
//!   this puts no zero at Nyquist, so the 100 Hz low-pass and the 1/f roll-off of the
//!   transition section keep their analog magnitude up to fs/2. The price is a phase
//!   that departs from the analog one near Nyquist; ISO 8041 tolerances are on
//!   magnitude, and the rms and VDV do not depend on phase for stationary signals.
//!   These run as transposed direct form II in f32 ([`Biquad`]), well-conditioned here
//!   because their poles are at 2 Hz or above.
//!
//! Measured deviation of the f32 filters from the analog magnitude over 0.5-80 Hz
//! (tests `deviation_*`): 2.8 % at 500 Hz, 0.8 % at 1 kHz, 0.2 % at 2 kHz (largest
//! near 80 Hz). At 200 Hz: 8.6 % up to 63.1 Hz and 14 % at 80 Hz, inside the ISO 8041
//! tolerances (+12/-11 % to 63.1 Hz, +26/-21 % above), so 200 Hz meets ISO 8041 over
//! the whole 0.5-80 Hz. Below fs = 200 Hz the band-limiting low-pass lies above
//! Nyquist: the discrete filter then follows the analog magnitude up to fs/2 (exactly
//! at DC, fs/3 and fs/2), and everything above fs/2 must be removed by the sensor's
//! anti-alias filter before sampling.

use core::cmp::Ordering;
use core::fmt;

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::gain_bound::{Amplification, Recursion2};
use crate::sample_rate::SampleRate;

const TAU: f64 = 2.0 * core::f64::consts::PI;
const Q_BAND: f64 = core::f64::consts::FRAC_1_SQRT_2;

/// Which ISO 2631-1 frequency weighting.
///
/// Serialized by its [`name`](Self::name) in a human-readable format (a parameter file's
/// `kind = "wd"`, read in either case, `"Wd"` too) and by its variant index in the blob
/// (postcard), exactly as a derived enum: the device's decoding is the derived one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WeightingKind {
    /// Wk: vertical; recumbent persons, vertical under the pelvis.
    Wk,
    /// Wd: horizontal; recumbent persons, both horizontal axes.
    Wd,
    /// Wj: recumbent persons, vertical under the head.
    Wj,
}

impl WeightingKind {
    /// All three weightings, for iteration in tests and tools.
    pub const ALL: [WeightingKind; 3] = [WeightingKind::Wk, WeightingKind::Wd, WeightingKind::Wj];

    /// The ISO 8041 parameters of this weighting (frequencies in Hz).
    pub const fn params(self) -> AnalogParams {
        match self {
            WeightingKind::Wk => AnalogParams {
                f1_hz: 0.4,
                f2_hz: 100.0,
                transition: Some(Transition {
                    f3_hz: 12.5,
                    f4_hz: 12.5,
                    q4: 0.63,
                }),
                step: Some(UpwardStep {
                    f5_hz: 2.37,
                    q5: 0.91,
                    f6_hz: 3.35,
                    q6: 0.91,
                }),
                gain: 1.0,
            },
            WeightingKind::Wd => AnalogParams {
                f1_hz: 0.4,
                f2_hz: 100.0,
                transition: Some(Transition {
                    f3_hz: 2.0,
                    f4_hz: 2.0,
                    q4: 0.63,
                }),
                step: None,
                gain: 1.0,
            },
            WeightingKind::Wj => AnalogParams {
                f1_hz: 0.4,
                f2_hz: 100.0,
                transition: None,
                step: Some(UpwardStep {
                    f5_hz: 3.75,
                    q5: 0.91,
                    f6_hz: 5.32,
                    q6: 0.91,
                }),
                gain: 1.0,
            },
        }
    }

    /// Lower-case name as used on the command line (`wk`, `wd`, `wj`).
    pub const fn name(self) -> &'static str {
        match self {
            WeightingKind::Wk => "wk",
            WeightingKind::Wd => "wd",
            WeightingKind::Wj => "wj",
        }
    }
}

impl fmt::Display for WeightingKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The blob's form of [`WeightingKind`]: the derived variant-index encoding, unchanged since
/// blob format 1, so the device's decoder stays the derived one.
#[derive(Serialize, Deserialize)]
#[serde(rename = "WeightingKind")]
enum Indexed {
    Wk,
    Wd,
    Wj,
}

impl Serialize for WeightingKind {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            return s.serialize_str(self.name());
        }
        match self {
            WeightingKind::Wk => Indexed::Wk,
            WeightingKind::Wd => Indexed::Wd,
            WeightingKind::Wj => Indexed::Wj,
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for WeightingKind {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        if d.is_human_readable() {
            return d.deserialize_str(NameVisitor);
        }
        Ok(match Indexed::deserialize(d)? {
            Indexed::Wk => WeightingKind::Wk,
            Indexed::Wd => WeightingKind::Wd,
            Indexed::Wj => WeightingKind::Wj,
        })
    }
}

/// Reads a weighting's name in either case (`wd`, `Wd`, `WD`), white space around it
/// ignored.
struct NameVisitor;

impl Visitor<'_> for NameVisitor {
    type Value = WeightingKind;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("one of wk, wd, wj (either case)")
    }

    fn visit_str<E: de::Error>(self, text: &str) -> Result<WeightingKind, E> {
        WeightingKind::ALL
            .into_iter()
            .find(|w| w.name().eq_ignore_ascii_case(text.trim()))
            .ok_or_else(|| {
                // At most 40 characters of what was written, escaped: one line.
                let end = text.char_indices().nth(40).map_or(text.len(), |(i, _)| i);
                E::custom(format_args!(
                    "expected one of wk, wd, wj (either case), found {:?}",
                    &text[..end]
                ))
            })
    }
}

/// Acceleration-velocity transition parameters (ISO 8041 Table; Hz, dimensionless Q).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition {
    /// Numerator corner `f3`, Hz.
    pub f3_hz: f64,
    /// Denominator resonance `f4`, Hz.
    pub f4_hz: f64,
    /// Denominator quality factor `Q4`.
    pub q4: f64,
}

/// Upward-step parameters (ISO 8041 Table; Hz, dimensionless Q).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpwardStep {
    /// Numerator resonance `f5`, Hz.
    pub f5_hz: f64,
    /// Numerator quality factor `Q5`.
    pub q5: f64,
    /// Denominator resonance `f6`, Hz.
    pub f6_hz: f64,
    /// Denominator quality factor `Q6`.
    pub q6: f64,
}

/// The analog definition of one weighting (ISO 8041 parameter table); `Q1 = Q2 = 1/sqrt 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalogParams {
    /// Band-limiting high-pass corner `f1`, Hz.
    pub f1_hz: f64,
    /// Band-limiting low-pass corner `f2`, Hz.
    pub f2_hz: f64,
    /// Transition section, `None` when `f3 = f4 = inf`.
    pub transition: Option<Transition>,
    /// Upward step, `None` when `f5 = f6 = inf`.
    pub step: Option<UpwardStep>,
    /// Overall gain `K`.
    pub gain: f64,
}

/// A complex number in f64, just enough arithmetic for frequency responses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Complex64 {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex64 {
    /// `re + j im`.
    pub const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    /// The number 1.
    pub const ONE: Complex64 = Complex64::new(1.0, 0.0);
    /// Magnitude `|z|`.
    pub fn abs(self) -> f64 {
        libm::hypot(self.re, self.im)
    }
    /// Phase `arg z`, radians in (-pi, pi].
    pub fn arg(self) -> f64 {
        libm::atan2(self.im, self.re)
    }
    /// `e^(j theta)`.
    pub fn from_angle(theta_rad: f64) -> Self {
        Self::new(libm::cos(theta_rad), libm::sin(theta_rad))
    }
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn div(self, o: Self) -> Self {
        let d = o.re * o.re + o.im * o.im;
        Self::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    fn scale(self, k: f64) -> Self {
        Self::new(self.re * k, self.im * k)
    }
}

impl core::ops::Mul for Complex64 {
    type Output = Complex64;
    fn mul(self, o: Self) -> Self {
        Complex64::mul(self, o)
    }
}

impl core::ops::Div for Complex64 {
    type Output = Complex64;
    fn div(self, o: Self) -> Self {
        Complex64::div(self, o)
    }
}

/// An analog second-order section `(n2 s^2 + n1 s + n0) / (d2 s^2 + d1 s + d0)`, s in rad/s.
#[derive(Clone, Copy, Debug)]
struct AnalogSection {
    num: [f64; 3],
    den: [f64; 3],
    /// The section's own frequency, Hz: where its shape is decided.
    f_char_hz: f64,
}

impl AnalogSection {
    fn at(&self, f_hz: f64) -> Complex64 {
        let w = TAU * f_hz;
        // n2 (jw)^2 + n1 jw + n0 = (n0 - n2 w^2) + j n1 w
        let n = Complex64::new(self.num[2] - self.num[0] * w * w, self.num[1] * w);
        let d = Complex64::new(self.den[2] - self.den[0] * w * w, self.den[1] * w);
        n / d
    }
    fn mag2(&self, f_hz: f64) -> f64 {
        let h = self.at(f_hz);
        h.re * h.re + h.im * h.im
    }
}

impl AnalogParams {
    /// How many frequency-shaping sections (transition, upward step) this weighting has.
    pub const fn shaping_sections(&self) -> usize {
        self.transition.is_some() as usize + self.step.is_some() as usize
    }

    /// Gain at DC of everything after the band-limiting high-pass: `K`, times `(f5/f6)^2`
    /// when there is an upward step (the transition passes DC unchanged).
    pub fn dc_gain_after_high_pass(&self) -> f64 {
        let step = self.step.map_or(1.0, |s| {
            let r = s.f5_hz / s.f6_hz;
            r * r
        });
        self.gain * step
    }

    /// The sections after the high-pass: low-pass, then transition and upward step when present.
    fn sections(&self) -> ([Option<AnalogSection>; 3], AnalogSection) {
        let w1 = TAU * self.f1_hz;
        let hp = AnalogSection {
            num: [1.0, 0.0, 0.0],
            den: [1.0, w1 / Q_BAND, w1 * w1],
            f_char_hz: self.f1_hz,
        };
        let w2 = TAU * self.f2_hz;
        let lp = AnalogSection {
            num: [0.0, 0.0, w2 * w2 * self.gain],
            den: [1.0, w2 / Q_BAND, w2 * w2],
            f_char_hz: self.f2_hz,
        };
        let tr = self.transition.map(|t| {
            let (w3, w4) = (TAU * t.f3_hz, TAU * t.f4_hz);
            AnalogSection {
                num: [0.0, 1.0 / w3, 1.0],
                den: [1.0 / (w4 * w4), 1.0 / (t.q4 * w4), 1.0],
                f_char_hz: t.f4_hz,
            }
        });
        let st = self.step.map(|s| {
            let (w5, w6) = (TAU * s.f5_hz, TAU * s.f6_hz);
            AnalogSection {
                num: [1.0, w5 / s.q5, w5 * w5],
                den: [1.0, w6 / s.q6, w6 * w6],
                f_char_hz: libm::sqrt(s.f5_hz * s.f6_hz),
            }
        });
        ([Some(lp), tr, st], hp)
    }
}

/// The analog weighting `W(j 2 pi f)` of ISO 8041 at `f_hz` (dimensionless, f64).
pub fn analog_response(kind: WeightingKind, f_hz: f64) -> Complex64 {
    let (rest, hp) = kind.params().sections();
    let mut h = hp.at(f_hz);
    for s in rest.iter().flatten() {
        h = h * s.at(f_hz);
    }
    h
}

/// Why a weighting could not be built or a stored one was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WeightingError {
    /// A coefficient is NaN or infinite.
    NonFiniteCoefficient,
    /// A section has a pole on or outside the unit circle.
    Unstable,
    /// The magnitude-matched numerator has no real solution (not seen at any supported rate).
    DesignFailed,
    /// The number of active shaping sections is not the one this kind has.
    WrongSectionCount,
    /// The pass-band gain differs from the kind's gain times the axis factor `k`.
    GainMismatch,
}

impl fmt::Display for WeightingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WeightingError::NonFiniteCoefficient => "weighting coefficient is not finite",
            WeightingError::Unstable => {
                "weighting section is unstable (pole on or outside |z| = 1)"
            }
            WeightingError::DesignFailed => "weighting section design has no real solution",
            WeightingError::WrongSectionCount => {
                "weighting has a different number of shaping sections than its kind"
            }
            WeightingError::GainMismatch => {
                "weighting gain differs from its kind's gain times the axis factor k"
            }
        })
    }
}

impl core::error::Error for WeightingError {}

/// The 0.4 Hz band-limiting high-pass as a topology-preserving (trapezoidal) SVF, f32.
///
/// Per sample: `hp = d (x - (k + g) s1 - s2)`, `bp = g hp + s1`, `lp = g bp + s2`,
/// `s1 <- bp + g hp`, `s2 <- lp + g bp`; output `hp`. With `g = tan(pi f1 / fs)`,
/// `k = 1/Q1` and `d = 1 / (1 + g k + g^2)` this is exactly the bilinear transform of
/// `s^2 / (s^2 + s w1/Q1 + w1^2)` prewarped at `f1`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HighPassSvf {
    /// `g = tan(pi f1 / fs)`, dimensionless.
    pub g: f32,
    /// `k + g` with `k = 1/Q1`.
    pub k_plus_g: f32,
    /// `d = 1 / (1 + g k + g^2)`.
    pub d: f32,
}

impl HighPassSvf {
    fn design(f1_hz: f64, q: f64, fs_hz: f64) -> Self {
        let g = libm::tan(core::f64::consts::PI * f1_hz / fs_hz);
        let k = 1.0 / q;
        Self {
            g: g as f32,
            k_plus_g: (k + g) as f32,
            d: (1.0 / (1.0 + g * k + g * g)) as f32,
        }
    }

    /// One sample through the high-pass; `state` holds the two integrator memories.
    #[inline(always)]
    pub fn step(&self, state: &mut [f32; 2], x: f32) -> f32 {
        let [s1, s2] = *state;
        let hp = (x - self.k_plus_g * s1 - s2) * self.d;
        let v1 = self.g * hp;
        let bp = v1 + s1;
        let v2 = self.g * bp;
        let lp = v2 + s2;
        *state = [bp + v1, lp + v2];
        hp
    }

    /// The recurrences above as one state-space recursion (for the blob's gain bound):
    /// with `c = k + g`, `hp = d (x - c s1 - s2)`, `s1 <- s1 + 2 g hp`,
    /// `s2 <- s2 + 2 g s1 + 2 g^2 hp`.
    pub fn recursion(&self) -> Recursion2 {
        let (g, c, d) = (self.g, self.k_plus_g, self.d);
        Recursion2 {
            a_minus_identity: [
                [-2.0 * g * d * c, -2.0 * g * d],
                [2.0 * g - 2.0 * g * g * d * c, -2.0 * g * g * d],
            ],
            b: [2.0 * g * d, 2.0 * g * g * d],
            c: [-d * c, -d],
            d,
        }
    }

    /// Transfer function of the recurrences above, from the stored f32 values, at `z`.
    ///
    /// Solving them for a phasor input: `hp = 1 / (1/d + 2 c g/(z-1) + 2 g^2 (z+1)/(z-1)^2)`
    /// with `c = k + g`.
    pub fn response_at(&self, z: Complex64) -> Complex64 {
        let (g, c, d) = (self.g as f64, self.k_plus_g as f64, self.d as f64);
        let zm1 = z.add(Complex64::new(-1.0, 0.0));
        let zp1 = z.add(Complex64::ONE);
        let t1 = Complex64::new(2.0 * c * g, 0.0) / zm1;
        let t2 = zp1.scale(2.0 * g * g) / zm1.mul(zm1);
        Complex64::ONE / Complex64::new(1.0 / d, 0.0).add(t1).add(t2)
    }

    fn validate(&self) -> Result<(), WeightingError> {
        if !(self.g.is_finite() && self.k_plus_g.is_finite() && self.d.is_finite()) {
            return Err(WeightingError::NonFiniteCoefficient);
        }
        Ok(())
    }
}

/// One second-order section in transposed direct form II, f32:
/// `y = b0 x + s1`, `s1 <- b1 x - a1 y + s2`, `s2 <- b2 x - a2 y`, i.e.
/// `H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Biquad {
    /// Numerator `[b0, b1, b2]`.
    pub b: [f32; 3],
    /// Denominator `[a1, a2]` (`a0 = 1`).
    pub a: [f32; 2],
}

impl Biquad {
    /// The section that passes its input unchanged.
    pub const IDENTITY: Biquad = Biquad {
        b: [1.0, 0.0, 0.0],
        a: [0.0, 0.0],
    };

    /// One sample through the section; `state` is `[s1, s2]`.
    #[inline(always)]
    pub fn step(&self, state: &mut [f32; 2], x: f32) -> f32 {
        let y = self.b[0] * x + state[0];
        state[0] = self.b[1] * x - self.a[0] * y + state[1];
        state[1] = self.b[2] * x - self.a[1] * y;
        y
    }

    /// The section as one state-space recursion (for the blob's gain bound): `y = b0 x + s1`,
    /// `s1 <- (b1 - a1 b0) x - a1 s1 + s2`, `s2 <- (b2 - a2 b0) x - a2 s1`.
    pub fn recursion(&self) -> Recursion2 {
        let [b0, b1, b2] = self.b;
        let [a1, a2] = self.a;
        Recursion2 {
            a_minus_identity: [[-a1 - 1.0, 1.0], [-a2, -1.0]],
            b: [b1 - a1 * b0, b2 - a2 * b0],
            c: [1.0, 0.0],
            d: b0,
        }
    }

    /// `H(z)` from the stored f32 coefficients, evaluated in f64.
    pub fn response_at(&self, z: Complex64) -> Complex64 {
        let zi = Complex64::ONE / z;
        let zi2 = zi.mul(zi);
        let num = Complex64::new(self.b[0] as f64, 0.0)
            .add(zi.scale(self.b[1] as f64))
            .add(zi2.scale(self.b[2] as f64));
        let den = Complex64::ONE
            .add(zi.scale(self.a[0] as f64))
            .add(zi2.scale(self.a[1] as f64));
        num / den
    }

    fn validate(&self) -> Result<(), WeightingError> {
        if !self.b.iter().chain(self.a.iter()).all(|c| c.is_finite()) {
            return Err(WeightingError::NonFiniteCoefficient);
        }
        Ok(())
    }

    /// `H(1)`: the section's gain at DC, from its coefficients, with no trigonometry; in
    /// f32 (hardware on the device), where `1 + a1 + a2` is exact for poles near `z = 1`
    /// (Sterbenz), so a low corner at a high rate costs no precision.
    fn dc_gain(&self) -> f32 {
        let [b0, b1, b2] = self.b;
        ((b0 + b2) + b1) / ((1.0 + self.a[0]) + self.a[1])
    }

    /// Magnitude-matched design of one analog section at `fs_hz` (see the module doc).
    ///
    /// With `phi1 = sin^2(w/2)`, `phi0 = 1 - phi1`, `phi2 = 4 phi0 phi1`, any quadratic
    /// `P(z)` has `|P(e^jw)|^2 = P0 phi0 + P1 phi1 + P2 phi2`, where `P0 = (p0+p1+p2)^2`,
    /// `P1 = (p0-p1+p2)^2`, `P2 = -4 p0 p2`. The denominator's `A0, A1, A2` follow from the
    /// matched poles; `B0, B1, B2` are solved so that `|B|^2 / |A|^2` equals the analog
    /// `|H|^2` at DC, Nyquist and `fm_hz`; `b` is the minimum-phase factor of `B`.
    fn design_matched(s: &AnalogSection, fs_hz: f64, fm_hz: f64) -> Result<Self, WeightingError> {
        let t = 1.0 / fs_hz;
        let [d2, d1, d0] = s.den;
        // Analog poles: roots of d2 s^2 + d1 s + d0.
        let disc = d1 * d1 - 4.0 * d2 * d0;
        // (1 - z1)(1 - z2), (1 + z1)(1 + z2), a1, a2, computed without cancellation.
        let (a1, a2, one_minus, one_plus) = if disc < 0.0 {
            let sigma = -d1 / (2.0 * d2);
            let omega = libm::sqrt(-disc) / (2.0 * d2);
            let r = libm::exp(sigma * t);
            let one_minus_r = -libm::expm1(sigma * t);
            // |1 -/+ r e^{j th}|^2 = (1 -/+ r)^2 +/- 4 r sin^2(th/2), no cancellation near z = 1.
            let half = libm::sin(omega * t / 2.0);
            let one_minus = one_minus_r * one_minus_r + 4.0 * r * half * half;
            let one_plus = (1.0 + r) * (1.0 + r) - 4.0 * r * half * half;
            (-2.0 * r * libm::cos(omega * t), r * r, one_minus, one_plus)
        } else {
            let sq = libm::sqrt(disc);
            let p1 = (-d1 + sq) / (2.0 * d2);
            let p2 = (-d1 - sq) / (2.0 * d2);
            let (z1, z2) = (libm::exp(p1 * t), libm::exp(p2 * t));
            (
                -(z1 + z2),
                z1 * z2,
                -libm::expm1(p1 * t) * -libm::expm1(p2 * t),
                (1.0 + z1) * (1.0 + z2),
            )
        };
        let big_a0 = one_minus * one_minus;
        let big_a1 = one_plus * one_plus;
        let big_a2 = -4.0 * a2;
        let phis = |f: f64| {
            let sn = libm::sin(core::f64::consts::PI * f / fs_hz);
            let p1 = sn * sn;
            let p0 = 1.0 - p1;
            (p0, p1, 4.0 * p0 * p1)
        };
        let big_b0 = big_a0 * s.mag2(0.0);
        let big_b1 = big_a1 * s.mag2(fs_hz / 2.0);
        let (p0, p1, p2) = phis(fm_hz);
        let a_m = big_a0 * p0 + big_a1 * p1 + big_a2 * p2;
        let big_b2 = (s.mag2(fm_hz) * a_m - big_b0 * p0 - big_b1 * p1) / p2;
        let (r0, r1) = (libm::sqrt(big_b0), libm::sqrt(big_b1));
        let w = 0.5 * (r0 + r1);
        let under = w * w + big_b2;
        // Written so that a NaN fails the test as well.
        if under.partial_cmp(&0.0).is_none_or(|o| o.is_lt())
            || w.partial_cmp(&0.0) != Some(Ordering::Greater)
        {
            return Err(WeightingError::DesignFailed);
        }
        let b0 = 0.5 * (w + libm::sqrt(under));
        let b1 = 0.5 * (r0 - r1);
        let b2 = -big_b2 / (4.0 * b0);
        let q = Biquad {
            b: [b0 as f32, b1 as f32, b2 as f32],
            a: [a1 as f32, a2 as f32],
        };
        q.validate()?;
        Ok(q)
    }
}

/// The band-limiting high-pass (0.4 Hz) and low-pass (100 Hz), identical for Wk, Wd and
/// Wj at one sample rate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandLimit {
    /// The 0.4 Hz band-limiting high-pass.
    pub high_pass: HighPassSvf,
    /// The 100 Hz band-limiting low-pass.
    pub low_pass: Biquad,
}

/// A frequency weighting ready to run: f32 coefficients designed for one sample rate.
///
/// Plain data for the parameter blob; build it with [`WeightingSettings::new`], or check
/// a stored one with [`WeightingSettings::validate`]. The rate is not stored here: the
/// blob holds it once for every stage.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WeightingSettings {
    /// Which weighting these coefficients realize.
    pub kind: WeightingKind,
    /// Band limiting, shared by all weightings at this rate.
    pub band: BandLimit,
    /// Transition and/or upward step; only the first `n_shaping` run.
    pub shaping: [Biquad; MAX_SHAPING],
    /// How many of `shaping` are active (1 or 2).
    pub n_shaping: u8,
}

/// Most frequency-shaping sections of one weighting (Wk: transition and upward step).
pub const MAX_SHAPING: usize = 2;

/// Running memory of one weighting filter (two f32 per section).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeightingState {
    high_pass: [f32; 2],
    low_pass: [f32; 2],
    shaping: [[f32; 2]; MAX_SHAPING],
}

impl WeightingState {
    /// The state of a filter at rest (all memories zero).
    pub const fn new() -> Self {
        Self {
            high_pass: [0.0; 2],
            low_pass: [0.0; 2],
            shaping: [[0.0; 2]; MAX_SHAPING],
        }
    }
}

impl WeightingSettings {
    /// Designs `kind` for `sample_rate` in f64 and stores f32 coefficients.
    pub fn new(kind: WeightingKind, sample_rate: SampleRate) -> Result<Self, WeightingError> {
        let fs = sample_rate.hz_f64();
        let params = kind.params();
        let ([lp, tr, st], hp) = params.sections();
        let high_pass = HighPassSvf::design(hp.f_char_hz, Q_BAND, fs);
        // The low-pass sits at or above fs/2 at low rates: match it at fs/3 at most; the
        // shaping sections at their own frequency, at most fs/4.
        let lp = lp.ok_or(WeightingError::DesignFailed)?;
        let low_pass = Biquad::design_matched(&lp, fs, lp.f_char_hz.min(fs / 3.0))?;
        let mut shaping = [Biquad::IDENTITY; MAX_SHAPING];
        let mut n = 0usize;
        for s in [tr, st].iter().flatten() {
            shaping[n] = Biquad::design_matched(s, fs, s.f_char_hz.min(fs / 4.0))?;
            n += 1;
        }
        let settings = Self {
            kind,
            band: BandLimit {
                high_pass,
                low_pass,
            },
            shaping,
            n_shaping: n as u8,
        };
        settings.validate_gain(1.0)?;
        Ok(settings)
    }

    /// Checks stored settings: the kind's number of sections, coefficients finite, all
    /// sections stable.
    pub fn validate(&self) -> Result<(), WeightingError> {
        if self.n_shaping as usize != self.kind.params().shaping_sections() {
            return Err(WeightingError::WrongSectionCount);
        }
        self.band.high_pass.validate()?;
        self.band.low_pass.validate()?;
        self.shaping.iter().try_for_each(Biquad::validate)?;
        // The poles of what actually runs, not of the analog prototype (a blob whose g,
        // k + g and d each look plausible can still combine into a pole outside |z| = 1),
        // with the margin the blob's gain bound needs: one test for both.
        if self.amplification().is_none() {
            return Err(WeightingError::Unstable);
        }
        Ok(())
    }

    /// [`validate`](Self::validate), then checks that the filter's gain is its kind's times
    /// `k` (the axis factor [`scaled`](Self::scaled) folded in). Compared at DC past the
    /// high-pass, where the magnitude-matched sections equal the analog exactly and `H(1)`
    /// needs no trigonometry on the device; 1 % covers the f32 coefficients' rounding.
    pub fn validate_gain(&self, k: f32) -> Result<(), WeightingError> {
        self.validate()?;
        let n = self.n_shaping as usize;
        let stored = self.shaping[..n]
            .iter()
            .fold(self.band.low_pass.dc_gain(), |g, q| g * q.dc_gain());
        let expected = self.kind.params().dc_gain_after_high_pass() as f32 * k;
        let ratio = stored / expected;
        if !(ratio.is_finite() && (ratio - 1.0).abs() <= 0.01) {
            return Err(WeightingError::GainMismatch);
        }
        Ok(())
    }

    /// What the whole cascade can make of input bounded by 1 m/s^2: the largest state
    /// norm of any section and the output bound; `None` if a section has no bound
    /// ([`crate::gain_bound::ModalBound::new`]).
    pub fn amplification(&self) -> Option<Amplification> {
        let n = (self.n_shaping as usize).min(MAX_SHAPING);
        let [first, second] = self.shaping;
        let sections = [
            self.band.high_pass.recursion(),
            self.band.low_pass.recursion(),
            first.recursion(),
            second.recursion(),
        ];
        let mut total = Amplification {
            state: 0.0,
            output: 1.0,
        };
        for section in &sections[..2 + n] {
            let gain = section.amplification()?;
            let state = gain.state * total.output;
            // Comparisons, not f32::max: no library call on the device.
            if state > total.state {
                total.state = state;
            }
            total.output *= gain.output;
        }
        (total.state.is_finite() && total.output.is_finite()).then_some(total)
    }

    /// One acceleration sample (m/s^2, at the design rate) in, the weighted sample (m/s^2) out.
    #[inline]
    pub fn step(&self, state: &mut WeightingState, x_m_s2: f32) -> f32 {
        self.step_with_band(&self.band, state, x_m_s2)
    }

    /// As [`step`](Self::step), with the band limiting taken from `band`, which must equal
    /// `self.band` (it does for every weighting at the same rate). A caller running three
    /// axes passes one copy, so its coefficients are loaded once per sample, not three times.
    #[inline(always)]
    pub fn step_with_band(&self, band: &BandLimit, state: &mut WeightingState, x_m_s2: f32) -> f32 {
        let y = band.high_pass.step(&mut state.high_pass, x_m_s2);
        let y = band.low_pass.step(&mut state.low_pass, y);
        let y = self.shaping[0].step(&mut state.shaping[0], y);
        if self.n_shaping >= 2 {
            self.shaping[1].step(&mut state.shaping[1], y)
        } else {
            y
        }
    }

    /// Multiplies the filter's gain by `k` (folds a vector-sum factor into the last section).
    pub fn scaled(mut self, k: f32) -> Self {
        let last = (self.n_shaping as usize).clamp(1, MAX_SHAPING) - 1;
        for b in self.shaping[last].b.iter_mut() {
            *b *= k;
        }
        self
    }

    /// Frequency response at `f_hz` of the filter the device runs (its f32 coefficients),
    /// at `sample_rate`, the rate it was designed for.
    pub fn response(&self, sample_rate: SampleRate, f_hz: f64) -> Complex64 {
        let z = Complex64::from_angle(TAU * f_hz / sample_rate.hz_f64());
        let n = (self.n_shaping as usize).min(MAX_SHAPING);
        let band = self.band.high_pass.response_at(z) * self.band.low_pass.response_at(z);
        self.shaping[..n]
            .iter()
            .fold(band, |h, q| h * q.response_at(z))
    }
}

#[cfg(test)]
mod tests;
