//! The readings of a static tumble test, for `supine calibrate --tumble FILE.csv`.
//!
//! A CSV file with the header `orientation,x_m_s2,y_m_s2,z_m_s2`: one or more rows per
//! orientation, each a reading of the sensor (sensor axes, m/s^2, as its datasheet scales
//! them) held still with the named axis pointing up (`+x`, `-x`, `+y`, `-y`, `+z`, `-z`;
//! `-x` up is x pointing down). The rows of an orientation are averaged; all six must be
//! there.

use std::path::Path;

use anyhow::{Result, anyhow, bail};

use crate::io::excerpt::value;
use crate::io::small_file::read_text;

/// The header line the file must start with.
pub const TUMBLE_HEADER: &str = "orientation,x_m_s2,y_m_s2,z_m_s2";

/// The orientations, in the order of [`TumbleReadings::mean_m_s2`]: axis `i / 2` up when
/// `i` is even, down when odd.
pub const ORIENTATIONS: [&str; 6] = ["+x", "-x", "+y", "-y", "+z", "-z"];

/// Largest tumble file read, bytes (a few minutes of readings at 400 Hz).
const MAX_TUMBLE_BYTES: u64 = 32 * 1024 * 1024;

/// The mean reading in each orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TumbleReadings {
    /// Mean reading (sensor x, y, z, m/s^2) per orientation, in [`ORIENTATIONS`] order.
    pub mean_m_s2: [[f64; 3]; 6],
    /// Rows averaged per orientation.
    pub rows: [usize; 6],
}

/// Reads `path`; an error names the file, the line and the field, and what was expected.
pub fn read(path: &Path) -> Result<TumbleReadings> {
    let text = read_text(path, "tumble-test file", MAX_TUMBLE_BYTES)?;
    parse(&text).map_err(|e| anyhow!("{}: {e}", path.display()))
}

fn parse(text: &str) -> Result<TumbleReadings> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    match lines.next() {
        Some((_, header)) if header.trim() == TUMBLE_HEADER => {}
        Some((n, header)) => bail!(
            "line {}: expected the header {TUMBLE_HEADER}, found {}",
            n + 1,
            value(header.trim())
        ),
        None => bail!("expected the header {TUMBLE_HEADER}, found an empty file"),
    }
    let mut sums = [[0.0f64; 3]; 6];
    let mut rows = [0usize; 6];
    for (n, line) in lines {
        let line_no = n + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != 4 {
            bail!(
                "line {line_no}: expected 4 fields ({TUMBLE_HEADER}), found {}",
                cells.len()
            );
        }
        let Some(k) = ORIENTATIONS.iter().position(|o| *o == cells[0]) else {
            bail!(
                "line {line_no}, orientation: expected one of {}, found {}",
                ORIENTATIONS.join(", "),
                value(cells[0])
            );
        };
        for (axis, (cell, name)) in cells[1..]
            .iter()
            .zip(["x_m_s2", "y_m_s2", "z_m_s2"])
            .enumerate()
        {
            let v: f64 = cell
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    anyhow!(
                        "line {line_no}, {name}: expected a number in m/s^2, found {}",
                        value(cell)
                    )
                })?;
            sums[k][axis] += v;
        }
        rows[k] += 1;
    }
    let missing: Vec<&str> = ORIENTATIONS
        .iter()
        .zip(rows)
        .filter(|(_, n)| *n == 0)
        .map(|(o, _)| *o)
        .collect();
    if !missing.is_empty() {
        bail!(
            "expected readings in all six orientations, found none for {}",
            missing.join(", ")
        );
    }
    let mean_m_s2 = std::array::from_fn(|k| sums[k].map(|s| s / rows[k] as f64));
    Ok(TumbleReadings { mean_m_s2, rows })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_averaged_per_orientation() {
        let text = format!(
            "{TUMBLE_HEADER}\n+x,9.8,0.1,0\n+x,9.9,0.1,0\n-x,-9.7,0,0\n+y,0,9.8,0\n\
             -y,0,-9.8,0\n+z,0,0,9.8\n\n-z,0,0,-9.8\n"
        );
        let r = parse(&text).unwrap();
        assert_eq!(r.rows, [2, 1, 1, 1, 1, 1]);
        assert!((r.mean_m_s2[0][0] - 9.85).abs() < 1e-12);
        assert_eq!(r.mean_m_s2[1], [-9.7, 0.0, 0.0]);
    }

    #[test]
    fn bad_files_name_the_line_and_field() {
        let err = |t: &str| parse(t).unwrap_err().to_string();
        assert!(err("a,b\n").contains("line 1: expected the header"));
        let e = err(&format!("{TUMBLE_HEADER}\n+q,1,2,3\n"));
        assert!(e.contains("line 2, orientation: expected one of +x"), "{e}");
        let e = err(&format!("{TUMBLE_HEADER}\n+x,1,nan,3\n"));
        assert!(e.contains("line 2, y_m_s2: expected a number"), "{e}");
        let e = err(&format!("{TUMBLE_HEADER}\n+x,1,2,3\n"));
        assert!(e.contains("found none for -x, +y, -y, +z, -z"), "{e}");
    }
}
