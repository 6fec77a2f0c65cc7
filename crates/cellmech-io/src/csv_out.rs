//! CSV curves that survive a crash: every pushed row is persisted before `push_row` returns.
//!
//! Strategy: the whole file is rewritten atomically ([`crate::write_atomic`]) after each row.
//! This costs O(rows²) bytes in total, which is negligible for load curves (< 10 000 rows) and
//! guarantees that the file on disk is always a complete CSV with all finished rows.

use std::path::{Path, PathBuf};

use crate::atomic::write_atomic;
use crate::error::WriteError;

/// A curve file: a header of column names (with units, e.g. `displacement_um`, `force_nN`)
/// and rows of numbers.
#[derive(Debug, Clone)]
pub struct CurveWriter {
    path: PathBuf,
    columns: usize,
    text: String,
}

/// A curve row or header that cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    /// The row length differs from the header.
    #[error("{}: row has {found} values, the header has {expected} columns", path.display())]
    RowLength {
        /// The curve file.
        path: PathBuf,
        /// Number of columns.
        expected: usize,
        /// Number of values pushed.
        found: usize,
    },
    /// A column name is empty or contains a comma, quote or line break.
    #[error("{}: invalid column name '{name}' (must be non-empty, without , \" or line breaks)", path.display())]
    BadColumn {
        /// The curve file.
        path: PathBuf,
        /// The offending name.
        name: String,
    },
    /// A text cell is empty or contains a comma, quote or line break.
    #[error("{}: invalid text cell '{text}' (must be non-empty, without , \" or line breaks)", path.display())]
    BadText {
        /// The table file.
        path: PathBuf,
        /// The offending text.
        text: String,
    },
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// One cell of a [`CurveWriter::push_records`] row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CsvCell<'a> {
    /// A number, written like [`CurveWriter::push_row`] writes it.
    Number(f64),
    /// An integer (ids, node numbers, counts, 0/1 flags).
    Integer(i64),
    /// A word (a family name, a state); no commas, quotes or line breaks.
    Text(&'a str),
    /// Nothing (not applicable).
    Empty,
}

impl CurveWriter {
    /// Creates (or truncates) `path` and writes the header line.
    pub fn create(path: &Path, columns: &[&str]) -> Result<Self, CsvError> {
        if columns.is_empty() {
            return Err(CsvError::BadColumn {
                path: path.to_path_buf(),
                name: String::new(),
            });
        }
        for c in columns {
            if c.is_empty() || c.contains([',', '"', '\n', '\r']) {
                return Err(CsvError::BadColumn {
                    path: path.to_path_buf(),
                    name: c.to_string(),
                });
            }
        }
        let writer = CurveWriter {
            path: path.to_path_buf(),
            columns: columns.len(),
            text: columns.join(",") + "\n",
        };
        write_atomic(&writer.path, writer.text.as_bytes())?;
        Ok(writer)
    }

    /// Appends a row and persists the file. Values use Rust's shortest exact representation
    /// (`NaN`, `inf` and `-inf` for non-finite values).
    pub fn push_row(&mut self, values: &[f64]) -> Result<(), CsvError> {
        if values.len() != self.columns {
            return Err(CsvError::RowLength {
                path: self.path.clone(),
                expected: self.columns,
                found: values.len(),
            });
        }
        let before = self.text.len();
        for (i, v) in values.iter().enumerate() {
            if i > 0 {
                self.text.push(',');
            }
            self.text.push_str(&format!("{v:?}"));
        }
        self.text.push('\n');
        if let Err(e) = write_atomic(&self.path, self.text.as_bytes()) {
            self.text.truncate(before);
            return Err(e.into());
        }
        Ok(())
    }

    /// Appends several rows of mixed cells (words, integers, numbers, empty cells) and
    /// persists the file once: a table with many rows per increment (e.g. one per filament)
    /// costs one atomic rewrite per increment. Nothing is appended on error.
    pub fn push_records(&mut self, rows: &[Vec<CsvCell<'_>>]) -> Result<(), CsvError> {
        use std::fmt::Write as _;
        let before = self.text.len();
        for row in rows {
            if row.len() != self.columns {
                self.text.truncate(before);
                return Err(CsvError::RowLength {
                    path: self.path.clone(),
                    expected: self.columns,
                    found: row.len(),
                });
            }
            for (i, cell) in row.iter().enumerate() {
                if i > 0 {
                    self.text.push(',');
                }
                match *cell {
                    CsvCell::Number(v) => {
                        let _ = write!(self.text, "{v:?}");
                    }
                    CsvCell::Integer(v) => {
                        let _ = write!(self.text, "{v}");
                    }
                    CsvCell::Text(t) => {
                        if t.is_empty() || t.contains([',', '"', '\n', '\r']) {
                            self.text.truncate(before);
                            return Err(CsvError::BadText {
                                path: self.path.clone(),
                                text: t.to_string(),
                            });
                        }
                        self.text.push_str(t);
                    }
                    CsvCell::Empty => {}
                }
            }
            self.text.push('\n');
        }
        if let Err(e) = write_atomic(&self.path, self.text.as_bytes()) {
            self.text.truncate(before);
            return Err(e.into());
        }
        Ok(())
    }

    /// The file path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::scratch_dir;

    #[test]
    fn rows_are_on_disk_after_each_push_and_parse_back() {
        let dir = scratch_dir("csv");
        let path = dir.join("curve.csv");
        let mut w = CurveWriter::create(&path, &["displacement_um", "force_nN"]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "displacement_um,force_nN\n"
        );
        w.push_row(&[0.1, 1.0 / 3.0]).unwrap();
        w.push_row(&[-2e-12, 5.0]).unwrap();
        let mut reader = csv::Reader::from_path(&path).unwrap();
        let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header, vec!["displacement_um", "force_nN"]);
        let rows: Vec<Vec<f64>> = reader
            .records()
            .map(|r| r.unwrap().iter().map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows, vec![vec![0.1, 1.0 / 3.0], vec![-2e-12, 5.0]]);
    }

    #[test]
    fn wrong_row_length_and_bad_names_are_errors() {
        let dir = scratch_dir("csv-errors");
        let path = dir.join("c.csv");
        let mut w = CurveWriter::create(&path, &["a_um", "b_nN"]).unwrap();
        let err = w.push_row(&[1.0]).unwrap_err().to_string();
        assert!(
            err.ends_with("row has 1 values, the header has 2 columns"),
            "{err}"
        );
        assert!(CurveWriter::create(&path, &["a,b"]).is_err());
        w.push_row(&[1.0, f64::NAN]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "a_um,b_nN\n1.0,NaN\n"
        );
    }

    #[test]
    fn records_of_mixed_cells_are_written_at_once_or_not_at_all() {
        let dir = scratch_dir("csv-records");
        let path = dir.join("t.csv");
        let mut w = CurveWriter::create(&path, &["family", "id", "force_nN", "fa_node"]).unwrap();
        let rows = vec![
            vec![
                CsvCell::Text("actin"),
                CsvCell::Integer(3),
                CsvCell::Number(0.5),
                CsvCell::Integer(17),
            ],
            vec![
                CsvCell::Text("cables"),
                CsvCell::Integer(4),
                CsvCell::Number(-1e-3),
                CsvCell::Empty,
            ],
        ];
        w.push_records(&rows).unwrap();
        let expected = "family,id,force_nN,fa_node\nactin,3,0.5,17\ncables,4,-0.001,\n";
        assert_eq!(std::fs::read_to_string(&path).unwrap(), expected);
        let bad = vec![
            rows[0].clone(),
            vec![
                CsvCell::Text("a,b"),
                CsvCell::Empty,
                CsvCell::Empty,
                CsvCell::Empty,
            ],
        ];
        assert!(w.push_records(&bad).is_err());
        assert!(w.push_records(&[vec![CsvCell::Empty]]).is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), expected);
    }
}
