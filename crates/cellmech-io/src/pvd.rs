//! ParaView collections (`.pvd`): a time series of `.vtu` frames.
//!
//! [`PvdSeries::add_frame`] writes `<basename>_<NNNN>.vtu` atomically, then rewrites
//! `<basename>.pvd` atomically, so after a crash the collection lists exactly the frames that
//! were completely written.

use std::path::{Path, PathBuf};

use crate::atomic::write_atomic;
use crate::error::WriteError;
use crate::vtu::{write_vtu, xml_escape, VtuError, VtuFrame};

/// A growing series of frames in one directory.
#[derive(Debug, Clone)]
pub struct PvdSeries {
    dir: PathBuf,
    basename: String,
    /// (time, file name relative to `dir`) of every written frame.
    frames: Vec<(f64, String)>,
}

impl PvdSeries {
    /// A series writing into `dir` (created if missing) with files `basename_NNNN.vtu` and
    /// `basename.pvd`. Nothing is written until the first frame.
    pub fn new(dir: &Path, basename: &str) -> Result<Self, WriteError> {
        std::fs::create_dir_all(dir).map_err(|source| WriteError {
            path: dir.to_path_buf(),
            source,
        })?;
        Ok(PvdSeries {
            dir: dir.to_path_buf(),
            basename: basename.to_string(),
            frames: Vec::new(),
        })
    }

    /// Path of the `.pvd` file.
    pub fn pvd_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.basename))
    }

    /// Number of frames written so far.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// True before the first frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Writes the next frame at `time` (s) and updates the collection; returns the `.vtu` path.
    pub fn add_frame(&mut self, time: f64, frame: &VtuFrame<'_>) -> Result<PathBuf, VtuError> {
        if !time.is_finite() {
            return Err(VtuError::Invalid(format!(
                "frame time must be finite, found {time}"
            )));
        }
        let name = format!("{}_{:04}.vtu", self.basename, self.frames.len());
        let path = self.dir.join(&name);
        write_vtu(&path, frame)?;
        self.frames.push((time, name));
        write_atomic(&self.pvd_path(), self.pvd_string().as_bytes())?;
        Ok(path)
    }

    /// The XML text of the collection.
    pub fn pvd_string(&self) -> String {
        let mut out = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" \
             byte_order=\"LittleEndian\">\n<Collection>\n",
        );
        for (time, file) in &self.frames {
            out.push_str(&format!(
                "<DataSet timestep=\"{time:e}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
                xml_escape(file)
            ));
        }
        out.push_str("</Collection>\n</VTKFile>\n");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::scratch_dir;
    use crate::vtu::{base64_decode, vtu_string, Field, VtuBlock};
    use cellmech_fem::mesh::ElementKind;

    /// The decoded payload of the DataArray called `name` (header checked and stripped).
    fn array(xml: &str, name: &str) -> (String, Vec<u8>) {
        let tag = format!("Name=\"{name}\"");
        let start = xml.find(&tag).unwrap_or_else(|| panic!("no array {name}"));
        let open = xml[..start].rfind("<DataArray").unwrap();
        let body_start = start + xml[start..].find('>').unwrap() + 1;
        let body_end = body_start + xml[body_start..].find("</DataArray>").unwrap();
        let bytes = base64_decode(&xml[body_start..body_end]);
        let header = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
        assert_eq!(header, bytes.len() - 8, "header of {name}");
        (xml[open..body_start].to_string(), bytes[8..].to_vec())
    }

    fn f64s(b: &[u8]) -> Vec<f64> {
        b.chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    fn i64s(b: &[u8]) -> Vec<i64> {
        b.chunks(8)
            .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    #[test]
    fn vtu_round_trips_geometry_cells_and_fields() {
        let points: Vec<[f64; 3]> = (0..9)
            .map(|i| [i as f64, 0.1 * i as f64, -1e-300])
            .collect();
        let hex: Vec<usize> = (0..8).collect();
        let line = [7usize, 8];
        let frame = VtuFrame {
            points: &points,
            blocks: vec![
                VtuBlock {
                    kind: ElementKind::Hex8,
                    connectivity: &hex,
                    cell_data: vec![Field::new(
                        "stress_kPa",
                        6,
                        vec![1.5, 2.0, 3.0, 4.0, 5.0, 6.0],
                    )],
                },
                VtuBlock {
                    kind: ElementKind::Line2,
                    connectivity: &line,
                    cell_data: vec![Field::new("tension_nN", 1, vec![0.25])],
                },
            ],
            point_data: vec![Field::new(
                "u_um",
                3,
                (0..27).map(|v| v as f64 / 3.0).collect(),
            )],
        };
        let xml = vtu_string(&frame).unwrap();
        // Kept on disk for external readers (ParaView, meshio).
        write_vtu(&scratch_dir("vtu").join("roundtrip.vtu"), &frame).unwrap();
        assert!(xml.contains("NumberOfPoints=\"9\" NumberOfCells=\"2\""));
        let (_, p) = array(&xml, "Points");
        assert_eq!(
            f64s(&p),
            points.iter().flatten().copied().collect::<Vec<_>>()
        );
        assert_eq!(
            i64s(&array(&xml, "connectivity").1),
            vec![0, 1, 2, 3, 4, 5, 6, 7, 7, 8]
        );
        assert_eq!(i64s(&array(&xml, "offsets").1), vec![8, 10]);
        assert_eq!(array(&xml, "types").1, vec![12, 3]);
        let (open, u) = array(&xml, "u_um");
        assert!(open.contains("NumberOfComponents=\"3\""), "{open}");
        assert_eq!(f64s(&u), frame.point_data[0].values);
        let s = f64s(&array(&xml, "stress_kPa").1);
        assert_eq!(&s[..6], &[1.5, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert!(s[6..].iter().all(|v| v.is_nan()) && s.len() == 12);
        let t = f64s(&array(&xml, "tension_nN").1);
        assert!(t[0].is_nan() && t[1] == 0.25);
        let ids: Vec<i32> = array(&xml, "block")
            .1
            .chunks(4)
            .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(ids, vec![0, 1]);
    }

    #[test]
    fn inconsistent_frames_are_rejected() {
        let points = [[0.0; 3]; 2];
        let conn = [0usize, 2];
        let frame = VtuFrame {
            points: &points,
            blocks: vec![VtuBlock {
                kind: ElementKind::Line2,
                connectivity: &conn,
                cell_data: vec![],
            }],
            point_data: vec![],
        };
        assert!(vtu_string(&frame)
            .unwrap_err()
            .to_string()
            .contains("point 2 of 2"));
        let conn = [0usize, 1];
        let frame = VtuFrame {
            points: &points,
            blocks: vec![VtuBlock {
                kind: ElementKind::Line2,
                connectivity: &conn,
                cell_data: vec![],
            }],
            point_data: vec![Field::new("u_um", 3, vec![0.0; 5])],
        };
        let err = vtu_string(&frame).unwrap_err().to_string();
        assert!(err.contains("'u_um' has 5 values; expected 2 x 3"), "{err}");
    }

    #[test]
    fn wedge_is_reordered_for_vtk() {
        let points = [[0.0; 3]; 6];
        let conn: Vec<usize> = (0..6).collect();
        let frame = VtuFrame {
            points: &points,
            blocks: vec![VtuBlock {
                kind: ElementKind::Wedge6,
                connectivity: &conn,
                cell_data: vec![],
            }],
            point_data: vec![],
        };
        let xml = vtu_string(&frame).unwrap();
        assert_eq!(i64s(&array(&xml, "connectivity").1), vec![0, 2, 1, 3, 5, 4]);
    }

    #[test]
    fn series_writes_numbered_frames_and_a_valid_collection() {
        let dir = scratch_dir("pvd");
        let mesh = cellmech_fem::mesh::Mesh {
            nodes: vec![[0.0; 3], [1.0, 0.0, 0.0]],
            blocks: vec![cellmech_fem::mesh::ElementBlock {
                name: "bar".into(),
                kind: ElementKind::Line2,
                connectivity: vec![0, 1],
            }],
            node_sets: Default::default(),
        };
        let mut series = PvdSeries::new(&dir.join("out"), "cell").unwrap();
        let frame = VtuFrame::from_mesh(&mesh);
        let first = series.add_frame(0.0, &frame).unwrap();
        let second = series.add_frame(0.5, &frame).unwrap();
        assert!(first.ends_with("cell_0000.vtu") && second.ends_with("cell_0001.vtu"));
        let pvd = std::fs::read_to_string(series.pvd_path()).unwrap();
        assert_eq!(pvd.matches("<DataSet ").count(), 2);
        assert!(pvd.contains("timestep=\"5e-1\" group=\"\" part=\"0\" file=\"cell_0001.vtu\""));
        let vtu = std::fs::read_to_string(&second).unwrap();
        assert!(vtu.contains("NumberOfPoints=\"2\" NumberOfCells=\"1\""));
        assert!(series.add_frame(f64::NAN, &frame).is_err());
        assert_eq!(series.len(), 2);
    }
}
