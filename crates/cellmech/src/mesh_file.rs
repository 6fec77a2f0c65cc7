//! Reading a mesh file named in a scenario: Gmsh `.msh` or Abaqus/CalculiX `.inp`.

use std::path::Path;

use cellmech_fem::mesh::Mesh;

/// Reads the mesh at `path`, choosing the reader by extension. The error message names the
/// file and, for syntax errors, the line.
pub fn read_mesh(path: &Path) -> Result<Mesh, String> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("msh") => cellmech_io::read_gmsh(path).map_err(|e| e.to_string()),
        Some("inp") => cellmech_io::read_abaqus(path).map(|deck| deck.mesh).map_err(|e| e.to_string()),
        _ => Err(format!(
            "{}: unknown mesh format; expected a Gmsh .msh (4.1 ASCII) or an Abaqus/CalculiX .inp file",
            path.display()
        )),
    }
}
