//! Test scaffolding shared by the identification tests.

use supine_core::model::{ModelParams, ParamId, Preset};

/// A truth away from the paper's values: every parameter the paper's rigid value times a
/// factor in 0.88..1.12, so that starting a fit at the paper's values is not starting at
/// the answer.
pub fn perturbed_truth() -> ModelParams {
    let mut p = ModelParams::preset(Preset::PaperRigid);
    for (i, id) in ParamId::ALL.into_iter().enumerate() {
        p.set(
            id,
            p.get(id) * (1.0 + 0.25 * ((i * 5 % 7) as f64 / 6.0 - 0.5)),
        );
    }
    p
}
