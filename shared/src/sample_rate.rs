//! The sample rates the device supports, defined once, and a rate checked against them.
//!
//! Every stage that depends on the rate (the model's discretization, the weighting
//! filters, the exposure and alert stages, the sensor checks) is designed and tested for
//! 100 Hz to 2 kHz (docs/model.md, docs/exposure.md). The parameter blob stores the one
//! rate its stages were built for; the stages take it from there instead of each keeping
//! a copy.

use core::fmt;

use serde::{Deserialize, Serialize};

/// A sample rate within [`SampleRate::MIN_HZ`]..=[`SampleRate::MAX_HZ`], in f32 as the
/// device and the blob hold it.
///
/// [`SampleRate::new`] refuses any other number. Deserializing takes the stored number as
/// it is (so that a blob refused for its rate says so, rather than failing to parse), and
/// a blob's validation checks it with [`SampleRate::check`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleRate(f32);

impl SampleRate {
    /// Lowest supported sample rate, Hz.
    pub const MIN_HZ: f32 = 100.0;
    /// Highest supported sample rate, Hz.
    pub const MAX_HZ: f32 = 2000.0;

    /// `hz` if it is a supported rate.
    pub const fn new(hz: f32) -> Result<Self, SampleRateError> {
        // False for NaN as well.
        if hz >= Self::MIN_HZ && hz <= Self::MAX_HZ {
            Ok(Self(hz))
        } else {
            Err(SampleRateError)
        }
    }

    /// A rate computed in f64 (a recording's, a command-line value), checked as given and
    /// then rounded to the f32 the device holds: 2000.0001 Hz is refused, not rounded in.
    pub fn from_hz_f64(hz: f64) -> Result<Self, SampleRateError> {
        if Self::supports_hz(hz) {
            Ok(Self(hz as f32))
        } else {
            Err(SampleRateError)
        }
    }

    /// Whether `hz` lies in the supported range (false for NaN and infinities). For f64
    /// rates that are used as they are, such as the host's f64 model at a simulation rate.
    pub fn supports_hz(hz: f64) -> bool {
        (f64::from(Self::MIN_HZ)..=f64::from(Self::MAX_HZ)).contains(&hz)
    }

    /// Checks a rate that was deserialized rather than built with [`new`](Self::new).
    pub fn check(self) -> Result<Self, SampleRateError> {
        Self::new(self.0)
    }

    /// The rate, Hz.
    pub const fn hz(self) -> f32 {
        self.0
    }

    /// The rate as f64 (exactly the f32 value), Hz: what the f64 designs compute with.
    pub fn hz_f64(self) -> f64 {
        f64::from(self.0)
    }
}

impl fmt::Display for SampleRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} Hz", self.0)
    }
}

/// A number that is not a supported sample rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleRateError;

impl fmt::Display for SampleRateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "expected a sample rate within {}..={} Hz",
            SampleRate::MIN_HZ,
            SampleRate::MAX_HZ
        )
    }
}

impl core::error::Error for SampleRateError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_range_is_inclusive_and_refuses_non_numbers() {
        for hz in [100.0, 500.0, 2000.0] {
            assert_eq!(SampleRate::new(hz).map(SampleRate::hz), Ok(hz));
        }
        for hz in [99.999, 2000.001, 0.0, -500.0, f32::NAN, f32::INFINITY] {
            assert_eq!(SampleRate::new(hz), Err(SampleRateError), "{hz}");
        }
        // Checked in f64 before rounding: just above the top does not round into range.
        assert_eq!(SampleRate::from_hz_f64(2000.00001), Err(SampleRateError));
        assert_eq!(
            SampleRate::from_hz_f64(1000.0 / 3.0).map(SampleRate::hz),
            Ok(333.333_34)
        );
        assert_eq!(
            SampleRateError.to_string(),
            "expected a sample rate within 100..=2000 Hz"
        );
    }

    #[test]
    fn a_stored_rate_is_checked_again() {
        let stored: SampleRate = postcard::from_bytes(&5000f32.to_le_bytes()).unwrap();
        assert_eq!(stored.hz(), 5000.0);
        assert_eq!(stored.check(), Err(SampleRateError));
        let good: SampleRate = postcard::from_bytes(&500f32.to_le_bytes()).unwrap();
        assert_eq!(good.check(), SampleRate::new(500.0));
    }
}
