//! The naming rules applied to an output as a script reads it: a JSON value or a CSV
//! file's text. Used by the tests that run every command (`host/tests/output_names.rs`,
//! and the QEMU tests for the commands that need the device).

use serde_json::Value;

use super::{is_snake_case, names_a_number};

/// The names in `value` (reached by `path`, e.g. the command's name) that break the
/// rules, each with where it is: keys not `snake_case`, and numbers whose key has no
/// unit, unless an enclosing key carries it (`"rms_m_s2": {"x": ..}`) or the object
/// names it in a `unit` field.
pub fn json_problems(value: &Value, path: &str) -> Vec<String> {
    let mut out = Vec::new();
    walk(value, path, false, &mut out);
    out
}

fn walk(value: &Value, path: &str, unit_given: bool, out: &mut Vec<String>) {
    match value {
        Value::Object(map) => {
            let unit_here = unit_given || map.get("unit").is_some_and(Value::is_string);
            for (key, v) in map {
                let at = format!("{path}.{key}");
                if !is_snake_case(key) {
                    out.push(format!("{at}: not snake_case"));
                }
                let numeric = v.is_number()
                    || v.as_array()
                        .is_some_and(|a| !a.is_empty() && a.iter().all(numeric_or_array));
                if numeric && !unit_here && !names_a_number(key) {
                    out.push(format!("{at}: a number without a unit in its name"));
                }
                let carries_unit = unit_here || (names_a_number(key) && !v.is_number());
                walk(v, &at, carries_unit, out);
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                walk(v, &format!("{path}[{i}]"), unit_given, out);
            }
        }
        _ => {}
    }
}

fn numeric_or_array(v: &Value) -> bool {
    v.is_number() || v.is_null() || v.as_array().is_some_and(|a| a.iter().all(numeric_or_array))
}

/// The header names of a CSV file's `text` (called `file` in the messages) that break
/// the rules: not `snake_case`, or a column whose first value is a number without a unit
/// in its name (none is needed beside a `unit` column).
pub fn csv_problems(text: &str, file: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let Some(header) = lines.next() else {
        return vec![format!("{file}: no header")];
    };
    let header: Vec<&str> = header.split(',').collect();
    let first: Vec<&str> = lines.next().map_or(vec![], |l| l.split(',').collect());
    let unit_column = header.contains(&"unit");
    for (k, column) in header.iter().enumerate() {
        if !is_snake_case(column) {
            out.push(format!("{file}: column {column}: not snake_case"));
        }
        let numeric = first.get(k).is_some_and(|v| v.parse::<f64>().is_ok());
        if numeric && !unit_column && !names_a_number(column) {
            out.push(format!("{file}: column {column}: a number without a unit"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_number_without_a_unit_and_a_name_not_in_snake_case_are_caught() {
        let bad = serde_json::json!({"head_x": 1.0, "Level": "alarm", "rms_m_s2": {"x": 1.0},
            "joints": [{"unit": "mm", "rms": 2.0}]});
        assert_eq!(
            json_problems(&bad, "bad"),
            [
                "bad.Level: not snake_case",
                "bad.head_x: a number without a unit in its name"
            ]
        );
        let csv = "sample,time_s,head_accel,platform_x,alert_level\n1,0.002,0.5,0.1,normal\n";
        assert_eq!(
            csv_problems(csv, "t.csv"),
            [
                "t.csv: column head_accel: a number without a unit",
                "t.csv: column platform_x: a number without a unit"
            ]
        );
    }
}
