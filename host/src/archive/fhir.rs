//! A mission as a FHIR R4 Bundle (type `collection`) of Observations, for the patient's
//! record (`docs/archive.md`, "FHIR export", gives the mapping):
//!
//! - the head's frequency-weighted vector rms, MTVV (m/s^2, UCUM `m/s2`) and VDV;
//! - the time at each alert level (s, UCUM `s`), one Observation with a component a level;
//! - the joints' largest excursions (mm, UCUM `mm`; degrees, UCUM `deg`), one Observation
//!   with a component an output.
//!
//! No standard code exists for these quantities, so each carries a code of this
//! project's own code system, [`CODE_SYSTEM`], with a display text. UCUM has integer
//! exponents only, so the VDV's unit m/s^1.75 has no UCUM code: its `valueQuantity` has
//! `unit` "m/s^1.75" and no `system` or `code` (FHIR allows a Quantity with a unit text
//! only; a receiver then cannot convert it, which is right: nothing converts it).
//!
//! Every Observation has `status` final, the mission's period as `effectivePeriod`, and
//! refers to the patient and/or encounter by the identifier the user gave (a Reference by
//! `identifier`, since the archive knows no resource ids of the receiving system).

use anyhow::{Result, anyhow, bail};
use jiff::{SignedDuration, Timestamp};
use serde_json::{Value, json};
use sha2::{Digest, Sha256};

use crate::archive::store::MissionSummary;

/// The code system of the Observations' codes.
pub const CODE_SYSTEM: &str = "urn:supine:fhir:patient-vibration";
/// UCUM.
pub const UCUM: &str = "http://unitsofmeasure.org";

/// A mission's Bundle. Needs the mission's start and a patient or encounter identifier.
pub fn bundle(m: &MissionSummary) -> Result<Value> {
    if m.meta.patient.is_none() && m.meta.encounter.is_none() {
        bail!(
            "mission {}: no patient or encounter identifier to refer to (add the mission with \
             --patient ID or --encounter ID)",
            m.id
        );
    }
    let start_text = m.meta.start.as_deref().ok_or_else(|| {
        anyhow!(
            "mission {}: no start time, so no period for the Observations (add it with --start)",
            m.id
        )
    })?;
    let start: Timestamp = start_text.parse()?;
    let mission = &m.mission;
    let number = |path: &[&str]| -> Result<f64> {
        let mut v = mission;
        for key in path {
            v = &v[*key];
        }
        v.as_f64()
            .ok_or_else(|| anyhow!("mission {}: stored values lack {}", m.id, path.join(".")))
    };
    let duration_s = number(&["duration_s"])?;
    let end = start.checked_add(SignedDuration::from_secs_f64(duration_s))?;
    let period = json!({"start": start.to_string(), "end": end.to_string()});
    let note = format!(
        "supine mission {} (model {}, parameter identity {}); ISO 2631-1 weighted values of \
         the head predicted from the litter frame's acceleration",
        m.id, m.model.name, m.model.identity
    );
    let base = |code: &str, display: &str| -> Value {
        let mut o = json!({
            "resourceType": "Observation",
            "status": "final",
            "code": {
                "coding": [{"system": CODE_SYSTEM, "code": code, "display": display}],
                "text": display
            },
            "effectivePeriod": period,
            "note": [{"text": note}]
        });
        if let Some(p) = &m.meta.patient {
            o["subject"] = json!({"identifier": {"value": p}});
        }
        if let Some(e) = &m.meta.encounter {
            o["encounter"] = json!({"identifier": {"value": e}});
        }
        o
    };
    let ucum = |value: f64, unit: &str, code: &str| json!({"value": value, "unit": unit, "system": UCUM, "code": code});
    let mut observations = Vec::new();
    let mut rms = base(
        "head-weighted-rms",
        "Head vibration, frequency-weighted vector rms (ISO 2631-1)",
    );
    rms["valueQuantity"] = ucum(number(&["vector", "rms_m_s2"])?, "m/s2", "m/s2");
    observations.push(rms);
    let mut mtvv = base(
        "head-mtvv",
        "Head vibration, maximum transient vibration value (ISO 2631-1)",
    );
    mtvv["valueQuantity"] = ucum(number(&["vector", "mtvv_m_s2"])?, "m/s2", "m/s2");
    observations.push(mtvv);
    let mut vdv = base(
        "head-vdv",
        "Head vibration, vibration dose value (ISO 2631-1)",
    );
    // m/s^1.75: no UCUM code (UCUM has integer exponents only): a unit text alone.
    vdv["valueQuantity"] = json!({"value": number(&["vector", "vdv_m_s175"])?, "unit": "m/s^1.75"});
    observations.push(vdv);
    let mut levels = base("time-at-alert-level", "Time at each vibration alert level");
    levels["component"] = Value::Array(
        ["normal", "advisory", "warning", "alarm"]
            .iter()
            .map(|level| {
                Ok(json!({
                    "code": {
                        "coding": [{"system": CODE_SYSTEM, "code": format!("time-at-{level}"),
                                    "display": format!("Time at {level}")}],
                        "text": format!("Time at {level}")
                    },
                    "valueQuantity": ucum(number(&["time_at_level_s", level])?, "s", "s")
                }))
            })
            .collect::<Result<_>>()?,
    );
    observations.push(levels);
    if let Some(joints) = mission["joints"].as_array().filter(|j| !j.is_empty()) {
        let mut excursions = base(
            "joint-largest-excursion",
            "Largest predicted spinal joint excursions",
        );
        excursions["component"] = Value::Array(
            joints
                .iter()
                .map(|j| {
                    let output = j["output"].as_str().unwrap_or("?");
                    let unit = j["unit"].as_str().unwrap_or("?");
                    let value = j["largest_excursion"].as_f64().ok_or_else(|| {
                        anyhow!("mission {}: joint {output} has no largest_excursion", m.id)
                    })?;
                    let display = format!("Largest excursion, {output}");
                    Ok(json!({
                        "code": {
                            "coding": [{"system": CODE_SYSTEM,
                                        "code": format!("largest-excursion-{output}"),
                                        "display": display}],
                            "text": display
                        },
                        "valueQuantity": ucum(value, unit, unit)
                    }))
                })
                .collect::<Result<_>>()?,
        );
        observations.push(excursions);
    }
    let entries: Vec<Value> = observations
        .into_iter()
        .enumerate()
        .map(|(i, resource)| {
            json!({"fullUrl": format!("urn:uuid:{}", entry_uuid(m, i)), "resource": resource})
        })
        .collect();
    Ok(json!({
        "resourceType": "Bundle",
        "type": "collection",
        "timestamp": Timestamp::now().to_string(),
        "entry": entries
    }))
}

/// A stable UUID for entry `index` of mission `m` (a version-8 UUID from a SHA-256 of
/// the mission's id, its rides' hashes and the index), so that exporting twice names the
/// same Observations.
fn entry_uuid(m: &MissionSummary, index: usize) -> uuid::Uuid {
    let mut h = Sha256::new();
    h.update(m.id.to_le_bytes());
    for r in &m.rides {
        h.update(r.sha256.as_bytes());
    }
    h.update((index as u64).to_le_bytes());
    let digest = h.finalize();
    let mut bytes = [0u8; 16];
    bytes.copy_from_slice(&digest[..16]);
    uuid::Uuid::new_v8(bytes)
}
