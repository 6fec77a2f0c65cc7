//! Readers and writers for cellmech.
//!
//! * Meshes in: Gmsh MSH 4.1 ASCII ([`read_gmsh`]) and the mesh part of Abaqus/CalculiX
//!   `.inp` decks ([`read_abaqus`]), both producing a [`cellmech_fem::mesh::Mesh`] and errors
//!   that name the file and line.
//! * Results out: VTK XML unstructured grids and ParaView collections ([`write_vtu`],
//!   [`PvdSeries`]), CSV curves ([`CurveWriter`]), JSON ([`write_json_atomic`]) and line plots
//!   as PNG or SVG ([`plot_xy`]) and orthographic line drawings of 3-D models
//!   ([`plot_model_picture`]).
//!
//! Every writer replaces its file atomically ([`write_atomic`]): a crash leaves the previous
//! complete file or the new complete file, never a truncated one. The formats are described in
//! `docs/file-formats.md`.

pub mod abaqus;
pub mod atomic;
pub mod bars;
pub mod csv_out;
pub mod error;
pub mod gmsh;
pub mod json_out;
mod lines;
pub mod plot;
pub mod pvd;
pub mod tornado;
pub mod view3d;
pub mod vtu;

pub use abaqus::{parse_abaqus, read_abaqus, AbaqusDeck, ElementRef};
pub use atomic::{write_atomic, write_atomic_with};
pub use bars::{plot_bars, BarSpec};
pub use csv_out::{CsvCell, CsvError, CurveWriter};
pub use error::{ReadError, WriteError};
pub use gmsh::{parse_gmsh, read_gmsh};
pub use json_out::{write_json_atomic, JsonError};
pub use plot::{plot_xy, PlotError, PlotSpec, Series, SeriesStyle};
pub use pvd::PvdSeries;
pub use tornado::{plot_tornado, TornadoBar, TornadoSpec};
pub use view3d::{plot_model_picture, LineGroup, ModelPicture, View3d};
pub use vtu::{
    read_data_array, read_f64_array, vtu_string, write_vtu, Field, VtuBlock, VtuError, VtuFrame,
};

#[cfg(test)]
pub(crate) mod test_util {
    use std::path::PathBuf;

    /// A fresh, empty directory for one test.
    pub(crate) fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("cellmech-io-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create scratch dir");
        dir
    }
}
