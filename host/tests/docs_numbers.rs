//! The numbers the README and `docs/` quote that the code defines: every statement of the
//! protocol version, the blob format version, the largest frame, the blob header, the
//! exposure warm-up and the PARAMS region equals the code's constant (or `memory.x`), and
//! every recording header quoted is the code's, so a bump, a change of default or a renamed
//! column that leaves a document behind fails here.
//!
//! Checked on the text: each pattern finds the number right after its words; a sentence
//! about an older version says so with "bump", "older", "earlier" or "was" just before.

use std::fs;
use std::path::{Path, PathBuf};

use supine_core::blob::{BLOB_FORMAT_VERSION, BLOB_HEADER_LEN};
use supine_core::exposure::ExposureConfig;
use supine_core::protocol::{MAX_FRAME_LEN, PROTOCOL_VERSION};
use supine_host::io::recording::{COLUMNS, HEADER_LINE, OLD_COLUMNS};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace")
        .to_path_buf()
}

/// README.md and every `docs/*.md`, with their names.
fn documents() -> Vec<(String, String)> {
    let mut docs = vec![("README.md".to_string(), root().join("README.md"))];
    let mut names: Vec<PathBuf> = fs::read_dir(root().join("docs"))
        .expect("docs/ readable")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    names.sort();
    for p in names {
        docs.push((
            format!("docs/{}", p.file_name().unwrap().to_string_lossy()),
            p,
        ));
    }
    docs.into_iter()
        .map(|(name, p)| (name, fs::read_to_string(&p).expect("readable")))
        .collect()
}

/// Every number that follows `words` (case-insensitive, then at most `gap` characters
/// of the same sentence), with the text just before it; statements about history skipped.
fn stated_after(text: &str, words: &str, gap: usize) -> Vec<(u64, String)> {
    let lower = text.to_lowercase();
    let mut found = Vec::new();
    for (at, _) in lower.match_indices(&words.to_lowercase()) {
        let before = &lower[at.saturating_sub(60)..at];
        if ["bump", "older", "earlier", " was ", "previous"]
            .iter()
            .any(|w| before.contains(w))
        {
            continue;
        }
        let rest = &lower[at + words.len()..];
        let window: String = rest.chars().take(gap).take_while(|c| *c != '.').collect();
        let digits: String = window
            .chars()
            .skip_while(|c| !c.is_ascii_digit())
            .take_while(|c| c.is_ascii_digit())
            .collect();
        if let Ok(n) = digits.parse() {
            found.push((
                n,
                text[at..(at + words.len() + window.len()).min(text.len())].to_string(),
            ));
        }
    }
    found
}

fn check(words: &str, gap: usize, expected: u64) -> usize {
    let mut seen = 0;
    for (name, text) in documents() {
        for (n, quote) in stated_after(&text, words, gap) {
            assert_eq!(
                n, expected,
                "{name} says \"{quote}\": the code has {expected}"
            );
            seen += 1;
        }
    }
    seen
}

#[test]
fn the_documents_state_the_protocol_and_blob_versions_the_code_has() {
    assert!(check("protocol is at version", 4, PROTOCOL_VERSION.into()) > 0);
    assert!(check("blob format is at version", 4, BLOB_FORMAT_VERSION.into()) > 0);
}

#[test]
fn the_documents_state_the_frame_and_header_sizes_the_code_has() {
    assert!(
        check(
            "COBS framing (a zero byte ends each frame), at most",
            4,
            MAX_FRAME_LEN as u64
        ) > 0
    );
    assert!(check("parameter blob is a", 3, BLOB_HEADER_LEN as u64) > 0);
}

#[test]
fn the_documents_state_the_warm_up_the_core_defaults_to() {
    let warmup_s = ExposureConfig::DEFAULT.warmup_s;
    assert_eq!(
        warmup_s.fract(),
        0.0,
        "the documents quote a whole number of seconds"
    );
    let mut seen = 0;
    for (name, text) in documents() {
        for (at, _) in text.match_indices(" s warm-up") {
            let digits: String = text[..at]
                .chars()
                .rev()
                .take_while(|c| c.is_ascii_digit())
                .collect();
            let n: u64 = digits
                .chars()
                .rev()
                .collect::<String>()
                .parse()
                .expect("a number");
            assert_eq!(
                n, warmup_s as u64,
                "{name} says a {n} s warm-up: the core's default is {warmup_s} s"
            );
            seen += 1;
        }
    }
    assert!(seen > 0);
}

#[test]
fn the_readme_states_the_params_region_memory_x_reserves() {
    let memory = fs::read_to_string(root().join("memory.x")).expect("memory.x");
    let line = memory
        .lines()
        .find(|l| l.trim_start().starts_with("PARAMS"))
        .expect("a PARAMS region in memory.x");
    assert!(line.contains("ORIGIN = 0x00070000") && line.contains("LENGTH = 64K"));
    let readme = fs::read_to_string(root().join("README.md")).expect("README.md");
    assert!(
        readme.contains("64 KiB PARAMS region at 0x0007_0000"),
        "README.md: expected the PARAMS region memory.x reserves ({line})"
    );
}

/// The column names a document quotes from `at` on (`time_s,platform_x_m_s2,...`), read
/// across a line break after a comma.
fn quoted_columns(text: &str, at: usize) -> Vec<String> {
    let mut quoted = String::new();
    let mut chars = text[at..].chars().peekable();
    while let Some(c) = chars.next() {
        let in_name = c.is_ascii_alphanumeric() || c == '_';
        if in_name || (c == ',' && chars.peek().is_some_and(|n| n.is_ascii_alphanumeric())) {
            quoted.push(c);
        } else if c == ',' && chars.peek() == Some(&'\n') {
            quoted.push(c);
            while chars.peek().is_some_and(|n| n.is_whitespace()) {
                chars.next();
            }
        } else {
            break;
        }
    }
    quoted.split(',').map(String::from).collect()
}

#[test]
fn the_recording_headers_the_documents_quote_are_the_codes() {
    // The format's own pages give the header whole.
    let all = documents();
    for page in ["docs/fitting.md", "docs/model.md"] {
        let (_, text) = all.iter().find(|(name, _)| name == page).expect(page);
        assert!(
            text.contains(HEADER_LINE),
            "{page} does not quote {HEADER_LINE}"
        );
    }
    // Every header quoted anywhere is the first columns of today's names or of the names
    // before units, in order.
    let mut quoted = 0;
    for (name, text) in &all {
        for (at, _) in text.match_indices("time_s,platform_") {
            let columns = quoted_columns(text, at);
            let prefix_of = |naming: &[&str; 13]| {
                columns.len() <= naming.len() && columns.iter().zip(naming).all(|(c, n)| c == n)
            };
            assert!(
                prefix_of(&COLUMNS) || prefix_of(&OLD_COLUMNS),
                "{name}: a recording header {} that is not the code's",
                columns.join(",")
            );
            quoted += 1;
        }
    }
    assert!(quoted >= 6, "{quoted} headers quoted");
}
