//! Value parsers shared by the subcommands' flags: bad values are refused by clap, with
//! the flag and what was expected on one line, before a command starts.

use std::time::Duration;

use supine_core::sample_rate::SampleRate;

/// Longest timeout any flag accepts, s: one day. Longer waits are mistakes, and
/// `Duration::from_secs_f64` panics on values it cannot hold.
pub const MAX_TIMEOUT_S: f64 = 86_400.0;

/// A timeout in seconds: finite, above 0, at most [`MAX_TIMEOUT_S`].
pub fn timeout_s(text: &str) -> Result<f64, String> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("expected a number of seconds, got {text:?}"))?;
    if value.is_finite() && value > 0.0 && value <= MAX_TIMEOUT_S {
        Ok(value)
    } else {
        Err(format!(
            "expected seconds above 0 and at most {MAX_TIMEOUT_S} (one day), got {text}"
        ))
    }
}

/// The [`Duration`] of a timeout flag's value (checked again for library callers, which
/// bypass clap); the error names `flag`.
pub fn timeout(flag: &str, seconds: f64) -> anyhow::Result<Duration> {
    timeout_s(&seconds.to_string())
        .map(Duration::from_secs_f64)
        .map_err(|e| anyhow::anyhow!("{flag}: {e}"))
}

/// A frequency in Hz: finite and above 0.
pub fn positive_hz(text: &str) -> Result<f64, String> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("expected a frequency in Hz, got {text:?}"))?;
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(format!("expected a frequency above 0 Hz, got {text}"))
    }
}

/// The help line of a sample-rate flag: `what`, then the device's range in Hz.
pub fn sample_rate_help(what: &str) -> String {
    format!(
        "{what}, Hz ({}..={})",
        SampleRate::MIN_HZ,
        SampleRate::MAX_HZ
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timeouts_are_finite_positive_and_at_most_a_day() {
        assert_eq!(timeout_s("2.5"), Ok(2.5));
        assert_eq!(timeout_s("86400"), Ok(86_400.0));
        for bad in ["0", "-1", "NaN", "inf", "1e300", "86400.5"] {
            let err = timeout_s(bad).expect_err(bad);
            assert!(err.contains("at most 86400 (one day)"), "{err}");
        }
        assert!(timeout_s("ten").unwrap_err().contains("\"ten\""));
        let err = timeout("--timeout-s", 1e30).unwrap_err().to_string();
        assert!(err.starts_with("--timeout-s: expected seconds"), "{err}");
        assert_eq!(
            timeout("--timeout-s", 0.25).unwrap(),
            Duration::from_millis(250)
        );
    }

    #[test]
    fn frequencies_are_finite_and_above_zero() {
        assert_eq!(positive_hz("0.5"), Ok(0.5));
        for bad in ["0", "-0.5", "NaN", "inf"] {
            assert!(positive_hz(bad).is_err(), "{bad}");
        }
    }
}
