//! The report's "Neck and lower back" section: the predicted joint motion of each leg (the
//! values `supine exposure` gives) and of the mission ([`crate::report::mission_joints`];
//! `docs/exposure.md`, "Neck and lower back").
//!
//! No standard sets limits for a supine patient's spinal motion, so the section reports and
//! does not judge: no thresholds, no levels.

use std::fmt::Write as _;

use crate::report::charts::{self, Layout};
use crate::report::markup::{escape, figure};
use crate::report::mission::Leg;
use crate::report::mission_joints::MissionJoint;
use anyhow::Result;

/// The section: what the numbers are, the mission table (not for two compared rides,
/// which are not one mission), the legs' largest excursions side by side, and the running
/// rms charts of both joints' translations.
pub fn section(
    h: &mut String,
    legs: &[Leg],
    mission: &[MissionJoint],
    layout: Layout,
) -> Result<()> {
    if mission.is_empty() {
        return Ok(());
    }
    h.push_str(
        "<section><h2>Neck and lower back</h2>\n<p>What the model predicts at its two joints, \
         which no sensor on the litter can see: the head relative to the torso (neck) and the \
         torso relative to the pelvis (lower back). x is along the spine (compression and \
         distraction), y lateral shear, z anteroposterior shear, in mm; ry flexion and \
         extension, rz lateral bending, in degrees. <strong>No standard sets limits for a \
         supine patient's spinal motion</strong>: these values are reported, not judged, and \
         any threshold is a medical director's to set (see the project's docs/exposure.md).</p>\n",
    );
    if layout == Layout::Mission {
        mission_table(h, mission);
    }
    if legs.len() > 1 {
        legs_table(h, legs, mission);
    }
    for (first_output, title, caption) in [
        (
            0,
            "Neck: head relative to torso, translations",
            "The neck's 1 s running rms along the spine (x), lateral (y) and anteroposterior (z).",
        ),
        (
            5,
            "Lower back: torso relative to pelvis, translations",
            "The lower back's 1 s running rms along the spine (x), lateral (y) and anteroposterior (z).",
        ),
    ] {
        figure(
            h,
            &charts::joint_translations(legs, layout, first_output, title),
            caption,
        )?;
    }
    h.push_str("</section>\n");
    Ok(())
}

fn mission_table(h: &mut String, mission: &[MissionJoint]) {
    h.push_str(
        "<table><tr><th class=\"text\">output</th><th class=\"text\">unit</th><th>rms</th>\
         <th>largest running rms (1 s)</th><th>largest excursion</th><th>at (mission time)</th>\
         <th>leg</th></tr>\n",
    );
    for j in mission {
        let _ = writeln!(
            h,
            "<tr><td class=\"text\">{}</td><td class=\"text\">{}</td><td>{:.4}</td><td>{:.4}</td>\
             <td>{:.4}</td><td>{:.2} s</td><td>{}</td></tr>",
            j.output,
            j.unit,
            j.rms,
            j.max_running_rms,
            j.largest_excursion,
            j.largest_excursion_at_mission_s,
            j.largest_excursion_leg
        );
    }
    h.push_str("</table>\n");
}

fn legs_table(h: &mut String, legs: &[Leg], mission: &[MissionJoint]) {
    h.push_str("<table><tr><th class=\"text\">largest excursion</th>");
    for (i, leg) in legs.iter().enumerate() {
        let _ = write!(h, "<th>{}</th>", escape(&charts::leg_label(i, leg)));
    }
    h.push_str("</tr>\n");
    for (o, j) in mission.iter().enumerate() {
        let _ = write!(h, "<tr><td class=\"text\">{}, {}</td>", j.output, j.unit);
        for leg in legs {
            let v = leg.joints.get(o).map_or(0.0, |r| r.largest_excursion);
            let _ = write!(h, "<td>{v:.4}</td>");
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
}
