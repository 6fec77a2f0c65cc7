//! Plots of a run's curves, made from the rows the output writer collected.

use std::path::Path;

use cellmech_io::{plot_xy, PlotSpec, Series, SeriesStyle};

use crate::analysis::Analysis as Scenario;
use crate::output::OutputWriter;

/// Draws the force–displacement curve of every requested curve (one file per curve), and
/// of every rigid tool (force along its motion vs its displacement), and returns the file
/// names written.
pub fn plot_curves(
    scenario: &Scenario,
    writer: &OutputWriter,
    dir: &Path,
) -> Result<Vec<String>, String> {
    let extension = scenario.model.output.plot_format.extension();
    let mut files = Vec::new();
    let mut plot =
        |file: String, x_label: &str, y_label: &str, x: Vec<f64>, y: Vec<f64>, label: &str| {
            let spec = PlotSpec {
                title: scenario.title.clone(),
                x_label: x_label.into(),
                y_label: y_label.into(),
                series: vec![Series {
                    label: label.into(),
                    points: x.into_iter().zip(y).collect(),
                    style: SeriesStyle::LineAndMarkers,
                }],
            };
            plot_xy(&dir.join(&file), &spec).map_err(|e| e.to_string())?;
            files.push(file);
            Ok::<(), String>(())
        };
    for (k, curve) in scenario.model.output.curves.iter().enumerate() {
        let c = ["x", "y", "z"][curve.component];
        let [u_column, f_column] = crate::model::curve_columns(&curve.name, curve.component);
        let (Some(u), Some(f)) = (writer.column(&u_column), writer.column(&f_column)) else {
            continue;
        };
        let file = if k == 0 {
            format!("curve.{extension}")
        } else {
            format!("curve_{}.{extension}", curve.name)
        };
        let u = u.iter().map(|v| v.abs()).collect();
        plot(
            file,
            &format!("{} displacement |u{c}| (µm)", curve.name),
            &format!("{} reaction f{c} (nN)", curve.name),
            u,
            f,
            &curve.name,
        )?;
    }
    for tool in &scenario.model.tools {
        let Some(dir) = crate::model::tools::push_direction(&scenario.model, &tool.name) else {
            continue;
        };
        let column = |q: &str| {
            let cols: Option<Vec<Vec<f64>>> = ["x", "y", "z"]
                .iter()
                .map(|c| {
                    writer.column(&format!(
                        "{}_{q}_{c}_{}",
                        tool.name,
                        if q == "force" { "nN" } else { "um" }
                    ))
                })
                .collect();
            cols.map(|c| {
                (0..c[0].len())
                    .map(|r| (0..3).map(|k| c[k][r] * dir[k]).sum::<f64>())
                    .collect::<Vec<f64>>()
            })
        };
        let (Some(u), Some(f)) = (column("displacement"), column("force")) else {
            continue;
        };
        plot(
            format!("{}.{extension}", tool.name),
            &format!("{} displacement towards the body (µm)", tool.name),
            &format!("{} force pushing the body (nN)", tool.name),
            u,
            f,
            &tool.name,
        )?;
    }
    Ok(files)
}
