//! supine-core: everything the host and the device both compute, once.
//!
//! The biodynamic model of a supine human on a litter (Wang & Rahmatalla 2013), its
//! discretization for the device, ISO 2631-1 weighting and exposure, alerts, the wire
//! protocol and the parameter blob. `no_std` and heap-free so the same code runs on the
//! Cortex-M4F and on the workstation.
//!
//! The data path reads one way: `model`, `weighting` and `mounting`, then `exposure` and
//! `calibration`,
//! `alerts`, `joint_exposure`, `blob`, `pipeline`, `protocol` and `upload`; a module uses
//! only those before it, and the leaf utilities (`fpu`, `gain_bound`, `input_resolution`,
//! `sample_rate`, `test_vector`, `timing`) anywhere
//! (`tests/module_layers.rs` checks it).
//!
//! Float functions that core lacks come from `libm` explicitly, never from an extension
//! trait, so that host and device compute bit-identical numbers (see `README.md`).
#![cfg_attr(not(any(test, feature = "std")), no_std)]
// The one exception, the FPU's square root, is allowed in `fpu` alone.
#![deny(unsafe_code)]

pub mod alerts;
pub mod blob;
pub mod calibration;
pub mod exposure;
pub mod fpu;
pub mod gain_bound;
pub mod input_resolution;
pub mod joint_exposure;
pub mod model;
pub mod mounting;
pub mod pipeline;
pub mod protocol;
pub mod sample_rate;
pub mod test_vector;
pub mod timing;
pub mod upload;
pub mod weighting;
