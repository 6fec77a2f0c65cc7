//! Curves of a fit: the measured curve (a CSV file whose header names each column's unit)
//! and a run's simulated curve (a column pair of the protocol's CSV), and the linear
//! interpolation of one at the other's abscissae.
//!
//! A measured file looks like
//!
//! ```text
//! # any comment lines (where the data come from)
//! displacement [um],force [nN]
//! 0,0
//! 0.63,9.81
//! ```
//!
//! Units may be written `name [unit]` or `name (unit)`, with any unit of
//! [`crate::units`] (`nm`, `um`, `µm`, `pN`, `nN`, `kPa`, `%`, …); a dimensionless column
//! says `[1]` or `[-]`. Values are converted to internal units (µm, nN, kPa, fractions).

use std::path::Path;

use crate::units::{find_unit, Dimension};

/// A column pair read from a CSV file, in internal units.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Abscissae (e.g. displacement, µm).
    pub x: Vec<f64>,
    /// Ordinates (e.g. force, nN).
    pub y: Vec<f64>,
    /// Name of the x column as written in the file.
    pub x_name: String,
    /// Name of the y column.
    pub y_name: String,
    /// Dimension of x.
    pub x_dim: Dimension,
    /// Dimension of y.
    pub y_dim: Dimension,
}

/// A CSV file: its header and its rows of numbers, `#` comment lines skipped.
struct Table {
    header: Vec<String>,
    /// (line number, values) per row.
    rows: Vec<(usize, Vec<f64>)>,
}

fn read_table(path: &Path) -> Result<Table, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let mut header = None;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = trimmed.split(',').map(str::trim).collect();
        let Some(names) = &header else {
            header = Some(
                fields
                    .iter()
                    .map(|f| f.trim_matches('"').to_string())
                    .collect::<Vec<_>>(),
            );
            continue;
        };
        if fields.len() != names.len() {
            return Err(format!(
                "{}:{line_no}: expected {} comma-separated fields as in the header; found {}",
                path.display(),
                names.len(),
                fields.len()
            ));
        }
        let values = fields
            .iter()
            .zip(names)
            .map(|(f, name)| {
                if f.is_empty() {
                    return Ok(f64::NAN);
                }
                f.parse::<f64>().map_err(|_| {
                    format!(
                        "{}:{line_no}: column `{name}`: expected a number; found \"{f}\"",
                        path.display()
                    )
                })
            })
            .collect::<Result<Vec<f64>, String>>()?;
        rows.push((line_no, values));
    }
    let header = header.ok_or_else(|| {
        format!(
            "{}: expected a header line naming the columns with units (e.g. `displacement [um],force [nN]`); found no lines",
            path.display()
        )
    })?;
    Ok(Table { header, rows })
}

/// Splits `force [nN]` or `force (nN)` into the name and the unit's dimension and factor.
fn name_and_unit(field: &str) -> Option<(String, Dimension, f64)> {
    let field = field.trim();
    let (open, close) = if field.ends_with(']') {
        ('[', ']')
    } else if field.ends_with(')') {
        ('(', ')')
    } else {
        return None;
    };
    let start = field.rfind(open)?;
    let unit = field[start + 1..field.len() - close.len_utf8()].trim();
    let name = field[..start].trim().to_string();
    if matches!(unit, "1" | "-" | "") {
        return Some((name, Dimension::Dimensionless, 1.0));
    }
    let u = find_unit(unit)?;
    Some((name, u.dimension, u.factor))
}

/// Reads the measured curve: the columns named `columns` (names without units; default
/// the first two), converted to internal units. Rows with an empty field are skipped.
pub fn read_measured(path: &Path, columns: Option<&[String; 2]>) -> Result<Curve, String> {
    let table = read_table(path)?;
    let parsed: Vec<(String, Dimension, f64)> = table
        .header
        .iter()
        .map(|h| {
            name_and_unit(h).ok_or_else(|| {
                format!(
                    "{}: header column \"{h}\": expected a name and a unit such as `displacement [um]` or `force (nN)` (units: nm, um, pN, nN, kPa, … ; `[1]` for none); found no known unit",
                    path.display()
                )
            })
        })
        .collect::<Result<_, _>>()?;
    let pick = |k: usize| -> Result<usize, String> {
        match columns {
            None if parsed.len() > k => Ok(k),
            None => Err(format!(
                "{}: expected at least two columns (x and y); found {}",
                path.display(),
                parsed.len()
            )),
            Some(names) => parsed
                .iter()
                .position(|(n, _, _)| *n == names[k])
                .ok_or_else(|| {
                    format!(
                        "{}: `columns`: expected one of {}; found \"{}\"",
                        path.display(),
                        parsed
                            .iter()
                            .map(|(n, _, _)| format!("\"{n}\""))
                            .collect::<Vec<_>>()
                            .join(", "),
                        names[k]
                    )
                }),
        }
    };
    let (ix, iy) = (pick(0)?, pick(1)?);
    let mut curve = Curve {
        x: Vec::new(),
        y: Vec::new(),
        x_name: table.header[ix].clone(),
        y_name: table.header[iy].clone(),
        x_dim: parsed[ix].1,
        y_dim: parsed[iy].1,
    };
    for (_, row) in &table.rows {
        let (x, y) = (row[ix] * parsed[ix].2, row[iy] * parsed[iy].2);
        if x.is_finite() && y.is_finite() {
            curve.x.push(x);
            curve.y.push(y);
        }
    }
    if curve.x.len() < 2 {
        return Err(format!(
            "{}: expected at least two rows of numbers; found {}",
            path.display(),
            curve.x.len()
        ));
    }
    Ok(curve)
}

/// The dimension of a column written by cellmech, from its unit suffix (`_um`, `_nN`,
/// `_kPa`; anything else is a pure number).
pub fn column_dimension(name: &str) -> Dimension {
    if name.ends_with("_um") {
        Dimension::Length
    } else if name.ends_with("_nN") {
        Dimension::Force
    } else if name.ends_with("_kPa") {
        Dimension::Pressure
    } else {
        Dimension::Dimensionless
    }
}

/// Reads columns `x` and `y` of a CSV file written by a run (internal units already).
/// Only the loading part is kept: each point whose x exceeds every x before it (a retract
/// or a cutback never makes x go back into the fitted curve).
pub fn read_simulated(path: &Path, x: &str, y: &str) -> Result<Curve, String> {
    let table = read_table(path)?;
    let find = |name: &str| {
        table.header.iter().position(|h| h == name).ok_or_else(|| {
            format!(
                "{}: expected a column `{name}` (the columns are {}); found none",
                path.display(),
                table.header.join(", ")
            )
        })
    };
    let (ix, iy) = (find(x)?, find(y)?);
    let mut curve = Curve::empty(x, y);
    for (_, row) in &table.rows {
        let (vx, vy) = (row[ix], row[iy]);
        if !(vx.is_finite() && vy.is_finite()) {
            continue;
        }
        if curve.x.last().is_none_or(|&last| vx > last) {
            curve.x.push(vx);
            curve.y.push(vy);
        }
    }
    Ok(curve)
}

impl Curve {
    /// A curve without points whose columns are the run's `x` and `y` (a run that wrote
    /// no curve, or a measured curve still to be made).
    pub fn empty(x: &str, y: &str) -> Curve {
        Curve {
            x: Vec::new(),
            y: Vec::new(),
            x_name: x.into(),
            y_name: y.into(),
            x_dim: column_dimension(x),
            y_dim: column_dimension(y),
        }
    }

    /// y at `at` by linear interpolation between the two neighbouring points; `None`
    /// outside `[x₀, x_last]` (a curve that stopped early does not reach the point).
    pub fn interpolate(&self, at: f64) -> Option<f64> {
        let (first, last) = (*self.x.first()?, *self.x.last()?);
        let slack = 1e-9 * (last - first).abs().max(1e-12);
        if at < first - slack || at > last + slack {
            return None;
        }
        let k = self.x.partition_point(|&x| x < at);
        if k == 0 {
            return Some(self.y[0]);
        }
        if k >= self.x.len() {
            return self.y.last().copied();
        }
        let (x0, x1, y0, y1) = (self.x[k - 1], self.x[k], self.y[k - 1], self.y[k]);
        Some(y0 + (y1 - y0) * (at - x0) / (x1 - x0))
    }

    /// The largest x (0 for an empty curve).
    pub fn x_max(&self) -> f64 {
        self.x.last().copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("cellmech-fit-curve-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn units_in_the_header_are_converted_and_comments_skipped() {
        let p = scratch(
            "m.csv",
            "# made up\nindentation (nm),force [pN],note [1]\n0,0,1\n500,120,2\n1000,400,3\n",
        );
        let c = read_measured(&p, None).unwrap();
        assert_eq!(c.x, vec![0.0, 0.5, 1.0]);
        assert!((c.y[2] - 0.4).abs() < 1e-15);
        assert_eq!((c.x_dim, c.y_dim), (Dimension::Length, Dimension::Force));
        let picked = read_measured(&p, Some(&["indentation".into(), "note".into()])).unwrap();
        assert_eq!(picked.y, vec![1.0, 2.0, 3.0]);
    }

    #[test]
    fn bad_files_are_clear_errors() {
        let no_unit = scratch("a.csv", "displacement,force [nN]\n0,0\n1,1\n");
        let e = read_measured(&no_unit, None).unwrap_err();
        assert!(
            e.contains("a.csv") && e.contains("\"displacement\"") && e.contains("unit"),
            "{e}"
        );
        let bad = scratch("b.csv", "d [um],f [nN]\n0,0\n1,x\n");
        let e = read_measured(&bad, None).unwrap_err();
        assert!(e.contains("b.csv:3") && e.contains("found \"x\""), "{e}");
        let short = scratch("c.csv", "d [um],f [nN]\n0,0,3\n");
        assert!(read_measured(&short, None).unwrap_err().contains("c.csv:2"));
        let col = scratch("d.csv", "d [um],f [nN]\n0,0\n1,1\n");
        let e = read_measured(&col, Some(&["d".into(), "force".into()])).unwrap_err();
        assert!(e.contains("\"force\"") && e.contains("\"f\""), "{e}");
    }

    #[test]
    fn interpolation_is_linear_and_refuses_points_beyond_the_curve() {
        let p = scratch("s.csv", "elongation_um,force_nN\n0,1\n1,3\n0.5,9\n2,4\n");
        let c = read_simulated(&p, "elongation_um", "force_nN").unwrap();
        assert_eq!(c.x, vec![0.0, 1.0, 2.0], "x going back is dropped");
        assert_eq!(c.interpolate(0.5), Some(2.0));
        assert_eq!(c.interpolate(1.5), Some(3.5));
        assert_eq!(c.interpolate(2.0), Some(4.0));
        assert_eq!(c.interpolate(2.1), None);
        assert_eq!(c.x_dim, Dimension::Length);
    }
}
