//! Test scaffolding shared by the integration tests.

use std::path::{Path, PathBuf};

use serde_json::Value;
use supine_core::model::{ModelParams, ParamId, Preset};
use supine_host::commands::band_args::BandArgs;
use supine_host::commands::report::{self, MissionArgs};
use supine_host::exposure::ride::{Profile, generate, write_ride};
use supine_host::io::params_file::{ModelSource, PresetArg};

/// A synthetic ride of `profile` at 500 Hz in `dir`, named by its profile and `seed`
/// (written once: a second call with the same name gives the same file).
pub fn ride(dir: &Path, profile: Profile, duration_s: f64, seed: u64) -> PathBuf {
    let path = dir.join(format!("{}-{seed}.csv", profile.name()));
    if !path.exists() {
        write_ride(&path, &generate(profile, duration_s, 500.0, seed).unwrap()).unwrap();
    }
    path
}

/// `--preset paper-litter`.
pub fn paper_litter() -> ModelSource {
    ModelSource {
        preset: Some(PresetArg::PaperLitter),
        params: None,
    }
}

/// `supine report --json` of `mission` (its page written into `out`), as a script reads it.
pub fn report_json(mission: MissionArgs, out: &Path) -> Value {
    let args = report::Args {
        mission,
        out: out.to_path_buf(),
        json: true,
        compare: false,
        band: BandArgs::default(),
    };
    let mut text = Vec::new();
    report::run_to(&args, &mut text).unwrap();
    serde_json::from_slice(&text).unwrap()
}

/// The parameter whose file key is `key` (e.g. `contacts.pelvis.damping_n_s_per_m.z`).
pub fn param(key: &str) -> ParamId {
    ParamId::ALL
        .into_iter()
        .find(|p| p.to_string() == key)
        .unwrap_or_else(|| panic!("no parameter {key}"))
}

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
