//! `--height-m` and `--mass-kg`: the patient the model is scaled to (the model's
//! anthropometric scaling, `docs/model.md`), for every command that builds a model for a
//! ride. Values outside the model's range are refused with the range.

use anyhow::{Result, anyhow, bail};
use supine_core::model::params::{HEIGHT_RANGE_M, MASS_RANGE_KG};

use supine_core::model::ModelParams;

use crate::io::excerpt::number;
use crate::io::params_file::{ModelSource, ParamFile};

/// The patient's height and mass, where given (else the parameters' subject).
#[derive(Clone, Copy, Debug, Default, PartialEq, clap::Args)]
pub struct SubjectArgs {
    /// The patient's height, m (the model's anthropometric scaling).
    #[arg(long, value_name = "M")]
    pub height_m: Option<f64>,
    /// The patient's mass, kg (the model's anthropometric scaling).
    #[arg(long, value_name = "KG")]
    pub mass_kg: Option<f64>,
}

impl SubjectArgs {
    /// The parameters `source` names, scaled to this patient.
    pub fn load_from(&self, source: &ModelSource) -> Result<ModelParams> {
        let mut file = source.load()?;
        self.apply(&mut file)?;
        Ok(file.params)
    }

    /// Replaces the subject of `file` where given; refuses values outside the model's range.
    pub fn apply(&self, file: &mut ParamFile) -> Result<()> {
        for (flag, value, (lo, hi), unit) in [
            ("--height-m", self.height_m, HEIGHT_RANGE_M, "m"),
            ("--mass-kg", self.mass_kg, MASS_RANGE_KG, "kg"),
        ] {
            if let Some(v) = value.filter(|v| !(lo..=hi).contains(v)) {
                let v = number(v);
                bail!("{flag} {v}: expected {lo} to {hi} {unit}, the model's range");
            }
        }
        if let Some(h) = self.height_m {
            file.params.subject.height_m = h;
        }
        if let Some(m) = self.mass_kg {
            file.params.subject.mass_kg = m;
        }
        file.params
            .validate()
            .map_err(|e| anyhow!("--height-m/--mass-kg: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::model::Preset;

    #[test]
    fn the_patient_replaces_the_subject_within_the_models_range() {
        let mut file = ParamFile::preset(Preset::PaperLitter);
        let patient = SubjectArgs {
            height_m: Some(1.6),
            mass_kg: Some(52.0),
        };
        patient.apply(&mut file).unwrap();
        assert_eq!(file.params.subject.height_m, 1.6);
        assert_eq!(file.params.subject.mass_kg, 52.0);
        let tall = SubjectArgs {
            height_m: Some(3.0),
            mass_kg: None,
        };
        let err = tall.apply(&mut file).unwrap_err().to_string();
        assert_eq!(
            err,
            "--height-m 3: expected 0.5 to 2.5 m, the model's range"
        );
        let heavy = SubjectArgs {
            height_m: None,
            mass_kg: Some(f64::NAN),
        };
        assert!(
            heavy
                .apply(&mut file)
                .unwrap_err()
                .to_string()
                .starts_with("--mass-kg NaN")
        );
    }
}
