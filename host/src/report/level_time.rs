//! Time at each alert level: a leg's, a mission's and a road segment's.

use serde::Serialize;

/// Seconds spent at each alert level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TimeAtLevel {
    /// At normal, s.
    pub normal: f64,
    /// At advisory, s.
    pub advisory: f64,
    /// At warning, s.
    pub warning: f64,
    /// At alarm, s.
    pub alarm: f64,
}

impl TimeAtLevel {
    /// The seconds in level order.
    pub fn as_array(&self) -> [f64; 4] {
        [self.normal, self.advisory, self.warning, self.alarm]
    }

    /// From seconds in level order.
    pub fn from_array(a: [f64; 4]) -> Self {
        Self {
            normal: a[0],
            advisory: a[1],
            warning: a[2],
            alarm: a[3],
        }
    }
}
