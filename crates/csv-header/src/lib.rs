//! The metadata header of the project's CSV contracts (time series, sweeps, scope captures):
//! `# key = value` lines, blank lines, then the header row. One reader for all three, line
//! endings of either kind (Excel and oscilloscopes write CRLF).
#![forbid(unsafe_code)]

use std::collections::BTreeMap;

/// A CSV text split at its header row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Split<'a> {
    /// The `# key = value` metadata, keys and values trimmed (comment lines without `=` are
    /// skipped).
    pub meta: BTreeMap<String, String>,
    /// The text from the header row on (empty when there is none).
    pub body: &'a str,
    /// 1-based line number of the header row in the whole text (0 when there is none).
    pub header_line: usize,
}

/// Splits `text` into its metadata and the rest, from the header row on. A UTF-8 byte-order
/// mark at the start is skipped.
///
/// ```
/// let s = csv_header::split("# fs = 330000\r\n\r\ntime,vout\r\n0,1\r\n");
/// assert_eq!(s.meta["fs"], "330000");
/// assert_eq!(s.header_line, 3);
/// assert!(s.body.starts_with("time,vout"));
/// ```
pub fn split(text: &str) -> Split<'_> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut meta = BTreeMap::new();
    let mut start = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix('#') {
            if let Some((k, v)) = rest.split_once('=') {
                meta.insert(k.trim().to_string(), v.trim().to_string());
            }
        } else if !trimmed.is_empty() {
            return Split { meta, body: &text[start..], header_line: i + 1 };
        }
        start += line.len();
    }
    Split { meta, body: "", header_line: 0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lf_crlf_and_a_byte_order_mark_split_alike() {
        for text in ["# a = 1\n# note\n\nx,y\n1,2\n", "# a = 1\r\n# note\r\n\r\nx,y\r\n1,2\r\n", "\u{feff}# a = 1\n# note\n\nx,y\n1,2\n"] {
            let s = split(text);
            assert_eq!(s.meta.len(), 1, "{text:?}");
            assert_eq!(s.meta["a"], "1");
            assert_eq!(s.header_line, 4);
            assert!(s.body.starts_with("x,y"), "{:?}", s.body);
        }
    }

    #[test]
    fn no_header_row_leaves_an_empty_body() {
        let s = split("# only = metadata\n\n");
        assert_eq!((s.body, s.header_line), ("", 0));
        assert_eq!(split(""), Split { meta: BTreeMap::new(), body: "", header_line: 0 });
    }
}
