//! The one CSV writer: every CSV file the crate writes is a [`CsvTable`]
//! (a header, then rows of the same width), quoted where a field needs it
//! and written atomically.

use std::path::Path;

use super::{write_atomically, FileError};

/// A CSV table built in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvTable {
    text: String,
    columns: usize,
}

impl CsvTable {
    /// A table with these column names.
    pub fn new(header: &[&str]) -> Self {
        let mut table = CsvTable {
            text: String::new(),
            columns: header.len(),
        };
        table.push_record(header.iter());
        table
    }

    /// Appends one row. Numbers are best given as `f64::to_string()`
    /// (shortest text that reads back to the same value); a missing value
    /// as an empty field.
    ///
    /// A row must have as many fields as the header; that is the caller's
    /// invariant (checked in debug builds), never a property of input data.
    pub fn row<I, S>(&mut self, fields: I)
    where
        I: IntoIterator<Item = S>,
        S: AsRef<str>,
    {
        let n = self.push_record(fields.into_iter());
        debug_assert_eq!(n, self.columns, "CSV row width differs from the header");
    }

    /// The table as CSV text.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Writes the table to `path` atomically.
    pub fn write(&self, path: &Path) -> Result<(), FileError> {
        write_atomically(path, self.text.as_bytes())
    }

    fn push_record<I, S>(&mut self, fields: I) -> usize
    where
        I: Iterator<Item = S>,
        S: AsRef<str>,
    {
        let mut n = 0;
        for field in fields {
            if n > 0 {
                self.text.push(',');
            }
            push_field(&mut self.text, field.as_ref());
            n += 1;
        }
        self.text.push('\n');
        n
    }
}

/// A field, in double quotes (inner quotes doubled) where it holds a
/// separator, a quote, a line break or edge whitespace (which readers
/// trim), as RFC 4180 has it.
fn push_field(out: &mut String, field: &str) {
    let needs_quotes = field.contains([',', '"', '\n', '\r']) || field.trim() != field;
    if needs_quotes {
        out.push('"');
        out.push_str(&field.replace('"', "\"\""));
        out.push('"');
    } else {
        out.push_str(field);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_reads_back_through_the_csv_parser() {
        let mut t = CsvTable::new(&["id", "value"]);
        t.row(["plain", "1.5"]);
        t.row(["a, \"quoted\" id", ""]);
        t.row([String::from("x"), 0.1f64.to_string()]);
        assert!(t.as_str().starts_with("id,value\nplain,1.5\n"));
        let mut r = csv::Reader::from_reader(t.as_str().as_bytes());
        let rows: Vec<Vec<String>> = r
            .records()
            .map(|r| r.unwrap().iter().map(String::from).collect())
            .collect();
        assert_eq!(
            rows,
            vec![
                vec!["plain".to_string(), "1.5".into()],
                vec!["a, \"quoted\" id".into(), "".into()],
                vec!["x".into(), "0.1".into()],
            ]
        );
    }
}
