//! Identification of the body model from measurements, and checking it against them.
//!
//! - [`spectral`]: Welch spectra and the H1 transmissibility estimator.
//! - [`geomean`]: the geometric mean of transmissibilities across subjects.
//! - [`transmissibility`]: measured H of a dataset's case, and the model's H.
//! - [`fit`]: the model's parameters from a measured transmissibility.
//! - [`synth`]: synthetic datasets from the model (tests and benchmarks).
//! - [`validate`]: predicted against measured sensor accelerations of a recording.

pub mod fit;
pub mod geomean;
pub mod identify_records;
pub mod spectral;
pub mod synth;
pub mod transmissibility;
pub mod validate;
