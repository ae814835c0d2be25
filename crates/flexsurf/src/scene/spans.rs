//! Locating a TOML parse or type error from the parser's own spans: the `toml` crate's error gives a byte span,
//! and its span-preserving document tree ([`toml::de::DeTable`], every key and value a [`toml::Spanned`]) gives
//! the dotted key path of the smallest key or value containing it (`time.dt`, `obstacle[1].sphere.radius`).
//! Nothing here slices text by hand, so no input (non-ASCII keys, a byte-order mark, invalid syntax) can make it
//! panic; elements of plain arrays are reported as their array's key (`sheet.nodes`), elements of arrays of
//! tables with their index (`obstacle[1]`).

use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// Line and column (1-based; the column counts characters) of byte `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    line_col_bytes(text.as_bytes(), offset)
}

/// As [`line_col`] for bytes that may not be valid UTF-8 (an offset inside a character counts it).
pub fn line_col_bytes(bytes: &[u8], offset: usize) -> (usize, usize) {
    let before = &bytes[..offset.min(bytes.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = before.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
    // Characters = bytes that do not continue a UTF-8 sequence.
    let column = before[start..].iter().filter(|&&b| (b & 0xC0) != 0x80).count() + 1;
    (line, column)
}

/// The best match so far: (span length, path depth, path).
type Best = Option<(usize, usize, String)>;

fn offer(best: &mut Best, span: std::ops::Range<usize>, offset: usize, path: &str, depth: usize) {
    let contains = span.start <= offset && (offset < span.end || (span.is_empty() && offset == span.start));
    if !contains || path.is_empty() {
        return;
    }
    let len = span.end - span.start;
    let better = match best {
        None => true,
        Some((l, d, _)) => len < *l || (len == *l && depth > *d),
    };
    if better {
        *best = Some((len, depth, path.to_string()));
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn visit_table(table: &DeTable<'_>, path: &str, depth: usize, offset: usize, best: &mut Best) {
    for (key, value) in table.iter() {
        let here = join(path, key.get_ref());
        offer(best, key.span(), offset, &here, depth + 1);
        visit_value(value, &here, depth + 1, offset, best);
    }
}

fn visit_value(value: &Spanned<DeValue<'_>>, path: &str, depth: usize, offset: usize, best: &mut Best) {
    offer(best, value.span(), offset, path, depth);
    match value.get_ref() {
        DeValue::Table(t) => visit_table(t, path, depth, offset, best),
        DeValue::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                // Only tables in an array get an index of their own (`obstacle[1]`); a number in `nodes = [..]`
                // is reported as `nodes`.
                if let DeValue::Table(t) = item.get_ref() {
                    let here = format!("{path}[{i}]");
                    offer(best, item.span(), offset, &here, depth + 1);
                    visit_table(t, &here, depth + 1, offset, best);
                }
            }
        }
        _ => {}
    }
}

/// Dotted key path of the key or value at byte `offset` of the TOML `text` (empty: the top level). Text that
/// does not parse is searched in the parser's best-effort recovery of it.
pub fn key_at(text: &str, offset: usize) -> String {
    let (doc, _errors) = DeTable::parse_recoverable(text);
    let mut best: Best = None;
    visit_table(doc.get_ref(), "", 0, offset, &mut best);
    best.map(|(_, _, p)| p).unwrap_or_default()
}

/// Line, column, key and message of a TOML error in `text`: `(line, column, key, message)`. The key of a
/// missing field is the table's key with the field appended.
pub fn locate(text: &str, error: &toml::de::Error) -> (usize, usize, String, String) {
    let span = error.span().unwrap_or(0..0);
    let (line, column) = line_col(text, span.start);
    let message = error.message().trim().to_string();
    // An empty span at the start is the top-level table's (a missing field of it), not the first key's.
    let mut key = if span == (0..0) { String::new() } else { key_at(text, span.start) };
    if let Some(field) = message.strip_prefix("missing field `").and_then(|s| s.split('`').next()) {
        key = join(&key, field);
    }
    (line, column, key, message)
}

/// A one-line description of a TOML error in `text` for files other than scenes (NURBS bodies): line, column
/// and the parser's message with the values it quotes removed ([`sanitize`]), without the quoted source line
/// the error's `Display` would add and without key paths (an unknown key is the file's text): nothing of the
/// file's contents is echoed.
pub fn describe(text: &str, error: &toml::de::Error) -> String {
    let (line, column, _key, message) = locate(text, error);
    format!("line {line}, column {column}: {}", sanitize(&message))
}

/// `message` of the TOML parser or of serde without the values it quotes from the file: `unknown variant
/// `secret`` becomes `unknown variant`, `invalid type: string "abc", expected f64` becomes `invalid type: string,
/// expected f64` (key names, and the lists of expected keys and kinds, which come from the format, are kept).
pub fn sanitize(message: &str) -> String {
    let message = message.trim();
    // Key names are the format's (or a typo of one) and are kept; values are not.
    for prefix in ["unknown variant `"] {
        if let Some(rest) = message.strip_prefix(prefix) {
            let after = rest.split_once('`').map_or("", |(_, a)| a);
            return format!("{}{after}", prefix.trim_end_matches(" `"));
        }
    }
    for prefix in ["invalid type: ", "invalid value: ", "invalid length "] {
        if let Some(rest) = message.strip_prefix(prefix) {
            let (what, expected) = rest.split_once(", expected").unwrap_or((rest, ""));
            // The kind of value (`string`, `integer`, `floating point`, `map`) without the value itself.
            let kind: String = what.split(['"', '`']).next().unwrap_or("").trim().to_string();
            let expected = if expected.is_empty() { String::new() } else { format!(", expected{expected}") };
            return format!("{prefix}{kind}{expected}");
        }
    }
    message.lines().next().unwrap_or("").to_string()
}
