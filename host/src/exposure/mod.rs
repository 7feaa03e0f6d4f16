//! ISO 2631-1 exposure on the host: rides to evaluate, the evaluation itself (the same
//! `supine-core` code the device runs), and the host's reference for the device.
//!
//! - [`ride`]: realistic litter-frame accelerations (`supine ride`).
//! - [`weighting_response`]: the device's weighting filters against the analog ones.
//! - [`evaluation_input`]: a ride at the rate it is evaluated at (resampled on request).
//! - [`model_run`]: the device pipeline over a ride, sample by sample.
//! - [`model_exposure`]: `supine exposure`'s model form (the device chain over a ride).
//! - [`channel_exposure`]: its channel form (one recorded channel weighted, no model).
//! - [`reported_values`], [`timed_event`]: the values and alert timeline they report.
//! - [`exposure_text`]: their readable text.
//! - [`ride_prediction`]: `supine predict` of a ride: that pass, every sample written.
//! - [`joints`]: the predicted neck and lower-back motion of a ride.
//! - [`reference`](mod@reference): what the device must produce for given inputs (f32 pipeline, f64 model).

pub mod channel_exposure;
pub mod evaluation_input;
pub mod exposure_records;
pub mod exposure_text;
pub mod joints;
pub mod model_exposure;
pub mod model_run;
pub mod reference;
pub mod reported_values;
pub mod ride;
pub mod ride_prediction;
pub mod timed_event;
pub mod weighting_response;
