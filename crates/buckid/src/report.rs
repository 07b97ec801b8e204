//! The HTML reports (`--report DIR`): one `index.html` with the figures inline, and each
//! figure also as its own `.svg` file next to it (for slides and papers). Every number on a
//! page goes through [`crate::units`]: SI prefixes, units, digits that match the interval.
pub mod diagnose;
pub mod identify;
pub mod plot;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// A report page being assembled: HTML fragments and figures in order.
pub struct Page {
    title: String,
    body: String,
    figures: Vec<(String, String)>,
}

impl Page {
    /// A page with this `<title>` and `<h1>`.
    pub fn new(title: &str, heading: &str) -> Self {
        Self { title: title.to_string(), body: format!("<h1>{}</h1>\n", esc(heading)), figures: Vec::new() }
    }

    /// Appends an HTML fragment (the caller escapes any text in it with [`esc`]).
    pub fn html(&mut self, fragment: &str) {
        self.body.push_str(fragment);
        self.body.push('\n');
    }

    /// Appends a figure, inline as `<figure id="<file>">`, and keeps it to be written as
    /// `<file>.svg`.
    pub fn figure(&mut self, file: &str, svg: String) {
        self.body.push_str(&format!("<figure id=\"{file}\">{svg}</figure>\n"));
        self.figures.push((format!("{file}.svg"), svg));
    }

    /// Writes `index.html` and the figures' SVG files into `dir` (created if needed); returns
    /// the path of `index.html`.
    pub fn write(self, dir: &Path) -> Result<PathBuf> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for (file, svg) in &self.figures {
            let path = dir.join(file);
            std::fs::write(&path, format!("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{svg}\n")).with_context(|| format!("writing {}", path.display()))?;
        }
        let html = format!(
            r#"<!doctype html><html><head><meta charset="utf-8"><title>{}</title>
<style>body{{font-family:sans-serif;max-width:880px;margin:2em auto;line-height:1.4}}figure{{margin:1.2em 0}}svg{{max-width:100%;height:auto}}
table{{border-collapse:collapse;font-size:0.9em}}td,th{{padding:3px 8px;text-align:right;vertical-align:top;border-bottom:1px solid #ddd}}th{{background:#f2f2f2}}td:first-child,th:first-child{{text-align:left}}</style></head><body>
{}</body></html>
"#,
            esc(&self.title),
            self.body
        );
        let path = dir.join("index.html");
        std::fs::write(&path, html).with_context(|| format!("writing {}", path.display()))?;
        Ok(path)
    }
}

/// An HTML table: a header row and body rows of already-escaped cells.
pub fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let th: String = header.iter().map(|h| format!("<th>{}</th>", esc(h))).collect();
    let body: String = rows.iter().map(|r| format!("<tr>{}</tr>", r.iter().map(|c| format!("<td>{c}</td>")).collect::<String>())).collect();
    format!("<table><tr>{th}</tr>{body}</table>")
}

/// Escapes text for HTML and XML.
pub fn esc(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
