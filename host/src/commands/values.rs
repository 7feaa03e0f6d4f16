//! Value parsers shared by the subcommands' flags: bad values are refused by clap, with
//! the flag and what was expected on one line, before a command starts.

use std::time::Duration;

use supine_core::sample_rate::SampleRate;

/// Default seed of every random draw (rides, synthetic datasets, fits, bands): one value
/// so that `--seed` means the same thing in every command.
pub const DEFAULT_SEED: u64 = 1;

/// Default length of a generated ride or recording, s (`ride`, `demo`, `monitor`, `synth`):
/// a minute shows the alerts rise and clear and runs in seconds.
pub const DEFAULT_DURATION_S: f64 = 60.0;

/// Default sample rate of a generated ride and of the device, Hz.
pub const DEFAULT_SAMPLE_RATE_HZ: f64 = 500.0;

/// The items of a comma-separated list flag (given once or repeated), so that
/// `--exclude s1,s2` and `--exclude "s1 , s2"` mean the same (`--exclude s1, s2`, two
/// shell words, is joined into one by `cli::join_list_words`); each item is
/// trimmed and none may be empty. `flag` names the list in the error.
pub fn comma_list(flag: &str, words: &[String]) -> anyhow::Result<Vec<String>> {
    if words.is_empty() {
        return Ok(Vec::new());
    }
    let joined = words.join(",");
    joined
        .split(',')
        .map(|item| {
            let item = item.trim();
            if item.is_empty() {
                Err(anyhow::anyhow!(
                    "{flag} {joined}: expected comma-separated items, found an empty one"
                ))
            } else {
                Ok(item.to_string())
            }
        })
        .collect()
}

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
    fn comma_lists_accept_spaces_around_commas_and_refuse_empty_items() {
        let words = |w: &[&str]| w.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        for given in [&["s1,s2"][..], &["s1", "s2"], &["s1 , s2"]] {
            assert_eq!(
                comma_list("--exclude", &words(given)).unwrap(),
                ["s1", "s2"]
            );
        }
        assert!(comma_list("--exclude", &[]).unwrap().is_empty());
        let err = comma_list("--exclude", &words(&["s1,,s2"])).unwrap_err();
        assert_eq!(
            err.to_string(),
            "--exclude s1,,s2: expected comma-separated items, found an empty one"
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
