//! The TOML files' common reading: syntax errors with a 1-based line and
//! column on one line, and the line of a key whose value parses but is out
//! of range. Every TOML reader in [`crate::io`] goes through here.

use std::path::Path;

use serde::de::DeserializeOwned;

use super::FileError;

/// Parses `text` as a `T`; a syntax or type error becomes
/// [`FileError::Syntax`] at the place the parser points to.
pub(crate) fn parse_toml<T: DeserializeOwned>(text: &str, path: &Path) -> Result<T, FileError> {
    toml::from_str(text).map_err(|e| syntax_error(text, path, &e))
}

/// A `toml` error as [`FileError::Syntax`]: the start of its span as
/// line and column (1-based; 0 where the parser gives no place), and its
/// message on one line (the `Display` of a `toml` error is a multi-line
/// excerpt of the file).
pub(crate) fn syntax_error(text: &str, path: &Path, e: &toml::de::Error) -> FileError {
    let (line, column) = e
        .span()
        .map(|span| line_column(text, span.start))
        .unwrap_or((0, 0));
    FileError::Syntax {
        path: path.to_path_buf(),
        line,
        column,
        message: one_line(e.message()),
    }
}

/// An error in the value of `key` (dotted, with `[i]` for array entries,
/// e.g. `truth.joint_friction.mu` or `tensions_kn[1][0]`): a
/// [`FileError::Field`] on the line of the value where the file has it,
/// else (a default the file left out) a [`FileError::Invalid`] naming the
/// key.
pub(crate) fn field_error(text: &str, path: &Path, key: &str, message: String) -> FileError {
    match value_line(text, key) {
        Some(line) => FileError::field(path, line, key, message),
        None => FileError::Invalid {
            path: path.to_path_buf(),
            entry: format!("field `{key}`"),
            message,
        },
    }
}

/// 1-based line of the value at `key` in `text`, if it is there.
fn value_line(text: &str, key: &str) -> Option<usize> {
    let doc = toml_edit::ImDocument::parse(text).ok()?;
    let mut item = doc.as_item();
    for part in key.split('.') {
        let (name, indices) = part.split_once('[').unwrap_or((part, ""));
        item = item.get(name)?;
        for index in indices.split('[') {
            let index = index.trim_end_matches(']');
            if !index.is_empty() {
                item = item.get(index.parse::<usize>().ok()?)?;
            }
        }
    }
    let span = item.span()?;
    Some(line_column(text, span.start).0)
}

/// 1-based line and column of byte `offset` in `text` (column in bytes).
pub(crate) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    line_column_bytes(text.as_bytes(), offset)
}

/// [`line_column`] over raw bytes (which need not be UTF-8).
pub(crate) fn line_column_bytes(bytes: &[u8], offset: usize) -> (usize, usize) {
    let before = &bytes[..offset.min(bytes.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map(|i| i + 1)
        .unwrap_or(0);
    (line, before.len() - line_start + 1)
}

/// `message` with its line breaks folded, so that an error stays one line.
fn one_line(message: &str) -> String {
    message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "a = 1\n[t]\nb = [1, 2]\nc = [[1], [2, 3]]\n";

    #[test]
    fn finds_the_line_of_nested_keys_and_array_entries() {
        assert_eq!(value_line(TEXT, "a"), Some(1));
        assert_eq!(value_line(TEXT, "t.b"), Some(3));
        assert_eq!(value_line(TEXT, "t.b[1]"), Some(3));
        assert_eq!(value_line(TEXT, "t.c[1][0]"), Some(4));
        assert_eq!(value_line(TEXT, "t.zz"), None);
        assert_eq!(value_line(TEXT, "t.c[5]"), None);
    }

    #[test]
    fn a_syntax_error_is_one_line_with_line_and_column() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct Doc {
            a: f64,
        }
        let text = "\n\na = [1,\n";
        let e = parse_toml::<Doc>(text, Path::new("x.toml")).unwrap_err();
        let FileError::Syntax { line, column, .. } = &e else {
            panic!("{e}")
        };
        // The parser reports the unterminated array at its end.
        assert!(*line >= 3, "{line}:{column}");
        assert_eq!(e_text(text), e_text(text).replace('\n', ""));
        let e = parse_toml::<Doc>("a = \"x\"\n", Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.toml:1:5: "), "{e}");
    }

    fn e_text(text: &str) -> String {
        parse_toml::<toml::Table>(text, Path::new("x.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn line_and_column_count_from_one() {
        assert_eq!(line_column("ab\ncd", 0), (1, 1));
        assert_eq!(line_column("ab\ncd", 4), (2, 2));
        assert_eq!(line_column("ab", 99), (1, 3));
    }
}
