//! The markup helpers every section of the page uses: escaping, a level's coloured tag and
//! a chart as a figure. A leaf: it imports no other module of `report`, so the numbers
//! and the charts never depend on the page's HTML.

use std::fmt::Write as _;

use anyhow::Result;
use supine_core::alerts::Level;

use crate::plot::time_chart::Chart;

/// Escapes text for HTML element content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A level's name as a coloured tag (the page's style sheet colours `tag-<level>`).
pub fn tag(level: Level) -> String {
    let level = level.name();
    format!("<span class=\"tag tag-{level}\">{level}</span>")
}

/// A chart as a figure, with its caption when there is one.
pub fn figure(h: &mut String, chart: &Chart, caption: &str) -> Result<()> {
    let svg = chart.to_svg()?;
    let _ = write!(h, "<figure>\n{svg}\n");
    if !caption.is_empty() {
        let _ = writeln!(h, "<figcaption>{caption}</figcaption>");
    }
    h.push_str("</figure>\n");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_covers_markup_and_quotes() {
        assert_eq!(
            escape("<script>alert(\"x\") & 'y'</script>"),
            "&lt;script&gt;alert(&quot;x&quot;) &amp; &#39;y&#39;&lt;/script&gt;"
        );
        assert_eq!(escape("0.1.0+qemu"), "0.1.0+qemu");
    }

    #[test]
    fn a_tag_names_its_level_and_its_colour_class() {
        assert_eq!(
            tag(Level::Warning),
            "<span class=\"tag tag-warning\">warning</span>"
        );
    }
}
