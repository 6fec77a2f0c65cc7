//! VTK XML `UnstructuredGrid` writer (`.vtu`).
//!
//! Format: inline base64 binary (`format="binary"`, `header_type="UInt64"`, little endian,
//! uncompressed): valid XML that ParaView reads, about 4/3 of the raw size, exact `f64`
//! values. Several blocks of different element kinds go into one file; cell data given for
//! only some blocks is filled with NaN elsewhere. An `Int32` cell field `block` holds each
//! cell's block index.

use std::path::Path;

use cellmech_fem::mesh::{ElementKind, Mesh};

use crate::atomic::write_atomic_with;
use crate::error::WriteError;

/// A named data array with `components` values per point or cell (1 scalar, 3 vector,
/// 6 symmetric tensor in Voigt order xx yy zz xy yz xz, 9 full tensor row by row).
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Name shown in ParaView; include the unit, e.g. `displacement_um`.
    pub name: String,
    /// Values per tuple.
    pub components: usize,
    /// `components` values per point (or cell), tuple by tuple.
    pub values: Vec<f64>,
}

impl Field {
    /// A field from its parts.
    pub fn new(name: impl Into<String>, components: usize, values: Vec<f64>) -> Self {
        Field {
            name: name.into(),
            components,
            values,
        }
    }
}

/// Cells of one element kind and their own cell data.
#[derive(Debug, Clone, PartialEq)]
pub struct VtuBlock<'a> {
    /// Element kind of every cell in the block.
    pub kind: ElementKind,
    /// Flat 0-based connectivity in the node order of [`Mesh`] (Abaqus order).
    pub connectivity: &'a [usize],
    /// Cell fields with one tuple per cell of this block.
    pub cell_data: Vec<Field>,
}

/// Everything written into one `.vtu` file.
#[derive(Debug, Clone, PartialEq)]
pub struct VtuFrame<'a> {
    /// Point coordinates (µm), current or reference configuration.
    pub points: &'a [[f64; 3]],
    /// Cell blocks, written one after the other.
    pub blocks: Vec<VtuBlock<'a>>,
    /// Point fields with one tuple per point.
    pub point_data: Vec<Field>,
}

impl<'a> VtuFrame<'a> {
    /// A frame with the mesh's nodes and every block, without data.
    pub fn from_mesh(mesh: &'a Mesh) -> Self {
        VtuFrame {
            points: &mesh.nodes,
            blocks: mesh
                .blocks
                .iter()
                .map(|b| VtuBlock {
                    kind: b.kind,
                    connectivity: &b.connectivity,
                    cell_data: Vec::new(),
                })
                .collect(),
            point_data: Vec::new(),
        }
    }
}

/// A frame that cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum VtuError {
    /// The frame's data is inconsistent.
    #[error("invalid VTU frame: {0}")]
    Invalid(String),
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// VTK cell type id.
pub fn vtk_cell_type(kind: ElementKind) -> u8 {
    match kind {
        ElementKind::Line2 => 3,
        ElementKind::Tri3 => 5,
        ElementKind::Quad4 => 9,
        ElementKind::Tet4 => 10,
        ElementKind::Hex8 => 12,
        ElementKind::Wedge6 => 13,
        ElementKind::Tet10 => 24,
        ElementKind::Hex20 => 25,
    }
}

/// Abaqus -> VTK node order. Only the wedge differs: VTK wants the first triangle's normal
/// to point away from the second triangle.
fn vtk_order(kind: ElementKind) -> Option<&'static [usize]> {
    match kind {
        ElementKind::Wedge6 => Some(&[0, 2, 1, 3, 5, 4]),
        _ => None,
    }
}

/// Writes `frame` to `path` atomically.
pub fn write_vtu(path: &Path, frame: &VtuFrame<'_>) -> Result<(), VtuError> {
    let xml = vtu_string(frame)?;
    write_atomic_with(path, |w| w.write_all(xml.as_bytes()))?;
    Ok(())
}

/// The XML text of `frame`.
pub fn vtu_string(frame: &VtuFrame<'_>) -> Result<String, VtuError> {
    let n_points = frame.points.len();
    let mut n_cells = 0;
    for (b, block) in frame.blocks.iter().enumerate() {
        let npe = block.kind.nodes_per_element();
        if block.connectivity.len() % npe != 0 {
            return Err(invalid(format!(
                "block {b}: connectivity is not a multiple of {npe}"
            )));
        }
        if let Some(&bad) = block.connectivity.iter().find(|&&v| v >= n_points) {
            return Err(invalid(format!(
                "block {b} refers to point {bad} of {n_points}"
            )));
        }
        for f in &block.cell_data {
            check_field(
                f,
                block.connectivity.len() / npe,
                &format!("block {b} cell"),
            )?;
        }
        n_cells += block.connectivity.len() / npe;
    }
    for f in &frame.point_data {
        check_field(f, n_points, "point")?;
    }
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" ");
    out.push_str("byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n");
    out.push_str(&format!(
        "<Piece NumberOfPoints=\"{n_points}\" NumberOfCells=\"{n_cells}\">\n<Points>\n"
    ));
    let coords: Vec<f64> = frame.points.iter().flatten().copied().collect();
    data_array(&mut out, "Float64", "Points", 3, &f64_bytes(&coords));
    out.push_str("</Points>\n<Cells>\n");
    let mut conn = Vec::new();
    let mut offsets = Vec::with_capacity(n_cells);
    let mut types = Vec::with_capacity(n_cells);
    let mut block_ids = Vec::with_capacity(n_cells);
    for (b, block) in frame.blocks.iter().enumerate() {
        let npe = block.kind.nodes_per_element();
        for element in block.connectivity.chunks_exact(npe) {
            match vtk_order(block.kind) {
                Some(p) => conn.extend(p.iter().map(|&k| element[k] as i64)),
                None => conn.extend(element.iter().map(|&v| v as i64)),
            }
            offsets.push(conn.len() as i64);
            types.push(vtk_cell_type(block.kind));
            block_ids.push(b as i32);
        }
    }
    data_array(&mut out, "Int64", "connectivity", 1, &i64_bytes(&conn));
    data_array(&mut out, "Int64", "offsets", 1, &i64_bytes(&offsets));
    data_array(&mut out, "UInt8", "types", 1, &types);
    out.push_str("</Cells>\n<PointData>\n");
    for f in &frame.point_data {
        data_array(
            &mut out,
            "Float64",
            &f.name,
            f.components,
            &f64_bytes(&f.values),
        );
    }
    out.push_str("</PointData>\n<CellData>\n");
    let ids: Vec<u8> = block_ids.iter().flat_map(|v| v.to_le_bytes()).collect();
    data_array(&mut out, "Int32", "block", 1, &ids);
    for (name, components) in cell_field_names(frame)? {
        let mut values = Vec::with_capacity(n_cells * components);
        for block in &frame.blocks {
            let cells = block.connectivity.len() / block.kind.nodes_per_element();
            match block.cell_data.iter().find(|f| f.name == name) {
                Some(f) => values.extend_from_slice(&f.values),
                None => values.extend(std::iter::repeat_n(f64::NAN, cells * components)),
            }
        }
        data_array(&mut out, "Float64", &name, components, &f64_bytes(&values));
    }
    out.push_str("</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    Ok(out)
}

fn invalid(message: String) -> VtuError {
    VtuError::Invalid(message)
}

fn check_field(f: &Field, tuples: usize, place: &str) -> Result<(), VtuError> {
    if !matches!(f.components, 1 | 2 | 3 | 6 | 9) {
        return Err(invalid(format!(
            "{place} field '{}' has {} components; expected 1, 2, 3, 6 or 9",
            f.name, f.components
        )));
    }
    if f.values.len() != tuples * f.components {
        return Err(invalid(format!(
            "{place} field '{}' has {} values; expected {tuples} x {}",
            f.name,
            f.values.len(),
            f.components
        )));
    }
    Ok(())
}

/// Union of the blocks' cell-field names in first-seen order, with consistent components.
fn cell_field_names(frame: &VtuFrame<'_>) -> Result<Vec<(String, usize)>, VtuError> {
    let mut names: Vec<(String, usize)> = Vec::new();
    for block in &frame.blocks {
        for f in &block.cell_data {
            match names.iter().find(|(n, _)| *n == f.name) {
                Some((_, c)) if *c != f.components => {
                    return Err(invalid(format!(
                        "cell field '{}' has {} components in one block and {c} in another",
                        f.name, f.components
                    )))
                }
                Some(_) => {}
                None => names.push((f.name.clone(), f.components)),
            }
        }
    }
    Ok(names)
}

fn data_array(out: &mut String, ty: &str, name: &str, components: usize, bytes: &[u8]) {
    out.push_str(&format!(
        "<DataArray type=\"{ty}\" Name=\"{}\" NumberOfComponents=\"{components}\" \
         format=\"binary\">\n",
        xml_escape(name)
    ));
    let mut payload = (bytes.len() as u64).to_le_bytes().to_vec();
    payload.extend_from_slice(bytes);
    base64_encode(&payload, out);
    out.push_str("\n</DataArray>\n");
}

fn f64_bytes(values: &[f64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn i64_bytes(values: &[i64]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Escapes the XML special characters of an attribute value.
pub(crate) fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding, appended to `out`.
fn base64_encode(bytes: &[u8], out: &mut String) {
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(B64[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
}

/// The payload bytes of the binary `DataArray` named `name` in VTU text written by
/// [`vtu_string`] (base64 with a UInt64 byte-count header, which is dropped). `None` when the
/// file has no such array. For tests and post-processing that read our files back.
pub fn read_data_array(vtu: &str, name: &str) -> Option<Vec<u8>> {
    let start = vtu.find(&format!("Name=\"{name}\""))?;
    let open = start + vtu[start..].find('>')? + 1;
    let close = open + vtu[open..].find('<')?;
    let bytes = base64_decode(&vtu[open..close]);
    (bytes.len() >= 8).then(|| bytes[8..].to_vec())
}

/// A `Float64` array of VTU text as numbers (see [`read_data_array`]).
pub fn read_f64_array(vtu: &str, name: &str) -> Option<Vec<f64>> {
    Some(
        read_data_array(vtu, name)?
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect(),
    )
}

/// Decodes base64 (whitespace ignored).
pub(crate) fn base64_decode(text: &str) -> Vec<u8> {
    let mut out = Vec::new();
    let digits: Vec<u32> = text
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .map(|c| B64.iter().position(|&d| d == c).expect("base64 digit") as u32)
        .collect();
    for chunk in digits.chunks(4) {
        let mut n = 0u32;
        for (k, d) in chunk.iter().enumerate() {
            n |= d << (18 - 6 * k);
        }
        for k in 0..chunk.len() - 1 {
            out.push((n >> (16 - 8 * k)) as u8);
        }
    }
    out
}
