//! The acceleration columns' unit (`--units`), as the ride readers and the recognized
//! formats name it.

use clap::ValueEnum;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;

/// Unit of the acceleration columns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AccelUnit {
    /// Metres per second squared.
    #[default]
    #[value(name = "m/s2")]
    MS2,
    /// Standard gravity, 9.80665 m/s^2.
    G,
}

impl AccelUnit {
    /// m/s^2 per unit.
    pub const fn to_m_s2(self) -> f64 {
        match self {
            AccelUnit::MS2 => 1.0,
            AccelUnit::G => STANDARD_GRAVITY_M_S2,
        }
    }

    /// The unit's name, as errors and reports say it.
    pub fn name(self) -> &'static str {
        match self {
            AccelUnit::MS2 => "m/s^2",
            AccelUnit::G => "g",
        }
    }
}
