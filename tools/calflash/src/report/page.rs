//! What every HTML report shares: its style sheet, and the escaping of text put into it.

/// Escapes `s` for HTML text and attribute values.
pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The typeface every report names, in its text and its figures: DejaVu Sans (Debian's
/// `fonts-dejavu-core`, which `cargo xtask test` installs beside Chromium), then the reader's
/// sans-serif. Named, so that a page lays out the same on every machine that has it: the generic
/// `sans-serif` is whatever font the machine's fontconfig prefers.
pub(crate) const FONT: &str = "DejaVu Sans, sans-serif";

/// The style sheet of every report (one column at most 1000 px wide; nothing wider overflows).
pub(crate) const STYLE: &str = "body{font-family:'DejaVu Sans',sans-serif;max-width:1000px;margin:2em auto;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ccc}\
.verdict{font-size:1.4em;padding:.5em 1em;border-radius:6px;display:inline-block}\
.accept{background:#d9f2d9}.review{background:#fff3cd}.reject{background:#f8d7da}\
table{border-collapse:collapse;margin:.5em 0}td,th{padding:2px 10px;text-align:right;border-bottom:1px solid #eee}\
th{background:#f4f4f4}.terms td{white-space:nowrap}td:first-child,th:first-child{text-align:left}.fig{margin:1em 0}\
.fig svg{display:block;max-width:100%;height:auto}\
.panels{display:grid;grid-template-columns:repeat(3,325px);gap:0 12px}.panels .fig{margin:.3em 0}.key{margin:.5em 0 0}\
pre{font-family:'DejaVu Sans Mono',monospace;white-space:pre-wrap;overflow-wrap:anywhere}\
.contents{background:#f7f7f7;padding:.5em 1em;border-radius:6px}.contents ol{columns:2;margin:.3em 0}\
@page{size:A4;margin:14mm 12mm 16mm;@bottom-center{content:'page ' counter(page) ' of ' counter(pages);font-size:8pt;color:#555}}\
@media print{body{max-width:none;margin:0;font-size:10pt}.fig,table,tr,.verdict{break-inside:avoid}h2,h3{break-after:avoid}.contents{display:none}}";

/// `html` with a contents list before its first section when it has at least four: each
/// `<h2>` gets an anchor before it and a line in the list, so a long report (a ramp's is many screens)
/// can be read in any order.
pub(crate) fn with_contents(html: &str) -> String {
    let count = html.matches("<h2>").count();
    if count < 4 {
        return html.to_string();
    }
    let mut body = String::with_capacity(html.len() + 64 * count);
    let mut list = String::from("<nav class=\"contents\"><b>Contents</b><ol>");
    let mut rest = html;
    let mut k = 0;
    while let Some(at) = rest.find("<h2>") {
        let (before, from) = rest.split_at(at);
        body.push_str(before);
        let from = &from["<h2>".len()..];
        let end = from.find("</h2>").unwrap_or(from.len());
        k += 1;
        body.push_str(&format!("<a id=\"s{k}\"></a><h2>"));
        list.push_str(&format!("<li><a href=\"#s{k}\">{}</a></li>", &from[..end]));
        rest = from;
    }
    body.push_str(rest);
    list.push_str("</ol></nav>\n");
    let first = body.find("<a id=\"s1\">").unwrap_or(0);
    body.insert_str(first, &list);
    body
}

/// The unit of a fitted coefficient of `term` (`1`, `f_x`, `w_y^2`, `input:input_o`,
/// `w_x:temp`): counts per unit of the term, `input` and `input_o` (a single axis's input and
/// the one across it) in `input_unit`.
pub(crate) fn term_unit(term: &str, input_unit: &str) -> String {
    if term == "1" {
        return "counts".to_string();
    }
    let factor = |f: &str| -> String {
        let (base, power) = match f.split_once('^') {
            Some((b, p)) => (b, Some(p)),
            None => (f, None),
        };
        let base = base
            .strip_prefix("abs(")
            .and_then(|b| b.strip_suffix(')'))
            .unwrap_or(base);
        let unit = if base.starts_with("dw_") {
            "rad/s^2"
        } else if base.starts_with("f_") {
            "m/s^2"
        } else if base.starts_with("w_") {
            "rad/s"
        } else if base == "temp" {
            "C"
        } else if base == "volt" {
            "V"
        } else if base == "input" || base == "input_o" {
            input_unit
        } else {
            return format!("unit of {f}");
        };
        match power {
            Some(p) => format!("({unit})^{p}"),
            None => unit.to_string(),
        }
    };
    let parts: Vec<String> = term.split(':').map(factor).collect();
    format!("counts per {}", parts.join(" "))
}

/// What a term is, in words, where its name is the fit's own (`input_o`: the input across a
/// single axis).
pub(crate) fn term_words(term: &str) -> String {
    term.split(':')
        .map(|f| match f {
            "input_o" => "the cross-axis input (input_o)".to_string(),
            other => other.to_string(),
        })
        .collect::<Vec<_>>()
        .join(" x ")
}

#[cfg(test)]
mod tests {
    use super::{term_unit, with_contents};

    #[test]
    fn a_term_says_its_unit() {
        assert_eq!(term_unit("1", "m/s^2"), "counts");
        assert_eq!(term_unit("f_y", ""), "counts per m/s^2");
        assert_eq!(term_unit("w_x", ""), "counts per rad/s");
        assert_eq!(term_unit("f_x^2", ""), "counts per (m/s^2)^2");
        assert_eq!(term_unit("w_x:temp", ""), "counts per rad/s C");
        assert_eq!(term_unit("f_y:abs(f_y)", ""), "counts per m/s^2 m/s^2");
        assert_eq!(term_unit("dw_z", ""), "counts per rad/s^2");
        assert_eq!(
            term_unit("input:input_o", "m/s^2"),
            "counts per m/s^2 m/s^2"
        );
        assert_eq!(term_unit("input^3", "rad/s"), "counts per (rad/s)^3");
    }

    #[test]
    fn a_long_report_gets_a_contents_list_and_a_short_one_none() {
        let short = "<h1>u</h1><h2>a</h2><h2>b</h2><h2>c</h2>";
        assert_eq!(with_contents(short), short);
        let long = "<h1>u</h1><p>v</p><h2>a</h2>x<h2>b &amp; c</h2>y<h2>d</h2><h2>e</h2>z";
        assert_eq!(
            with_contents(long),
            "<h1>u</h1><p>v</p><nav class=\"contents\"><b>Contents</b><ol>\
             <li><a href=\"#s1\">a</a></li><li><a href=\"#s2\">b &amp; c</a></li>\
             <li><a href=\"#s3\">d</a></li><li><a href=\"#s4\">e</a></li></ol></nav>\n\
             <a id=\"s1\"></a><h2>a</h2>x<a id=\"s2\"></a><h2>b &amp; c</h2>y\
             <a id=\"s3\"></a><h2>d</h2><a id=\"s4\"></a><h2>e</h2>z"
        );
    }
}
