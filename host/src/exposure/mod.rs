//! ISO 2631-1 exposure on the host: rides to evaluate, the evaluation itself (the same
//! `supine-core` code the device runs), and the host's reference for the device.
//!
//! - [`ride`]: realistic litter-frame accelerations (`supine ride`).
//! - [`weighting_response`]: the device's weighting filters against the analog ones.
//! - [`resample`]: band-limited sample-rate conversion of recordings.
//! - [`report`]: exposure reports of recordings (`supine exposure`).
//! - [`reference`](mod@reference): what the device must produce for given inputs (f32 pipeline, f64 model).

pub mod joints;
pub mod reference;
pub mod report;
pub mod resample;
pub mod ride;
pub mod weighting_response;
