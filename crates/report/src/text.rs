//! Text helpers of every section: HTML escaping, centimetres, the "what this means" line. A leaf
//! module, so the page, the plots and the sections import it without importing each other.

use std::fmt::Write as _;

/// Escapes text for HTML content and attribute values.
pub(crate) fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// Metres → centimetres, two decimals ("—" for a non-finite value).
pub(crate) fn cm(m: f64) -> String {
    if m.is_finite() {
        format!("{:.2}", m * 100.0)
    } else {
        "—".into()
    }
}

pub(crate) fn meaning(o: &mut String, text: &str) {
    let _ = writeln!(
        o,
        "<p class=\"meaning\"><strong>What this means:</strong> {text}</p>"
    );
}

/// Centimetres, or a dash when there is no value.
pub(crate) fn cm_opt(m: Option<f64>) -> String {
    m.map(cm).unwrap_or_else(|| "—".into())
}

/// Signed centimetres with a sign.
pub(crate) fn cm_signed(m: f64) -> String {
    if m.is_finite() {
        format!("{:+.2}", m * 100.0)
    } else {
        "—".into()
    }
}
