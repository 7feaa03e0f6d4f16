//! Quoting input in error messages: a bounded excerpt with non-printable bytes escaped, so
//! that one bad field (a megabyte of text, NUL bytes, terminal escapes) cannot turn an error
//! into a flood, or a terminal's control sequence, and the message stays one line.

use std::borrow::Cow;
use std::fmt::Write as _;

/// Most characters of input an error message quotes (escapes count by what they print):
/// enough to recognise a field, and short enough that the message with its path and what
/// was expected stays within about 200 characters.
pub const MAX_EXCERPT_CHARS: usize = 60;

/// Most characters of a name quoted beside other text (a key or subject id named as the
/// context of an error, a key inside a parser's own message).
pub const MAX_NAME_CHARS: usize = 32;

/// `bytes` in double quotes as an error message quotes input: at most
/// [`MAX_EXCERPT_CHARS`] characters, control characters and quotes escaped as Rust writes
/// them (`\0`, `\n`, `\u{1b}`, `\"`), bytes that are not UTF-8 as `\xNN`; a longer input
/// is cut and says how long it was: `"aaaa..." (1000000 bytes)`.
pub fn excerpt(bytes: impl AsRef<[u8]>) -> String {
    excerpt_within(bytes.as_ref(), MAX_EXCERPT_CHARS)
}

fn excerpt_within(bytes: &[u8], max_chars: usize) -> String {
    let mut out = String::from("\"");
    let mut shown = 0;
    let mut cut = false;
    'chunks: for chunk in bytes.utf8_chunks() {
        for c in chunk.valid().chars() {
            let escaped = escape(c);
            if shown + escaped.chars().count() > max_chars {
                cut = true;
                break 'chunks;
            }
            shown += escaped.chars().count();
            out.push_str(&escaped);
        }
        for b in chunk.invalid() {
            if shown + 4 > max_chars {
                cut = true;
                break 'chunks;
            }
            shown += 4;
            let _ = write!(out, "\\x{b:02x}");
        }
    }
    out.push('"');
    if cut {
        let _ = write!(out, "... ({} bytes)", bytes.len());
    }
    out
}

/// A name taken from the input (a header field, a column asked for) in double quotes, as
/// [`excerpt`] quotes input but within [`MAX_NAME_CHARS`], so that several fit on one line:
/// `"acc X"`, `"acc\u{1b}[2J"`, `"AAAA..." (1000000 bytes)`.
pub fn quoted_name(bytes: impl AsRef<[u8]>) -> String {
    excerpt_within(bytes.as_ref(), MAX_NAME_CHARS)
}

/// A name taken from the input (a key, a subject id) as a message shows it: as it is when
/// it is printable and at most [`MAX_NAME_CHARS`] long, else quoted like [`excerpt`] within
/// that many characters.
pub fn name(text: &str) -> Cow<'_, str> {
    bare_or_quoted(text, MAX_NAME_CHARS)
}

/// A value taken from the input's text (a TOML value as written) as a message shows it:
/// as it is when it is printable and at most [`MAX_EXCERPT_CHARS`] long, else
/// [`excerpt`].
pub fn value(text: &str) -> Cow<'_, str> {
    bare_or_quoted(text, MAX_EXCERPT_CHARS)
}

fn bare_or_quoted(text: &str, max_chars: usize) -> Cow<'_, str> {
    if text.chars().count() <= max_chars && escape_free(text) {
        Cow::Borrowed(text)
    } else {
        Cow::Owned(excerpt_within(text.as_bytes(), max_chars))
    }
}

fn escape_free(text: &str) -> bool {
    text.chars().all(|c| escape(c).len() == c.len_utf8())
}

/// A number read from the input as a message shows it: Rust's shortest form, in exponent
/// form from 1e15 on and below 1e-6, so that neither 1e300 nor 1e-320 prints as hundreds
/// of digits (at most 24 characters).
pub fn number(v: f64) -> String {
    if v.is_finite() && (v.abs() >= 1e15 || (v != 0.0 && v.abs() < 1e-6)) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A parser's message (TOML, serde) made safe to print: control characters escaped, and
/// each part it quotes between backquotes or double quotes cut to [`MAX_NAME_CHARS`]
/// characters (serde quotes the offending key or value whole, however long, beside a list
/// of what it expected).
pub fn bound_quoted_parts(message: &str) -> String {
    let mut out = String::with_capacity(message.len().min(4 * MAX_EXCERPT_CHARS));
    let mut quote: Option<char> = None;
    let mut inside = 0usize;
    // Inside double quotes, serde escapes like Rust: `\"` does not end the quote.
    let mut escaped = false;
    for c in message.chars() {
        match quote {
            None => {
                if c == '`' || c == '"' {
                    quote = Some(c);
                    inside = 0;
                    escaped = false;
                }
                push_printable(&mut out, c);
            }
            Some(q) if c == q && !escaped => {
                if inside > MAX_NAME_CHARS {
                    let _ = write!(out, "{q}... ({inside} characters)");
                } else {
                    out.push(q);
                }
                quote = None;
            }
            Some(q) => {
                escaped = q == '"' && c == '\\' && !escaped;
                inside += 1;
                if inside <= MAX_NAME_CHARS {
                    push_printable(&mut out, c);
                }
            }
        }
    }
    if quote.is_some() && inside > MAX_NAME_CHARS {
        let _ = write!(out, "... ({inside} characters)");
    }
    out
}

/// How `c` appears in an excerpt: itself if printable, else Rust's escape for it.
fn escape(c: char) -> String {
    match c {
        // An apostrophe prints as itself; Rust's debug escape would add a backslash.
        '\'' => c.to_string(),
        _ => c.escape_debug().to_string(),
    }
}

/// `c` onto `out`, escaped when it is a control character (quotes and backslashes of an
/// already escaped message stay as they are).
fn push_printable(out: &mut String, c: char) {
    if c.is_control() {
        out.extend(c.escape_debug());
    } else {
        out.push(c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_printable_fields_are_quoted_as_they_are() {
        assert_eq!(excerpt("1.5e-3"), "\"1.5e-3\"");
        assert_eq!(excerpt("é l'axe"), "\"é l'axe\"");
        assert_eq!(excerpt(""), "\"\"");
    }

    #[test]
    fn control_characters_quotes_and_invalid_bytes_are_escaped() {
        assert_eq!(excerpt(b"a\0b\n\x1b[2J\""), r#""a\0b\n\u{1b}[2J\"""#);
        assert_eq!(excerpt(b"\xff\xfe1"), r#""\xff\xfe1""#);
        assert_eq!(excerpt("\u{feff}x"), r#""\u{feff}x""#);
    }

    #[test]
    fn a_long_field_is_cut_to_the_limit_and_says_its_length() {
        let long = "x".repeat(1_000_000);
        let e = excerpt(&long);
        assert_eq!(
            e,
            format!("\"{}\"... (1000000 bytes)", "x".repeat(MAX_EXCERPT_CHARS))
        );
        // Escapes count by what they print: 30 NULs fill the 60 characters.
        let nul = excerpt(vec![0u8; 1000]);
        assert_eq!(nul, format!("\"{}\"... (1000 bytes)", "\\0".repeat(30)));
        // Exactly the limit is not cut.
        let fits = "y".repeat(MAX_EXCERPT_CHARS);
        assert_eq!(excerpt(&fits), format!("\"{fits}\""));
    }

    #[test]
    fn names_show_as_they_are_unless_long_or_unprintable() {
        assert_eq!(name("s1"), "s1");
        assert_eq!(name("a b"), "a b");
        assert_eq!(name("a\nb"), "\"a\\nb\"");
        assert_eq!(
            name(&"k".repeat(33)),
            format!("\"{}\"... (33 bytes)", "k".repeat(32))
        );
        assert_eq!(
            value("[[1, 0, 0], [0, 1, 0], [0, 0, 2]]"),
            "[[1, 0, 0], [0, 1, 0], [0, 0, 2]]"
        );
        assert_eq!(value("[1,\n2]"), "\"[1,\\n2]\"");
    }

    #[test]
    fn quoted_names_are_quoted_once_escaped_and_cut() {
        assert_eq!(quoted_name("acc X"), "\"acc X\"");
        assert_eq!(quoted_name(b"acc\x1b[2J\xff"), "\"acc\\u{1b}[2J\\xff\"");
        assert_eq!(
            quoted_name("A".repeat(1_000_000)),
            format!("\"{}\"... (1000000 bytes)", "A".repeat(MAX_NAME_CHARS))
        );
    }

    #[test]
    fn numbers_stay_short_however_large() {
        assert_eq!(number(-1.0), "-1");
        assert_eq!(number(0.485), "0.485");
        assert_eq!(number(1e300), "1e300");
        assert_eq!(number(-2.5e20), "-2.5e20");
        assert_eq!(number(f64::NAN), "NaN");
        assert_eq!(number(1e-320), "1e-320");
        assert_eq!(number(-2.5e-7), "-2.5e-7");
        assert_eq!(number(0.0), "0");
    }

    #[test]
    fn parser_messages_keep_their_text_but_not_a_flood_or_raw_controls() {
        let key = "b".repeat(500);
        let message = format!("unknown field `{key}`, expected `x` or `s`");
        assert_eq!(
            bound_quoted_parts(&message),
            format!(
                "unknown field `{}`... (500 characters), expected `x` or `s`",
                "b".repeat(MAX_NAME_CHARS)
            )
        );
        let value = format!(
            "invalid type: string \"{}\\\"\\0\", expected f32",
            "a".repeat(40)
        );
        let bounded = bound_quoted_parts(&value);
        assert!(
            bounded.ends_with("... (44 characters), expected f32"),
            "{bounded}"
        );
        assert_eq!(
            bound_quoted_parts("unknown field `a\0\n`, expected `x`"),
            "unknown field `a\\0\\n`, expected `x`"
        );
        assert_eq!(bound_quoted_parts("duplicate key"), "duplicate key");
        // An escaped backslash before the closing quote still closes it.
        let backslash = r#"invalid type: string "a\\", expected f32"#;
        assert_eq!(bound_quoted_parts(backslash), backslash);
    }
}
