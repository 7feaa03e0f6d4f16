//! ISO 2631-1 exposure on the host: rides to evaluate, the evaluation itself (the same
//! `supine-core` code the device runs), and the host's reference for the device.
//!
//! - [`ride`]: realistic litter-frame accelerations (`supine ride`).
//! - [`resample`]: band-limited sample-rate conversion of recordings.
//! - [`report`]: exposure reports of recordings (`supine exposure`).
//! - [`reference`]: what the device must produce for given inputs (f32 pipeline, f64 model).

pub mod reference;
pub mod report;
pub mod resample;
pub mod ride;
