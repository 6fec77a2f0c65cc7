//! Orthographic line drawings of a 3-D model (PNG or SVG), drawn by the program itself.
//!
//! A [`ModelPicture`] is a list of [`LineGroup`]s (3-D segments sharing one colour, width and
//! legend entry) seen from one or more [`View3d`]s. [`plot_model_picture`] draws every view as
//! a panel, side by side, at one common scale with equal aspect ratio (a sphere is round in
//! every panel), each with its title above it and a small x/y/z axis triad in its lower left
//! corner; one legend under the panels names the groups. Groups are drawn in order, the first
//! underneath. As a depth cue, segments (or the parts of segments) behind the plane through the
//! model's centre (perpendicular to the view direction) are drawn in a lighter tint of their
//! colour, before the segments in front.
//!
//! The text uses the bundled DejaVu Sans font (no system fonts needed); the file is written to
//! a temporary and renamed over the target, like [`crate::plot_xy`].
//!
//! # View convention
//!
//! Azimuth and elevation give the direction from the model's centre to the camera, as in
//! matplotlib's `view_init(elev, azim)`: the camera sits at
//! `(cos el · cos az, cos el · sin az, sin el)` and looks back at the centre. The screen's
//! right and up directions are `(−sin az, cos az, 0)` and `(−sin el · cos az, −sin el · sin az,
//! cos el)`; right × up points at the camera. Hence:
//!
//! | azimuth, elevation | looks along | right | up |
//! |---|---|---|---|
//! | 0°, 0° | −x | +y | +z |
//! | 90°, 0° | −y | −x | +z |
//! | −90°, 0° (front) | +y | +x | +z |
//! | −90°, 90° (top) | −z | +x | +y |
//!
//! Adding 90° to the azimuth turns the camera about +z by 90°, so the view at `az + 90°` of a
//! model rotated by 90° about +z (x → y, y → −x) is the same picture as the view at `az` of
//! the unrotated model.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::plot::{register_font, render, PlotError, PlotFormat, FONT_FAMILY};

/// One group of 3-D line segments drawn in one style, with a legend entry.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineGroup {
    /// Legend entry.
    pub label: String,
    /// Line colour, RGB.
    pub color: (u8, u8, u8),
    /// Line width in pixels (0 is drawn as 1).
    pub width: u32,
    /// Segments as pairs of end points `[x, y, z]` in model units. Segments with a non-finite
    /// coordinate are skipped.
    pub segments: Vec<[[f64; 3]; 2]>,
}

/// Orthographic view: camera direction from azimuth/elevation in degrees.
///
/// See the [module documentation](self) for the convention (matplotlib's: azimuth about +z
/// from +x, elevation above the x-y plane; `0°, 0°` looks along −x with +y to the right and
/// +z up).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct View3d {
    /// Angle of the camera direction about +z, measured from +x towards +y, in degrees.
    pub azimuth_deg: f64,
    /// Angle of the camera direction above the x-y plane, in degrees (90 looks down −z).
    pub elevation_deg: f64,
}

impl View3d {
    /// A view from azimuth and elevation in degrees.
    pub fn new(azimuth_deg: f64, elevation_deg: f64) -> Self {
        Self {
            azimuth_deg,
            elevation_deg,
        }
    }

    /// The screen's unit vectors in model coordinates: `[right, up, toward_camera]`, an
    /// orthonormal right-handed triple (`right × up = toward_camera`).
    pub fn basis(&self) -> [[f64; 3]; 3] {
        let (sa, ca) = self.azimuth_deg.to_radians().sin_cos();
        let (se, ce) = self.elevation_deg.to_radians().sin_cos();
        [
            [-sa, ca, 0.0],
            [-se * ca, -se * sa, ce],
            [ce * ca, ce * sa, se],
        ]
    }

    /// Projects `point` relative to `centre`: `[right, up, depth]` in model units, where
    /// `right`/`up` are the screen coordinates (centre at the origin) and `depth` is positive
    /// towards the camera (in front of the plane through `centre`).
    pub fn project(&self, point: [f64; 3], centre: [f64; 3]) -> [f64; 3] {
        let d = [
            point[0] - centre[0],
            point[1] - centre[1],
            point[2] - centre[2],
        ];
        self.basis()
            .map(|e| e[0] * d[0] + e[1] * d[1] + e[2] * d[2])
    }
}

/// A complete picture: a title, the views (one panel each, with its own title) and the line
/// groups drawn in every view.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelPicture {
    /// Title above all panels (may be empty).
    pub title: String,
    /// `(panel title, view)`, drawn left to right.
    pub views: Vec<(String, View3d)>,
    /// Line groups, drawn in order (the first underneath) and listed in the legend.
    pub groups: Vec<LineGroup>,
}

/// Draws each view as a panel side by side (same scale in all panels, equal aspect ratio,
/// axis triad x/y/z in the corner of each panel), with one legend; PNG or SVG chosen by the
/// path's extension.
///
/// Each panel is 700 × 620 pixels (two views give a 1400 pixel wide picture); the title and
/// the legend add rows above and below. Errors: [`PlotError::UnknownFormat`] for an extension
/// other than `.png`/`.svg`; [`PlotError::InvalidPicture`] when there are no views, no
/// groups, no finite segments, a non-finite view angle, or the model has zero extent (all
/// points coincide, or it projects to a single point in every view).
pub fn plot_model_picture(path: &Path, picture: &ModelPicture) -> Result<(), PlotError> {
    let format = PlotFormat::of(path)?;
    register_font()?;
    let layout = layout(picture).map_err(|reason| PlotError::InvalidPicture {
        path: path.to_path_buf(),
        reason,
    })?;
    render(
        path,
        format,
        layout.size,
        |root| draw(root, &layout),
        |root| draw(root, &layout),
    )
}

const PANEL_W: u32 = 700;
const PANEL_H: u32 = 620;
const TITLE_H: u32 = 52;
const NO_TITLE_H: u32 = 12;
const PANEL_TITLE_H: i32 = 40;
const PANEL_PAD: i32 = 34;
const LEGEND_ROW_H: u32 = 32;
const LEGEND_PAD: u32 = 18;
const LEGEND_SAMPLE: i32 = 32;
const TRIAD_LEN: f64 = 32.0;
const TRIAD_INSET: i32 = 48;
const TITLE_FONT: u32 = 26;
const PANEL_TITLE_FONT: u32 = 20;
const LEGEND_FONT: u32 = 17;
const TRIAD_FONT: u32 = 15;
/// How far towards white the segments behind the centre plane are tinted.
const BACK_TINT: f64 = 0.55;
const TRIAD_AXES: [(&str, RGBColor); 3] = [
    ("x", RGBColor(214, 39, 40)),
    ("y", RGBColor(44, 160, 44)),
    ("z", RGBColor(31, 119, 180)),
];
const FRAME: RGBColor = RGBColor(205, 205, 205);

type Px = (i32, i32);

/// Segments in pixels sharing one style.
#[derive(Debug)]
struct Stroke {
    color: RGBColor,
    width: u32,
    segments: Vec<[Px; 2]>,
}

#[derive(Debug)]
struct TriadAxis {
    label: &'static str,
    color: RGBColor,
    end: Px,
    label_at: Px,
}

#[derive(Debug)]
struct Panel {
    title: String,
    /// `(x0, y0, x1, y1)` of the whole panel including its title.
    rect: (i32, i32, i32, i32),
    /// Strokes in drawing order.
    strokes: Vec<Stroke>,
    triad_origin: Px,
    /// Triad axes, back to front.
    triad: Vec<TriadAxis>,
}

#[derive(Debug)]
struct LegendEntry {
    label: String,
    color: RGBColor,
    width: u32,
    /// Left end of the colour sample, vertically centred.
    at: Px,
}

/// Everything placed in pixels, ready to draw on any backend.
#[derive(Debug)]
struct Layout {
    size: (u32, u32),
    title: String,
    panels: Vec<Panel>,
    legend: Vec<LegendEntry>,
    legend_top: i32,
}

fn text_width(text: &str, size: u32) -> i32 {
    (FONT_FAMILY, size)
        .into_font()
        .box_size(text)
        .map(|(w, _)| w as i32)
        .unwrap_or_else(|_| (text.chars().count() as u32 * size * 3 / 5) as i32)
}

fn tint(c: (u8, u8, u8), towards_white: f64) -> RGBColor {
    let t = |v: u8| (v as f64 + (255.0 - v as f64) * towards_white).round() as u8;
    RGBColor(t(c.0), t(c.1), t(c.2))
}

/// Lays the legend entries out left to right, wrapping at `width`; returns the entries (with
/// `y` relative to the legend's top) and the number of rows.
fn legend_layout(groups: &[LineGroup], width: u32) -> (Vec<LegendEntry>, u32) {
    let left = 30;
    let right = width as i32 - 30;
    let (mut x, mut row) = (left, 0u32);
    let mut entries = Vec::with_capacity(groups.len());
    for g in groups {
        let w = LEGEND_SAMPLE + 8 + text_width(&g.label, LEGEND_FONT);
        if x > left && x + w > right {
            x = left;
            row += 1;
        }
        entries.push(LegendEntry {
            label: g.label.clone(),
            color: RGBColor(g.color.0, g.color.1, g.color.2),
            width: g.width.clamp(2, 8),
            at: (x, (row * LEGEND_ROW_H + LEGEND_ROW_H / 2) as i32),
        });
        x += w + 30;
    }
    (entries, row + 1)
}

/// Validates `picture` and places everything in pixels. The error is a sentence for
/// [`PlotError::InvalidPicture`].
fn layout(picture: &ModelPicture) -> Result<Layout, String> {
    if picture.views.is_empty() {
        return Err("no views to draw".into());
    }
    if let Some((name, _)) = picture
        .views
        .iter()
        .find(|(_, v)| !(v.azimuth_deg.is_finite() && v.elevation_deg.is_finite()))
    {
        return Err(format!(
            "view '{name}' has a non-finite azimuth or elevation"
        ));
    }
    if picture.groups.is_empty() {
        return Err("no line groups to draw".into());
    }
    let finite = |s: &&[[f64; 3]; 2]| s.iter().flatten().all(|c| c.is_finite());
    let segments: Vec<Vec<[[f64; 3]; 2]>> = picture
        .groups
        .iter()
        .map(|g| g.segments.iter().filter(finite).copied().collect())
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in segments.iter().flatten().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if lo[0] > hi[0] {
        return Err("the line groups hold no segments with finite coordinates".into());
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(format!(
            "the model has zero extent (all points at ({}, {}, {}))",
            lo[0], lo[1], lo[2]
        ));
    }
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));

    // Projected extent per view, and the largest scale at which every view fits its panel.
    let draw_w = (PANEL_W as i32 - 2 * PANEL_PAD) as f64;
    let draw_h = (PANEL_H as i32 - PANEL_TITLE_H - 2 * PANEL_PAD) as f64;
    let mut scale = f64::INFINITY;
    let mut mids = Vec::with_capacity(picture.views.len());
    for (_, view) in &picture.views {
        let (mut ulo, mut uhi, mut vlo, mut vhi) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in segments.iter().flatten().flatten() {
            let [u, v, _] = view.project(*p, centre);
            ulo = ulo.min(u);
            uhi = uhi.max(u);
            vlo = vlo.min(v);
            vhi = vhi.max(v);
        }
        // Rounding noise in a flat direction must not set the scale.
        let tiny = 1e-12 * extent;
        if uhi - ulo > tiny {
            scale = scale.min(draw_w / (uhi - ulo));
        }
        if vhi - vlo > tiny {
            scale = scale.min(draw_h / (vhi - vlo));
        }
        mids.push((0.5 * (ulo + uhi), 0.5 * (vlo + vhi)));
    }
    // Depths within rounding noise of the centre plane count as in front.
    let depth_tol = 1e-9 * extent;
    if !scale.is_finite() {
        return Err("the model projects to a single point in every view".into());
    }

    let width = PANEL_W * picture.views.len() as u32;
    let title_h = if picture.title.is_empty() {
        NO_TITLE_H
    } else {
        TITLE_H
    };
    let (mut legend, rows) = legend_layout(&picture.groups, width);
    let legend_top = (title_h + PANEL_H) as i32 + LEGEND_PAD as i32 / 2;
    for e in &mut legend {
        e.at.1 += legend_top;
    }
    let height = title_h + PANEL_H + rows * LEGEND_ROW_H + LEGEND_PAD;

    let round = |x: f64| x.round() as i32;
    let panels = picture
        .views
        .iter()
        .zip(&mids)
        .enumerate()
        .map(|(i, ((title, view), &(um, vm)))| {
            let x0 = (i as u32 * PANEL_W) as i32;
            let y0 = title_h as i32;
            let (x1, y1) = (x0 + PANEL_W as i32, y0 + PANEL_H as i32);
            let cx = x0 as f64 + 0.5 * PANEL_W as f64;
            let cy = (y0 + PANEL_TITLE_H + PANEL_PAD) as f64 + 0.5 * draw_h;
            let to_px =
                |u: f64, v: f64| (round(cx + scale * (u - um)), round(cy - scale * (v - vm)));
            let mut strokes = Vec::with_capacity(2 * segments.len());
            for (group, segs) in picture.groups.iter().zip(&segments) {
                let (mut back, mut front) = (Vec::new(), Vec::new());
                for [a, b] in segs {
                    let [ua, va, da] = view.project(*a, centre);
                    let [ub, vb, db] = view.project(*b, centre);
                    let (pa, pb) = (to_px(ua, va), to_px(ub, vb));
                    if (da < -depth_tol && db > depth_tol) || (da > depth_tol && db < -depth_tol) {
                        // Crosses the centre plane: each part gets its own tint.
                        let t = da / (da - db);
                        let m = to_px(ua + t * (ub - ua), va + t * (vb - va));
                        let (behind, ahead) = if da < 0.0 { (pa, pb) } else { (pb, pa) };
                        back.push([behind, m]);
                        front.push([m, ahead]);
                    } else if da + db < -depth_tol {
                        back.push([pa, pb]);
                    } else {
                        front.push([pa, pb]);
                    }
                }
                let width = group.width.max(1);
                strokes.push(Stroke {
                    color: tint(group.color, BACK_TINT),
                    width,
                    segments: back,
                });
                let c = group.color;
                strokes.push(Stroke {
                    color: RGBColor(c.0, c.1, c.2),
                    width,
                    segments: front,
                });
            }
            let origin = (x0 + TRIAD_INSET, y1 - TRIAD_INSET);
            let [right, up, toward] = view.basis();
            let mut axes: Vec<(f64, TriadAxis)> = TRIAD_AXES
                .iter()
                .enumerate()
                .map(|(k, &(label, color))| {
                    let (du, dv) = (right[k], up[k]);
                    let end = (
                        origin.0 + round(TRIAD_LEN * du),
                        origin.1 - round(TRIAD_LEN * dv),
                    );
                    let r = du.hypot(dv);
                    // An axis pointing at the camera has no direction on screen: label it
                    // beside the origin.
                    let label_at = if r > 0.2 {
                        let s = TRIAD_LEN + 11.0 / r;
                        (origin.0 + round(s * du), origin.1 - round(s * dv))
                    } else {
                        (origin.0 + 11, origin.1 - 11)
                    };
                    (
                        toward[k],
                        TriadAxis {
                            label,
                            color,
                            end,
                            label_at,
                        },
                    )
                })
                .collect();
            axes.sort_by(|a, b| a.0.total_cmp(&b.0));
            Panel {
                title: title.clone(),
                rect: (x0, y0, x1, y1),
                strokes,
                triad_origin: origin,
                triad: axes.into_iter().map(|(_, a)| a).collect(),
            }
        })
        .collect();
    Ok(Layout {
        size: (width, height),
        title: picture.title.clone(),
        panels,
        legend,
        legend_top,
    })
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, layout: &Layout) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let centred = |size: u32| {
        TextStyle::from((FONT_FAMILY, size).into_font()).pos(Pos::new(HPos::Center, VPos::Center))
    };
    if !layout.title.is_empty() {
        root.draw_text(
            &layout.title,
            &centred(TITLE_FONT),
            (layout.size.0 as i32 / 2, TITLE_H as i32 / 2 + 2),
        )
        .map_err(e)?;
    }
    for panel in &layout.panels {
        let (x0, y0, x1, y1) = panel.rect;
        root.draw(&Rectangle::new(
            [(x0 + 4, y0), (x1 - 4, y1)],
            ShapeStyle::from(FRAME).stroke_width(1),
        ))
        .map_err(e)?;
        root.draw_text(
            &panel.title,
            &centred(PANEL_TITLE_FONT),
            ((x0 + x1) / 2, y0 + PANEL_TITLE_H / 2),
        )
        .map_err(e)?;
        for stroke in &panel.strokes {
            let style = ShapeStyle::from(stroke.color).stroke_width(stroke.width);
            for &[a, b] in &stroke.segments {
                root.draw(&PathElement::new(vec![a, b], style)).map_err(e)?;
            }
        }
        for axis in &panel.triad {
            root.draw(&PathElement::new(
                vec![panel.triad_origin, axis.end],
                ShapeStyle::from(axis.color).stroke_width(2),
            ))
            .map_err(e)?;
            root.draw_text(
                axis.label,
                &centred(TRIAD_FONT).color(&axis.color),
                axis.label_at,
            )
            .map_err(e)?;
        }
        root.draw(&Circle::new(panel.triad_origin, 2, BLACK.filled()))
            .map_err(e)?;
    }
    root.draw(&PathElement::new(
        vec![
            (4, layout.legend_top),
            (layout.size.0 as i32 - 4, layout.legend_top),
        ],
        ShapeStyle::from(FRAME).stroke_width(1),
    ))
    .map_err(e)?;
    let label_style = TextStyle::from((FONT_FAMILY, LEGEND_FONT).into_font())
        .pos(Pos::new(HPos::Left, VPos::Center));
    for entry in &layout.legend {
        let (x, y) = entry.at;
        root.draw(&PathElement::new(
            vec![(x, y), (x + LEGEND_SAMPLE, y)],
            ShapeStyle::from(entry.color).stroke_width(entry.width),
        ))
        .map_err(e)?;
        root.draw_text(&entry.label, &label_style, (x + LEGEND_SAMPLE + 8, y))
            .map_err(e)?;
    }
    root.present().map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::scratch_dir;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12)
    }

    /// Latitude and longitude circles of a sphere of radius `r` around `c`.
    fn sphere_lines(c: [f64; 3], r: f64) -> Vec<[[f64; 3]; 2]> {
        let point = |lat: f64, lon: f64| {
            let (lat, lon) = (lat.to_radians(), lon.to_radians());
            [
                c[0] + r * lat.cos() * lon.cos(),
                c[1] + r * lat.cos() * lon.sin(),
                c[2] + r * lat.sin(),
            ]
        };
        let mut segs = Vec::new();
        for lat in [-60.0, -30.0, 0.0, 30.0, 60.0] {
            for i in 0..72 {
                let (a, b) = (5.0 * i as f64, 5.0 * (i + 1) as f64);
                segs.push([point(lat, a), point(lat, b)]);
            }
        }
        for lon in (0..12).map(|i| 30.0 * i as f64) {
            for i in 0..36 {
                let (a, b) = (-90.0 + 5.0 * i as f64, -90.0 + 5.0 * (i + 1) as f64);
                segs.push([point(a, lon), point(b, lon)]);
            }
        }
        segs
    }

    fn sphere_picture() -> ModelPicture {
        let diameter = |k: usize| {
            let mut a = [0.0; 3];
            let mut b = [0.0; 3];
            a[k] = -1.0;
            b[k] = 1.0;
            vec![[a, b]]
        };
        ModelPicture {
            title: "Unit sphere".into(),
            views: vec![
                (
                    "oblique (azimuth −60°, elevation 25°)".into(),
                    View3d::new(-60.0, 25.0),
                ),
                (
                    "top (azimuth −90°, elevation 90°)".into(),
                    View3d::new(-90.0, 90.0),
                ),
            ],
            groups: vec![
                LineGroup {
                    label: "surface".into(),
                    color: (170, 170, 170),
                    width: 1,
                    segments: sphere_lines([0.0; 3], 1.0),
                },
                LineGroup {
                    label: "x diameter".into(),
                    color: (214, 39, 40),
                    width: 3,
                    segments: diameter(0),
                },
                LineGroup {
                    label: "y diameter".into(),
                    color: (44, 160, 44),
                    width: 3,
                    segments: diameter(1),
                },
                LineGroup {
                    label: "z diameter".into(),
                    color: (31, 119, 180),
                    width: 3,
                    segments: diameter(2),
                },
            ],
        }
    }

    fn png_size(bytes: &[u8]) -> (u32, u32) {
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        assert_eq!(&bytes[12..16], b"IHDR", "first chunk is IHDR");
        let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
        (be(&bytes[16..20]), be(&bytes[20..24]))
    }

    #[test]
    fn basis_is_orthonormal_and_right_handed() {
        for (az, el) in [(0.0, 0.0), (-60.0, 25.0), (137.0, -40.0), (10.0, 90.0)] {
            let [r, u, t] = View3d::new(az, el).basis();
            let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            for (a, b, want) in [
                (r, r, 1.0),
                (u, u, 1.0),
                (t, t, 1.0),
                (r, u, 0.0),
                (r, t, 0.0),
                (u, t, 0.0),
            ] {
                assert!((dot(a, b) - want).abs() < 1e-12, "az {az} el {el}");
            }
            let cross = [
                r[1] * u[2] - r[2] * u[1],
                r[2] * u[0] - r[0] * u[2],
                r[0] * u[1] - r[1] * u[0],
            ];
            assert!(
                close(cross, t),
                "right × up = toward camera at az {az} el {el}"
            );
        }
    }

    #[test]
    fn points_on_the_view_axis_project_to_the_centre() {
        let centre = [1.0, -2.0, 0.5];
        for (az, el) in [(0.0, 0.0), (-60.0, 25.0), (200.0, -70.0), (45.0, 90.0)] {
            let view = View3d::new(az, el);
            let toward = view.basis()[2];
            for t in [-3.0, 0.0, 2.5] {
                let p = [0, 1, 2].map(|k| centre[k] + t * toward[k]);
                let [u, v, d] = view.project(p, centre);
                assert!(
                    u.abs() < 1e-12 && v.abs() < 1e-12,
                    "az {az} el {el}: ({u}, {v})"
                );
                assert!(
                    (d - t).abs() < 1e-12,
                    "depth is the distance towards the camera"
                );
            }
        }
    }

    #[test]
    fn documented_axis_conventions() {
        let o = [0.0; 3];
        let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        // Azimuth 0, elevation 0 looks along −x: x points at the camera, y right, z up.
        let v = View3d::new(0.0, 0.0);
        assert!(close(v.project(x, o), [0.0, 0.0, 1.0]));
        assert!(close(v.project(y, o), [1.0, 0.0, 0.0]));
        assert!(close(v.project(z, o), [0.0, 1.0, 0.0]));
        // Azimuth 90 looks along −y: −x to the right.
        let v = View3d::new(90.0, 0.0);
        assert!(close(v.project(y, o), [0.0, 0.0, 1.0]));
        assert!(close(v.project(x, o), [-1.0, 0.0, 0.0]));
        // Front view (azimuth −90) has x right and z up; the top view adds y up.
        let v = View3d::new(-90.0, 0.0);
        assert!(close(v.project(x, o), [1.0, 0.0, 0.0]));
        assert!(close(v.project(z, o), [0.0, 1.0, 0.0]));
        let v = View3d::new(-90.0, 90.0);
        assert!(close(v.project(x, o), [1.0, 0.0, 0.0]));
        assert!(close(v.project(y, o), [0.0, 1.0, 0.0]));
        assert!(close(v.project(z, o), [0.0, 0.0, 1.0]));
    }

    #[test]
    fn ninety_degrees_of_azimuth_map_x_to_y() {
        // The view at az + 90° of the model rotated by 90° about +z (x → y, y → −x) equals
        // the view at az of the unrotated model.
        let rot = |p: [f64; 3]| [-p[1], p[0], p[2]];
        let centre = [0.3, -0.2, 0.1];
        let points = [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.7, -1.3, 2.1],
            [-0.4, 0.9, -0.6],
        ];
        for (az, el) in [(0.0, 0.0), (-60.0, 25.0), (33.0, -50.0)] {
            let (a, b) = (View3d::new(az, el), View3d::new(az + 90.0, el));
            for p in points {
                assert!(
                    close(a.project(p, centre), b.project(rot(p), rot(centre))),
                    "az {az} el {el} p {p:?}"
                );
            }
        }
        // In particular: where x is drawn at azimuth 0, y is drawn at azimuth 90.
        let o = [0.0; 3];
        assert!(close(
            View3d::new(0.0, 0.0).project([1.0, 0.0, 0.0], o),
            View3d::new(90.0, 0.0).project([0.0, 1.0, 0.0], o)
        ));
    }

    /// Pixel bounding box of the strokes of one group (both tints) in one panel.
    fn pixel_box(panel: &Panel, group: usize) -> (i32, i32, i32, i32) {
        let mut b = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
        for s in &panel.strokes[2 * group..2 * group + 2] {
            for p in s.segments.iter().flatten() {
                b = (b.0.min(p.0), b.1.min(p.1), b.2.max(p.0), b.3.max(p.1));
            }
        }
        b
    }

    #[test]
    fn spheres_are_round_and_panels_share_one_scale() {
        let mut picture = sphere_picture();
        picture.views.push(("side".into(), View3d::new(0.0, 0.0)));
        let layout = layout(&picture).unwrap();
        assert_eq!(layout.size.0, 3 * PANEL_W);
        let mut sizes = Vec::new();
        for panel in &layout.panels {
            let (x0, y0, x1, y1) = pixel_box(panel, 0);
            let (w, h) = (x1 - x0, y1 - y0);
            assert!((w - h).abs() <= 2, "equal aspect: {w} × {h}");
            // Inside the panel, below its title.
            let (px0, py0, px1, py1) = panel.rect;
            assert!(x0 > px0 && x1 < px1 && y0 > py0 + PANEL_TITLE_H && y1 < py1);
            sizes.push(w);
        }
        let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
        assert!(hi - lo <= 2, "common scale: {sizes:?}");
        assert!(*lo > 400, "the model fills the panel: {sizes:?}");
    }

    #[test]
    fn back_segments_are_lighter_and_drawn_first() {
        let layout = layout(&sphere_picture()).unwrap();
        let top = &layout.panels[1];
        // Seen from above, the southern hemisphere is behind: lighter, and drawn before.
        let (back, front) = (&top.strokes[0], &top.strokes[1]);
        assert!(!back.segments.is_empty() && !front.segments.is_empty());
        assert_eq!(front.color, RGBColor(170, 170, 170));
        assert!(back.color.0 > front.color.0);
        // Groups keep their order: the surface first, then the diameters.
        assert_eq!(top.strokes[3].color, RGBColor(214, 39, 40));
        assert_eq!(top.strokes[7].color, RGBColor(31, 119, 180));
        // The top view's equator lies in the centre plane: all of it counts as in front.
        assert_eq!(back.segments.len() + front.segments.len(), 5 * 72 + 12 * 36);
        assert_eq!(
            back.segments.len(),
            2 * 72 + 12 * 18,
            "southern latitudes and meridian halves"
        );
        // Seen obliquely from above, the z diameter crosses the centre plane and is split
        // there: the lower half (behind) lighter, the upper half in front.
        let oblique = &layout.panels[0];
        let (z_back, z_front) = (&oblique.strokes[6], &oblique.strokes[7]);
        assert_eq!((z_back.segments.len(), z_front.segments.len()), (1, 1));
        let (lower, upper) = (z_back.segments[0], z_front.segments[0]);
        assert_eq!(lower[1], upper[0], "split at the centre");
        assert!(
            lower[0].1 > lower[1].1 && upper[1].1 < upper[0].1,
            "lower half behind"
        );
    }

    #[test]
    fn writes_png_of_the_expected_size() {
        let dir = scratch_dir("view3d-png");
        let path = dir.join("sphere.png");
        let picture = sphere_picture();
        plot_model_picture(&path, &picture).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (w, h) = png_size(&bytes);
        assert_eq!(w, 1400, "two panels of {PANEL_W} px");
        assert_eq!(
            h,
            TITLE_H + PANEL_H + LEGEND_ROW_H + LEGEND_PAD,
            "one legend row"
        );
        assert_eq!((w, h), layout(&picture).unwrap().size);
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "no temporary files left: {names:?}");
    }

    #[test]
    fn svg_names_every_group_and_panel() {
        let dir = scratch_dir("view3d-svg");
        let path = dir.join("sphere.SVG");
        let mut picture = sphere_picture();
        // Long labels wrap onto further legend rows within the width.
        picture.groups.push(LineGroup {
            label: "a rather long legend label for the cortex mesh at rest".into(),
            color: (0, 0, 0),
            width: 1,
            segments: vec![],
        });
        picture.groups.push(LineGroup {
            label: "another rather long label, for actin stress fibres".into(),
            color: (148, 103, 189),
            width: 2,
            segments: vec![[[0.0, 0.0, 0.0], [0.5, 0.5, f64::NAN]]],
        });
        let layout = layout(&picture).unwrap();
        assert!(layout.legend.iter().all(|e| e.at.0 + 40 < 1400));
        assert!(
            layout.legend.last().unwrap().at.1 > layout.legend[0].at.1,
            "wrapped"
        );
        plot_model_picture(&path, &picture).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"), "{svg:.200}");
        assert!(svg.contains("width=\"1400\""), "{svg:.200}");
        for g in &picture.groups {
            assert!(svg.contains(&g.label), "legend names {}", g.label);
        }
        for (title, _) in &picture.views {
            assert!(svg.contains(title.as_str()), "panel title {title}");
        }
        assert!(svg.contains("Unit sphere"));
    }

    #[test]
    fn unusable_pictures_give_clear_errors() {
        let dir = scratch_dir("view3d-errors");
        let path = dir.join("bad.png");
        let message = |picture: &ModelPicture| match plot_model_picture(&path, picture).unwrap_err()
        {
            e @ PlotError::InvalidPicture { .. } => e.to_string(),
            e => panic!("unexpected error {e}"),
        };
        let good = sphere_picture();

        let mut p = good.clone();
        p.groups.clear();
        assert!(message(&p).contains("no line groups"), "{}", message(&p));

        let mut p = good.clone();
        p.views.clear();
        assert!(message(&p).contains("no views"));

        let mut p = good.clone();
        p.views[1].1.elevation_deg = f64::NAN;
        assert!(message(&p).contains("non-finite azimuth or elevation"));

        let mut p = good.clone();
        for g in &mut p.groups {
            g.segments = vec![[[f64::INFINITY, 0.0, 0.0], [0.0, 0.0, 0.0]]];
        }
        assert!(message(&p).contains("no segments with finite coordinates"));
        p.groups[0].segments.clear();
        assert!(message(&p).contains("no segments with finite coordinates"));

        let mut p = good.clone();
        for g in &mut p.groups {
            g.segments = vec![[[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]];
        }
        let m = message(&p);
        assert!(m.contains("zero extent") && m.contains("bad.png"), "{m}");

        // A segment along the only view direction collapses to a point.
        let mut p = good.clone();
        p.views = vec![("end-on".into(), View3d::new(0.0, 0.0))];
        for g in &mut p.groups {
            g.segments = vec![[[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]];
        }
        assert!(message(&p).contains("single point in every view"));

        let err = plot_model_picture(&dir.join("bad.jpg"), &good).unwrap_err();
        assert!(matches!(err, PlotError::UnknownFormat { .. }), "{err}");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            0,
            "nothing written"
        );
    }

    /// Renders the demo picture into `target/view3d-demo.png` for a look by eye.
    #[test]
    fn demo_sphere_picture() {
        let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target");
        std::fs::create_dir_all(&target).unwrap();
        let path = target.join("view3d-demo.png");
        plot_model_picture(&path, &sphere_picture()).unwrap();
        let (w, _) = png_size(&std::fs::read(&path).unwrap());
        assert_eq!(w, 1400);
    }
}
