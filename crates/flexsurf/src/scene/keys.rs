//! Locating a TOML parse or type error: turns the byte span the `toml` crate reports into a line, a column and
//! the dotted key path of the value under it (`time.dt`, `obstacle[1].sphere.radius`), so an error message can
//! name the key even though `toml` does not expose its own key list.

/// Line and column (1-based) of byte `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = before.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
    let column = String::from_utf8_lossy(&before[start..]).chars().count() + 1;
    (line, column)
}

/// The header of a `[table]` or `[[array]]` line, without brackets; for arrays of tables the index of this
/// occurrence is appended (`obstacle[1]`).
fn header(line: &str, counts: &mut Vec<(String, usize)>) -> Option<String> {
    let t = strip_comment(line).trim();
    if let Some(name) = t.strip_prefix("[[").and_then(|s| s.strip_suffix("]]")) {
        let name = name.trim().to_string();
        let index = match counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => {
                *c += 1;
                *c - 1
            }
            None => {
                counts.push((name.clone(), 1));
                0
            }
        };
        return Some(format!("{name}[{index}]"));
    }
    let name = t.strip_prefix('[').and_then(|s| s.strip_suffix(']'))?;
    // A sub-table of the last array element (`[obstacle.sphere]` after `[[obstacle]]`) keeps its index.
    let name = name.trim();
    for (n, c) in counts.iter() {
        if let Some(rest) = name.strip_prefix(n.as_str()).and_then(|r| r.strip_prefix('.')) {
            return Some(format!("{n}[{}].{rest}", c - 1));
        }
    }
    Some(name.to_string())
}

/// A line without its `#` comment (ignores `#` inside strings only roughly: good enough for key names).
fn strip_comment(line: &str) -> &str {
    let mut in_str = false;
    for (i, ch) in line.char_indices() {
        match ch {
            '"' => in_str = !in_str,
            '#' if !in_str => return &line[..i],
            _ => {}
        }
    }
    line
}

/// The key path inside one line at byte `here`: the line's key, then the keys of the inline tables that enclose
/// `here` (`sphere = { radius = 0.3 }` gives `sphere.radius` at the `0.3`). A key counts from its first byte, so
/// an error spanning the key name itself (an unknown field) names that key.
fn line_path(line: &str, here: usize) -> Vec<String> {
    let bytes = line.as_bytes();
    let mut path: Vec<String> = Vec::new();
    let mut depth = 0usize;
    let mut in_str = false;
    for (i, &b) in bytes.iter().enumerate() {
        match b {
            b'"' => in_str = !in_str,
            b'{' if !in_str => {
                if i >= here {
                    break;
                }
                depth += 1;
            }
            b'}' if !in_str => {
                if i >= here {
                    break;
                }
                depth = depth.saturating_sub(1);
                path.truncate(depth + 1);
            }
            b'=' if !in_str => {
                let before = line[..i].trim_end();
                let start = before
                    .rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.'))
                    .map_or(0, |p| p + 1);
                if start > here && !path.is_empty() {
                    break;
                }
                let key = &before[start..];
                if !key.is_empty() {
                    path.truncate(depth);
                    path.push(key.to_string());
                }
            }
            _ => {}
        }
    }
    path
}

/// Dotted key path of the value at byte `offset` of `text`.
pub fn key_at(text: &str, offset: usize) -> String {
    let offset = offset.min(text.len());
    let mut table = String::new();
    let mut counts = Vec::new();
    let mut last_key: Option<String> = None;
    let mut pos = 0;
    for line in text.split_inclusive('\n') {
        let end = pos + line.len();
        let code = strip_comment(line);
        if code.trim_start().starts_with('[') {
            if let Some(h) = header(line, &mut counts) {
                table = h;
                last_key = None;
            }
            if offset < end {
                return table;
            }
        } else {
            let path = line_path(code, offset.saturating_sub(pos));
            if offset < end {
                // A continuation line of a multi-line array has no key of its own.
                let key = if path.is_empty() { last_key } else { Some(path.join(".")) };
                return join(&table, key.as_deref());
            }
            if let Some(k) = path.first() {
                last_key = Some(k.clone());
            }
        }
        pos = end;
    }
    table
}

fn join(table: &str, key: Option<&str>) -> String {
    match (table.is_empty(), key) {
        (_, None) => table.to_string(),
        (true, Some(k)) => k.to_string(),
        (false, Some(k)) => format!("{table}.{k}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_of_values_and_headers() {
        let t = "gravity = [0, 0, -9.81]\n[time]\ndt = -1.0 # s\n[[obstacle]]\nsphere = { center = [0, 0, 0], radius = 0.3 }\n[[obstacle]]\nplane = { point = [0, 0, 0], normal = [0, 0, 1] }\n";
        assert_eq!(key_at(t, t.find("-9.81").unwrap()), "gravity");
        assert_eq!(key_at(t, t.find("-1.0").unwrap()), "time.dt");
        assert_eq!(key_at(t, t.find("[time]").unwrap()), "time");
        assert_eq!(key_at(t, t.find("0.3").unwrap()), "obstacle[0].sphere.radius");
        assert_eq!(key_at(t, t.find("normal").unwrap() + 10), "obstacle[1].plane.normal");
        assert_eq!(line_col(t, t.find("-1.0").unwrap()), (3, 6));
        let u = "[[obstacle]]\nsphere = { centre = [0, 0, 0] }\n[sheet]\nnodes = [\n  21,\n  2,\n]\nsizes = 1\n";
        assert_eq!(key_at(u, u.find("centre").unwrap()), "obstacle[0].sphere.centre");
        assert_eq!(key_at(u, u.find("2,").unwrap()), "sheet.nodes");
        assert_eq!(key_at(u, u.find("sizes").unwrap()), "sheet.sizes");
    }
}
