//! The stack's depth, for the status report.

/// Measures how deep the stack has been (a painted stack on the device).
pub trait StackGauge {
    /// Deepest stack use since boot, bytes.
    fn high_water_bytes(&self) -> usize;
}
