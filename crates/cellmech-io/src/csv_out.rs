//! CSV curves that survive a crash: every pushed row is persisted before `push_row` returns.
//!
//! Strategy: the whole file is rewritten atomically ([`crate::write_atomic`]) after each row.
//! This costs O(rows²) bytes in total, which is negligible for load curves (< 10 000 rows) and
//! guarantees that the file on disk is always a complete CSV with all finished rows.
//!
//! A table that grows by many rows per result (a row per Newton iteration) can use
//! [`CurveWriter::push_row_deferred`]: its rows reach the disk at most `max_age` late, or at
//! the next [`CurveWriter::flush`] or `push_row`, and the file on disk is still always a
//! complete CSV.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::atomic::write_atomic;
use crate::error::WriteError;

/// A curve file: a header of column names (with units, e.g. `displacement_um`, `force_nN`)
/// and rows of numbers.
#[derive(Debug, Clone)]
pub struct CurveWriter {
    path: PathBuf,
    columns: usize,
    text: String,
    /// Bytes of `text` on disk, and when they were written.
    persisted: usize,
    persisted_at: Instant,
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
        let mut writer = CurveWriter {
            path: path.to_path_buf(),
            columns: columns.len(),
            text: columns.join(",") + "\n",
            persisted: 0,
            persisted_at: Instant::now(),
        };
        writer.persist()?;
        Ok(writer)
    }

    /// Appends a row and persists the file. Values use Rust's shortest exact representation
    /// (`NaN`, `inf` and `-inf` for non-finite values).
    pub fn push_row(&mut self, values: &[f64]) -> Result<(), CsvError> {
        let before = self.append_row(values)?;
        if let Err(e) = self.persist() {
            self.text.truncate(before);
            return Err(e);
        }
        Ok(())
    }

    /// Appends a row like [`Self::push_row`], but persists the file only when it was last
    /// written at least `max_age` ago (then with every row so far); [`Self::flush`] or the
    /// next `push_row` writes the rest. A failed write keeps the rows for the next one.
    pub fn push_row_deferred(&mut self, values: &[f64], max_age: Duration) -> Result<(), CsvError> {
        self.append_row(values)?;
        if self.persisted_at.elapsed() >= max_age {
            self.persist()?;
        }
        Ok(())
    }

    /// Writes the rows that [`Self::push_row_deferred`] has not written yet (nothing when
    /// there are none).
    pub fn flush(&mut self) -> Result<(), CsvError> {
        if self.persisted != self.text.len() {
            self.persist()?;
        }
        Ok(())
    }

    /// Appends one row of numbers to the text; returns the text's length before it.
    fn append_row(&mut self, values: &[f64]) -> Result<usize, CsvError> {
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
            let _ = write!(self.text, "{v:?}");
        }
        self.text.push('\n');
        Ok(before)
    }

    /// Rewrites the file atomically with the whole text.
    fn persist(&mut self) -> Result<(), CsvError> {
        write_atomic(&self.path, self.text.as_bytes())?;
        self.persisted = self.text.len();
        self.persisted_at = Instant::now();
        Ok(())
    }

    /// Appends several rows of mixed cells (words, integers, numbers, empty cells) and
    /// persists the file once: a table with many rows per increment (e.g. one per filament)
    /// costs one atomic rewrite per increment. Nothing is appended on error.
    pub fn push_records(&mut self, rows: &[Vec<CsvCell<'_>>]) -> Result<(), CsvError> {
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
        if let Err(e) = self.persist() {
            self.text.truncate(before);
            return Err(e);
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
    fn deferred_rows_reach_the_disk_when_due_or_flushed() {
        let dir = scratch_dir("csv-deferred");
        let path = dir.join("iterations.csv");
        let mut w = CurveWriter::create(&path, &["iteration", "residual"]).unwrap();
        let on_disk = || std::fs::read_to_string(&path).unwrap();
        w.push_row_deferred(&[1.0, 0.5], Duration::from_secs(3600))
            .unwrap();
        w.push_row_deferred(&[2.0, 0.25], Duration::from_secs(3600))
            .unwrap();
        assert_eq!(on_disk(), "iteration,residual\n", "not due yet");
        w.flush().unwrap();
        assert_eq!(on_disk(), "iteration,residual\n1.0,0.5\n2.0,0.25\n");
        w.push_row_deferred(&[3.0, 0.125], Duration::ZERO).unwrap();
        assert_eq!(on_disk().lines().count(), 4, "due at once");
        w.push_row_deferred(&[4.0, 0.0625], Duration::from_secs(3600))
            .unwrap();
        w.push_row(&[5.0, 0.0]).unwrap();
        assert_eq!(
            on_disk().lines().count(),
            6,
            "push_row writes the pending row too"
        );
        assert!(w.push_row_deferred(&[1.0], Duration::ZERO).is_err());
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
