//! Self-contained HTML: one page with its style inline and figures embedded as SVG, so it
//! opens in any browser from disk, with no server and nothing fetched.

use std::path::{Path, PathBuf};

use super::Table;

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:80em;padding:0 1em;color:#222}\
table{border-collapse:collapse;margin:0.5em 0 1.5em;font-size:0.9em}\
th,td{border:1px solid #ccc;padding:0.25em 0.6em;text-align:left;vertical-align:top}\
th{background:#f3f3f3}tr:nth-child(even) td{background:#fafafa}\
.yes{background:#d4f4d4!important}.partly{background:#fff3c4!important}.no{background:#f8d4d4!important}\
.not_measured{background:#e8e8e8!important}.not_resolved{background:#e4ecf7!important}.details{color:#666;font-size:0.85em}figure{display:inline-block;margin:0.5em;max-width:48%}\
figure svg{max-width:100%;height:auto}figcaption{font-size:0.85em;color:#555}code{font-size:0.9em}";

/// A table as HTML, title above.
/// `s` escaped, with the inline Markdown tmo's own texts use rendered: `**bold**` and
/// `` `code` ``. (Only these two: a Markdown crate would be a dependency for four lines.)
pub fn inline_markdown(s: &str) -> String {
    let mut out = String::new();
    let (mut bold, mut code) = (false, false);
    let mut rest = s;
    while !rest.is_empty() {
        if !code && rest.starts_with("**") {
            out += if bold { "</b>" } else { "<b>" };
            bold = !bold;
            rest = &rest[2..];
        } else if rest.starts_with('`') {
            out += if code { "</code>" } else { "<code>" };
            code = !code;
            rest = &rest[1..];
        } else {
            let c = rest.chars().next().expect("not empty");
            out += &escape(c.encode_utf8(&mut [0; 4]));
            rest = &rest[c.len_utf8()..];
        }
    }
    // an unmatched marker is closed, so the page's markup stays whole
    if code {
        out += "</code>";
    }
    if bold {
        out += "</b>";
    }
    out
}

pub fn table(t: &Table) -> String {
    let mut out = format!("<h3>{}</h3>\n<table>\n<tr>", escape(&t.title));
    for c in &t.columns {
        out += &format!("<th>{}</th>", escape(c));
    }
    out += "</tr>\n";
    for r in &t.rows {
        out += "<tr>";
        for c in r {
            out += &format!("<td>{}</td>", escape(&c.display()));
        }
        out += "</tr>\n";
    }
    out + "</table>\n"
}

/// The SVG figures among `paths`, inline, each with its file name as caption.
/// `caption` says what a figure of a file stem shows (`None`: its file name alone; the
/// plots module's captions, passed in so that the page does not depend on the plots).
pub fn figures(paths: &[PathBuf], caption: &dyn Fn(&str) -> Option<String>) -> String {
    let mut out = String::new();
    for p in paths
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
    {
        let Ok(svg) = std::fs::read_to_string(p) else {
            continue;
        };
        let start = svg.find("<svg").unwrap_or(0);
        let name = p
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let stem = p
            .file_stem()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let caption = match caption(&stem) {
            Some(c) => format!(
                "{} <span class=\"details\">({})</span>",
                escape(&c),
                escape(&name)
            ),
            None => escape(&name),
        };
        out += &format!(
            "<figure>{}<figcaption>{caption}</figcaption></figure>\n",
            &svg[start..]
        );
    }
    out
}

/// A whole page around `body` (already HTML).
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style></head>\n<body>\n<h1>{}</h1>\n{body}</body></html>\n",
        escape(title),
        escape(title)
    )
}

/// Tables (and figures, if any) as one page.
pub fn tables_page(
    title: &str,
    tables: &[Table],
    figure_paths: &[PathBuf],
    caption: &dyn Fn(&str) -> Option<String>,
) -> String {
    let mut body: String = tables.iter().map(table).collect();
    if !figure_paths.is_empty() {
        body += "<h2>Figures</h2>\n";
        body += &figures(figure_paths, caption);
    }
    page(title, &body)
}

/// Writes `html` to `path`.
pub fn write(path: &Path, html: &str) -> std::io::Result<()> {
    crate::output::atomic::write_atomic(path, html.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_markdown_renders_bold_and_code_and_escapes_the_rest() {
        assert_eq!(
            inline_markdown("**yes** where `a < b` & more"),
            "<b>yes</b> where <code>a &lt; b</code> &amp; more"
        );
        // inside code, stars are text; an unmatched marker is closed
        assert_eq!(inline_markdown("`**x`"), "<code>**x</code>");
        assert_eq!(inline_markdown("**open"), "<b>open</b>");
    }
    use crate::report::Cell;

    #[test]
    fn a_table_page_is_escaped_and_self_contained() {
        let mut t = Table::new("t", "A <table>", &["what", "caught"]);
        t.push(vec![
            Cell::text("a&b"),
            Cell::Rate {
                count: 8,
                trials: 10,
            },
        ]);
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("f.svg");
        std::fs::write(&svg, "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\"><text>x</text></svg>").unwrap();
        let html = tables_page("Report", &[t], &[svg, dir.path().join("f.png")], &|_| None);
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains("<h3>A &lt;table&gt;</h3>"));
        assert!(html.contains("<td>a&amp;b</td><td>8/10 (80 %; 49–94)</td>"));
        assert!(html.contains("<figure><svg xmlns"));
        assert!(!html.contains("<?xml"));
        assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
    }
}
