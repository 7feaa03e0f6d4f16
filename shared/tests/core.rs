//! The core's integration tests, one module per file, in one binary. Each file's own
//! documentation says what it checks; `cargo test -p supine-core --test core NAME::` runs
//! one file's tests.

mod blob_and_frames;
mod blob_gain_bound;
mod extreme_input;
mod golden_bytes;
mod hostile_blob;
mod input_frame;
mod model_joints;
mod model_params;
mod model_physics;
mod model_realization;
mod model_state_space;
mod module_layers;
mod mounting;
mod pipeline;
mod pipeline_joint_alerts;
mod pipeline_joints;
mod telemetry_frame;
mod upload;
