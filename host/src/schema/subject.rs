//! The patient as outputs name them: one record wherever a command prints who the device
//! (or a parameter file) was set up for.

use serde::Serialize;

use crate::schema::shortest;

/// A patient's height and mass, each the shortest decimal of the f32 the device holds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SubjectRecord {
    /// Height, m.
    pub height_m: f64,
    /// Mass, kg.
    pub mass_kg: f64,
}

impl SubjectRecord {
    /// The record of the device's `height_m` and `mass_kg`.
    pub fn new(height_m: f32, mass_kg: f32) -> Self {
        Self {
            height_m: shortest(height_m),
            mass_kg: shortest(mass_kg),
        }
    }
}
