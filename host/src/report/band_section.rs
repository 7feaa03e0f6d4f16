//! The prediction band's table on the report's page ([`crate::report::prediction_band`]
//! computes it).

use std::fmt::Write as _;

use crate::report::charts::leg_label;
use crate::report::markup::escape;
use crate::report::mission::Leg;
use crate::report::prediction_band::ReportBand;

/// The band as a small table of the page's exposure section; `total` names the last row
/// (the mission, or both rides of a comparison).
pub fn html(band: &ReportBand, legs: &[Leg], total: &str) -> String {
    let [low, median, high] = band.quantiles.map(|q| 100.0 * q);
    let mut h = format!(
        "<h3>Prediction band</h3><p>The head's vector values from {} parameter sets drawn \
         from the fit's uncertainty (seed {}): the {low:.1} %, {median:.0} % and {high:.1} % \
         quantiles over the draws. The band is the fitted mean model's parameter \
         uncertainty only: not the spread between patients, and not the error of the \
         model's structure.</p>\n<table><tr><th></th><th>rms at the fit, m/s<sup>2</sup></th>\
         <th>{low:.1} %</th><th>{median:.0} %</th><th>{high:.1} %</th>\
         <th>VDV at the fit, m/s<sup>1.75</sup></th><th>{low:.1} %</th><th>{median:.0} %</th>\
         <th>{high:.1} %</th></tr>\n",
        band.draws, band.seed
    );
    let labels = legs
        .iter()
        .enumerate()
        .map(|(i, leg)| leg_label(i, leg))
        .chain([total.to_string()]);
    for (label, row) in labels.zip(band.legs.iter().chain([&band.mission])) {
        let _ = write!(h, "<tr><td>{}</td>", escape(&label));
        for v in [&row.vector_rms_m_s2, &row.vector_vdv_m_s175] {
            let _ = write!(
                h,
                "<td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td>",
                v.nominal, v.low, v.median, v.high
            );
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
    h
}
