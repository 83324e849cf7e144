//! What every HTML report shares: its style sheet, and the escaping of text put into it.

/// Escapes `s` for HTML text and attribute values.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The style sheet of every report (one column at most 1000 px wide; nothing wider overflows).
pub(crate) const STYLE: &str = "body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ccc}\
.verdict{font-size:1.4em;padding:.5em 1em;border-radius:6px;display:inline-block}\
.accept{background:#d9f2d9}.review{background:#fff3cd}.reject{background:#f8d7da}\
table{border-collapse:collapse;margin:.5em 0}td,th{padding:2px 10px;text-align:right;border-bottom:1px solid #eee}\
th{background:#f4f4f4}td:first-child,th:first-child{text-align:left}.fig{margin:1em 0}\
pre{white-space:pre-wrap;overflow-wrap:anywhere}";
