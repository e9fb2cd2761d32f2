//! Pictures of what the decoder sees (people would rather look than read):
//!
//! - one pixel: its fringe samples against frequency (the f-domain) and what the decoder reads
//!   its lights from against column (the c-domain), with the lights it found marked — paper
//!   Figs. 3 and 8; for EFSM one pair of panels per group plus its mask levels;
//! - one row: that c-domain view of every pixel of a camera row as an image, pixel `x`
//!   across, column down — paper Fig. 4e, where direct and indirect light show up as separate
//!   lines.
//!
//! The c-domain view is the decoder's own: for a plan decoded by the cosine search (the
//! default), the light of every column, the inverse cosine transform of the samples
//! ([`Decoder::profile`], SPEC §2b); for the DFT searches (CLEAN, local maxima), the magnitude of
//! the spectrum ([`Decoder::spectrum`]). The numbers come from `fsm_core`'s decoder
//! ([`Decoder::peaks`], [`Decoder::decode_pixel`]); this module only draws them (`plotters`,
//! bitmap backend, PNG).
//!
//! The baselines (phase shift, Micro Phase Shifting, Code Ensemble, line scanning) have their
//! own views in [`sequence`].

use std::path::Path;

use fsm_core::{Decoder, Group, Method, Row, ScanPlan};
use plotters::coord::ReverseCoordTranslate;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::candidate_file::HostCandidates;
use crate::capture::Capture;
use crate::error::{Error, Result};
use crate::image_files;
use crate::map_picture::{register_font, FONT};
use crate::outputs::StagedFile;
use crate::plan_file::MethodPlan;

pub mod sequence;

/// One group's view of a pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupView {
    /// The group (BFSM: group 1).
    pub group: Group,
    /// `f_m` of each fringe, cycles per column.
    pub frequencies: Vec<f64>,
    /// The fringe samples, DN.
    pub samples: Vec<u16>,
    /// Column (BFSM) or local column `c̃` (EFSM) of each bin.
    pub bin_columns: Vec<f32>,
    /// Of each bin: `|X_k|` (DFT searches), or the light of the column, DN of fringe
    /// modulation (cosine search: [`GroupView::profile`]; noise makes some slightly negative).
    pub magnitudes: Vec<f32>,
    /// Whether `magnitudes` is the column profile of the cosine search, one bin per column.
    pub profile: bool,
    /// Peaks found: (span-domain column, magnitude at the peak, amplitude DN).
    pub peaks: Vec<(f32, f32, f32)>,
    /// EFSM: each mask's sample, DN (empty for BFSM).
    pub masks: Vec<u16>,
}

/// Everything the pixel plot shows.
#[derive(Clone, Debug)]
pub struct PixelView {
    /// Camera pixel.
    pub x: u32,
    /// Camera row.
    pub y: u32,
    /// Dark reference sample, DN.
    pub dark: Option<u16>,
    /// White reference sample, DN.
    pub white: Option<u16>,
    /// Per group.
    pub groups: Vec<GroupView>,
    /// The decoder's candidates for the pixel.
    pub candidates: HostCandidates,
}

fn decoder_tables(plan: &ScanPlan) -> Vec<f32> {
    vec![0.0; Decoder::tables_len(plan)]
}

fn new_decoder<'t>(plan: &ScanPlan, tables: &'t mut [f32]) -> Result<Decoder<'t>> {
    Decoder::new(plan, tables)
        .map_err(|e| Error::Usage(format!("cannot decode with this plan: {e}")))
}

/// What the decoder sees at pixel `x` of a temporal row (`frames[i·W + x]`).
pub fn pixel_view(
    plan: &ScanPlan,
    frames: &[u16],
    width: usize,
    bit_depth: u8,
    x: u32,
    y: u32,
) -> Result<PixelView> {
    let mut tables = decoder_tables(plan);
    let decoder = new_decoder(plan, &mut tables)?;
    let row = Row {
        frames,
        width,
        bit_depth,
        column_limits: None,
    };
    let xi = x as usize;
    let row_error = |e: fsm_core::RowError| Error::Usage(format!("pixel ({x}, {y}): {e}"));
    let mut scratch = vec![0.0f32; Decoder::scratch_len(plan)];
    let sample = |i: usize| frames[i * width + xi];
    let mut groups = Vec::new();
    for group in plan.groups() {
        let mut magnitudes = Vec::new();
        let profile = c_domain(&decoder, &row, xi, group, &mut scratch, &mut magnitudes)
            .map_err(row_error)?;
        let bin_columns = bin_columns(plan, magnitudes.len(), profile);
        let peaks = decoder
            .peaks(&row, xi, group, &mut scratch)
            .map_err(row_error)?;
        let start = plan.fringe_start(group);
        let masks = match plan.method {
            Method::Bfsm => Vec::new(),
            Method::Efsm(_) => {
                let m0 = plan.mask_start(group);
                (0..plan.mask_count(group) as usize)
                    .map(|i| sample(m0 + i))
                    .collect()
            }
        };
        groups.push(GroupView {
            group,
            frequencies: (0..plan.band.count).map(|m| plan.frequency(m)).collect(),
            samples: (0..plan.band.count as usize)
                .map(|m| sample(start + m))
                .collect(),
            bin_columns,
            magnitudes,
            profile,
            peaks: peaks
                .peaks
                .iter()
                .map(|p| (p.column, p.magnitude, p.amplitude))
                .collect(),
            masks,
        });
    }
    let mut candidates = HostCandidates::new();
    decoder
        .decode_pixel(&row, xi, &mut scratch, &mut candidates)
        .map_err(row_error)?;
    Ok(PixelView {
        x,
        y,
        dark: plan.dark_index().map(sample),
        white: plan.white_index().map(sample),
        groups,
        candidates,
    })
}

/// Appends to `out` what the decoder reads a pixel's lights from, one value per bin (see the
/// module's docs); returns whether it is the cosine search's column profile.
fn c_domain(
    decoder: &Decoder<'_>,
    row: &Row<'_>,
    x: usize,
    group: Group,
    scratch: &mut [f32],
    out: &mut Vec<f32>,
) -> std::result::Result<bool, fsm_core::RowError> {
    if let Some(profile) = decoder.profile(row, x, group, scratch)? {
        out.extend_from_slice(profile);
        return Ok(true);
    }
    let spectrum = decoder.spectrum(row, x, group, scratch)?;
    out.extend((0..spectrum.len()).map(|k| spectrum.magnitude(k)));
    Ok(false)
}

/// The column (or `c̃`) of each of `bins` bins: one per column for a profile, the spectrum's
/// bin columns otherwise.
fn bin_columns(plan: &ScanPlan, bins: usize, profile: bool) -> Vec<f32> {
    (0..bins)
        .map(|k| {
            if profile {
                k as f32
            } else {
                plan.bin_column(k as f32)
            }
        })
        .collect()
}

/// The c-domain of a whole row: one view per pixel (see the module's docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RowMap {
    /// Camera row.
    pub y: u32,
    /// The group shown.
    pub group: Group,
    /// Pixels `W`.
    pub width: usize,
    /// Column (or `c̃`) of each bin.
    pub bin_columns: Vec<f32>,
    /// Pixel `x`'s value at bin `k` (as [`GroupView::magnitudes`]): `magnitudes[x·bins + k]`.
    pub magnitudes: Vec<f32>,
    /// Whether the values are the cosine search's column profiles.
    pub profile: bool,
}

impl RowMap {
    /// Bins per pixel.
    pub fn bins(&self) -> usize {
        self.bin_columns.len()
    }

    /// The spectrum of pixel `x`.
    pub fn spectrum(&self, x: usize) -> &[f32] {
        &self.magnitudes[x * self.bins()..(x + 1) * self.bins()]
    }
}

/// The spectra of every pixel of a temporal row for `group`.
pub fn row_map(
    plan: &ScanPlan,
    frames: &[u16],
    width: usize,
    bit_depth: u8,
    y: u32,
    group: Group,
) -> Result<RowMap> {
    if group.index() >= plan.group_count() {
        return Err(Error::Usage(format!(
            "the plan has no group {}",
            group.number()
        )));
    }
    let mut tables = decoder_tables(plan);
    let decoder = new_decoder(plan, &mut tables)?;
    let row = Row {
        frames,
        width,
        bit_depth,
        column_limits: None,
    };
    let mut scratch = vec![0.0f32; Decoder::scratch_len(plan)];
    let mut magnitudes = Vec::new();
    let mut profile = false;
    for x in 0..width {
        profile = c_domain(&decoder, &row, x, group, &mut scratch, &mut magnitudes)
            .map_err(|e| Error::Usage(format!("row {y}: {e}")))?;
    }
    let bins = magnitudes.len() / width.max(1);
    Ok(RowMap {
        y,
        group,
        width,
        bin_columns: bin_columns(plan, bins, profile),
        magnitudes,
        profile,
    })
}

/// Plots pixel `(x, y)` of `capture` as `plan`'s method shows it into the PNG `out` (FSM:
/// [`pixel_view`]; the others: [`sequence::sequence_view`]); returns the pixel's candidates.
pub fn draw_pixel(
    plan: &MethodPlan,
    capture: &Capture,
    x: u32,
    y: u32,
    out: &Path,
) -> Result<HostCandidates> {
    check_pixel(capture, x, y)?;
    let frames = temporal_row(capture, y)?;
    let (width, bit_depth) = (capture.width() as usize, capture.bit_depth());
    if let MethodPlan::Fsm(p) = plan {
        let view = pixel_view(p, &frames, width, bit_depth, x, y)?;
        plot_pixel(p, &view, out)?;
        return Ok(view.candidates);
    }
    let view = sequence::sequence_view(plan, &frames, width, bit_depth, x, y)?;
    sequence::plot_sequence(plan, &view, out)?;
    Ok(view.candidates)
}

/// The candidates of pixel `(x, y)` ([`draw_pixel`]'s) as `fsm inspect --pixel` prints them:
/// one a line, with the group and block each came from for an FSM plan.
pub fn candidate_lines(plan: &MethodPlan, x: u32, y: u32, candidates: &HostCandidates) -> String {
    if candidates.candidates.is_empty() {
        return format!("pixel ({x}, {y}): no candidate\n");
    }
    let mut text = String::new();
    for c in &candidates.candidates {
        let origin = match plan {
            MethodPlan::Fsm(_) => format!(", group {}, block {}", c.group.number(), c.block),
            _ => String::new(),
        };
        text += &format!(
            "pixel ({x}, {y}): column {:.3}, amplitude {:.1} DN{origin}\n",
            c.column, c.amplitude
        );
    }
    text
}

/// Draws row `y` of `capture` as `plan`'s method shows it into the PNG `out` (FSM: the
/// [`row_map`] of `group`, group 1 by default; the others, which have no groups: every pixel's
/// candidates, [`sequence::plot_sequence_row`]).
pub fn draw_row(
    plan: &MethodPlan,
    capture: &Capture,
    y: u32,
    group: Option<Group>,
    out: &Path,
) -> Result<()> {
    if let (false, Some(g)) = (matches!(plan, MethodPlan::Fsm(_)), group) {
        return Err(Error::Usage(format!(
            "group {}: a {} plan has no pattern groups",
            g.number(),
            plan.name()
        )));
    }
    let frames = temporal_row(capture, y)?;
    let (width, bit_depth) = (capture.width() as usize, capture.bit_depth());
    if let MethodPlan::Fsm(p) = plan {
        let map = row_map(p, &frames, width, bit_depth, y, group.unwrap_or(Group::One))?;
        return plot_row_map(p, &map, out);
    }
    let pixels = sequence::row_candidates(plan, &frames, width, bit_depth, y)?;
    sequence::plot_sequence_row(plan, y, &frames, width, &pixels, out)
}

/// The samples of camera row `y` (`frames[i·W + x]`).
fn temporal_row(capture: &Capture, y: u32) -> Result<Vec<u16>> {
    let mut frames = vec![0u16; capture.row_len()];
    capture.read_row(y, &mut frames)?;
    Ok(frames)
}

/// `"{what} — candidates: 412.25 (900 DN), …"` (or `none`): a pixel plot's title.
fn candidates_title(what: &str, candidates: &HostCandidates) -> String {
    let list: Vec<String> = candidates
        .candidates
        .iter()
        .map(|c| format!("{:.2} ({:.0} DN)", c.column, c.amplitude))
        .collect();
    let list = if list.is_empty() {
        "none".to_owned()
    } else {
        list.join(", ")
    };
    format!("{what} — candidates: {list}")
}

/// Paints the plotting area of a row map (camera pixel `x` across, column `c` down) with the
/// colour of `value(x, c)` in `[0, 1]`.
fn paint_row_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    area: &DrawingArea<
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    value: impl Fn(f64, f64) -> f64,
) -> std::result::Result<(), String> {
    let (xr, yr) = area.get_pixel_range();
    let spec = area.as_coord_spec().clone();
    for py in yr {
        for px in xr.clone() {
            let Some((x, c)) = spec.reverse_translate((px, py)) else {
                continue;
            };
            let color = ViridisRGB.get_color_normalized(value(x, c).clamp(0.0, 1.0), 0.0, 1.0);
            root.draw_pixel((px, py), &color)
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

/// Refuses a pixel outside the capture's images.
fn check_pixel(capture: &Capture, x: u32, y: u32) -> Result<()> {
    if x >= capture.width() || y >= capture.height() {
        return Err(Error::Usage(format!(
            "pixel ({x}, {y}) is outside the {}x{} images of the {}",
            capture.width(),
            capture.height(),
            capture.describe()
        )));
    }
    Ok(())
}

fn draw_error(out: &Path) -> impl Fn(String) -> Error + '_ {
    move |message| Error::Encode {
        path: out.to_path_buf(),
        message: format!("drawing failed: {message}"),
    }
}

/// Renders `draw` on a white `width × height` canvas and writes it as PNG, whole or not at all.
fn render_png(
    out: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(
        &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    ) -> std::result::Result<(), String>,
) -> Result<()> {
    register_font();
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE)
            .map_err(|e| draw_error(out)(e.to_string()))?;
        draw(&root).map_err(draw_error(out))?;
        root.present().map_err(|e| draw_error(out)(e.to_string()))?;
    }
    let mut file = StagedFile::create(out)?;
    image_files::write_png_rgb8(file.writer(), width, height, &rgb).map_err(|e| Error::Encode {
        path: out.to_path_buf(),
        message: e.0,
    })?;
    file.commit()
}

fn span_label(plan: &ScanPlan) -> &'static str {
    match plan.method {
        Method::Bfsm => "projector column c",
        Method::Efsm(_) => "local column c~ (within a block)",
    }
}

/// Draws the pixel view: per group the f-domain samples, the c-domain magnitude with the
/// peaks marked, and (EFSM) the mask levels.
pub fn plot_pixel(plan: &ScanPlan, view: &PixelView, out: &Path) -> Result<()> {
    let efsm = !matches!(plan.method, Method::Bfsm);
    let panels_per_group = if efsm { 3 } else { 2 };
    let rows = panels_per_group * view.groups.len();
    let (width, height) = (1200u32, 60 + 330 * rows as u32);
    let title = candidates_title(&format!("pixel ({}, {})", view.x, view.y), &view.candidates);
    render_png(out, (width, height), |root| {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let (top, body) = root.split_vertically(50);
        top.draw(&Text::new(title.as_str(), (20, 15), (FONT, 22).into_font()))
            .map_err(|x| e(&x))?;
        let areas = body.split_evenly((rows, 1));
        for (g, gv) in view.groups.iter().enumerate() {
            let suffix = if efsm {
                format!(" — group {}", gv.group.number())
            } else {
                String::new()
            };
            let base = g * panels_per_group;
            // f-domain
            let f_max = gv.frequencies.last().copied().unwrap_or(0.5) * 1.02;
            let s_max = gv
                .samples
                .iter()
                .copied()
                .chain(view.white)
                .max()
                .unwrap_or(1)
                .max(1) as f64
                * 1.05;
            let mut chart = ChartBuilder::on(&areas[base])
                .caption(format!("fringe samples (f-domain){suffix}"), (FONT, 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(0.0..f_max, 0.0..s_max)
                .map_err(|x| e(&x))?;
            chart
                .configure_mesh()
                .x_desc("frequency f (cycles per column)")
                .y_desc("sample (DN)")
                .label_style((FONT, 14))
                .draw()
                .map_err(|x| e(&x))?;
            let points: Vec<(f64, f64)> = gv
                .frequencies
                .iter()
                .zip(&gv.samples)
                .map(|(&f, &s)| (f, s as f64))
                .collect();
            chart
                .draw_series(LineSeries::new(points.iter().copied(), BLUE.mix(0.6)))
                .map_err(|x| e(&x))?;
            if points.len() <= 256 {
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 2, BLUE.filled())))
                    .map_err(|x| e(&x))?;
            }
            for (level, label, color) in [(view.dark, "dark", BLACK), (view.white, "white", RED)] {
                if let Some(level) = level {
                    let level = level as f64;
                    chart
                        .draw_series(LineSeries::new(
                            [(0.0, level), (f_max, level)],
                            color.mix(0.5),
                        ))
                        .map_err(|x| e(&x))?
                        .label(format!("{label} reference ({level:.0} DN)"))
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
                }
            }
            if view.dark.is_some() || view.white.is_some() {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .label_font((FONT, 14))
                    .draw()
                    .map_err(|x| e(&x))?;
            }
            // c-domain
            let c_max = gv.bin_columns.last().copied().unwrap_or(1.0) as f64;
            let m_max = gv
                .magnitudes
                .iter()
                .copied()
                .fold(0.0f32, f32::max)
                .max(1e-3) as f64
                * 1.12;
            // A column profile dips below zero where there is only noise.
            let m_min = gv.magnitudes.iter().copied().fold(0.0f32, f32::min) as f64 * 1.12;
            let (caption, y_desc) = if gv.profile {
                (
                    "light per column (inverse cosine transform), lights marked",
                    "light (DN of fringe modulation)",
                )
            } else {
                ("spectrum magnitude (c-domain), peaks marked", "|X| (DN)")
            };
            let mut chart = ChartBuilder::on(&areas[base + 1])
                .caption(format!("{caption}{suffix}"), (FONT, 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(0.0..c_max, m_min..m_max)
                .map_err(|x| e(&x))?;
            chart
                .configure_mesh()
                .x_desc(span_label(plan))
                .y_desc(y_desc)
                .label_style((FONT, 14))
                .draw()
                .map_err(|x| e(&x))?;
            chart
                .draw_series(LineSeries::new(
                    gv.bin_columns
                        .iter()
                        .zip(&gv.magnitudes)
                        .map(|(&c, &m)| (c as f64, m as f64)),
                    BLUE,
                ))
                .map_err(|x| e(&x))?;
            for &(column, magnitude, amplitude) in &gv.peaks {
                let p = (column as f64, magnitude as f64);
                chart
                    .draw_series([Circle::new(p, 6, RED.stroke_width(2))])
                    .map_err(|x| e(&x))?;
                // Label beside the marker, on the side with room.
                let right_half = column as f64 > 0.75 * c_max;
                let (dx, anchor) = if right_half {
                    (-0.012 * c_max, HPos::Right)
                } else {
                    (0.012 * c_max, HPos::Left)
                };
                let style = (FONT, 14)
                    .into_font()
                    .color(&RED)
                    .pos(Pos::new(anchor, VPos::Center));
                chart
                    .draw_series([Text::new(
                        format!("{column:.2} ({amplitude:.0} DN)"),
                        (column as f64 + dx, (magnitude as f64).min(m_max * 0.95)),
                        style,
                    )])
                    .map_err(|x| e(&x))?;
            }
            // masks
            if efsm {
                let n = gv.masks.len().max(1);
                let top = gv
                    .masks
                    .iter()
                    .copied()
                    .chain(view.white)
                    .max()
                    .unwrap_or(1)
                    .max(1) as f64
                    * 1.05;
                let mut chart = ChartBuilder::on(&areas[base + 2])
                    .caption(format!("mask samples by block{suffix}"), (FONT, 18))
                    .margin(10)
                    .x_label_area_size(40)
                    .y_label_area_size(70)
                    .build_cartesian_2d(0.0..n as f64, 0.0..top)
                    .map_err(|x| e(&x))?;
                chart
                    .configure_mesh()
                    .x_desc("mask (block b)")
                    .y_desc("sample (DN)")
                    .label_style((FONT, 14))
                    .draw()
                    .map_err(|x| e(&x))?;
                chart
                    .draw_series(gv.masks.iter().enumerate().map(|(i, &s)| {
                        Rectangle::new(
                            [(i as f64 + 0.1, 0.0), (i as f64 + 0.9, s as f64)],
                            GREEN.mix(0.7).filled(),
                        )
                    }))
                    .map_err(|x| e(&x))?;
                if let Some(dark) = view.dark {
                    chart
                        .draw_series(LineSeries::new(
                            [(0.0, dark as f64), (n as f64, dark as f64)],
                            BLACK,
                        ))
                        .map_err(|x| e(&x))?;
                }
            }
        }
        Ok(())
    })
}

/// Draws the row map: pixel `x` across, column down, colour = the pixel's magnitude scaled to
/// its own maximum (so dim and bright pixels show alike; indirect light appears as a weaker
/// second line).
pub fn plot_row_map(plan: &ScanPlan, map: &RowMap, out: &Path) -> Result<()> {
    let (width, height) = (1200u32, 800u32);
    let c_max = map.bin_columns.last().copied().unwrap_or(1.0) as f64;
    // Bins are evenly spaced from column 0: one per column for a profile.
    let bin_width = match map.bin_columns.get(1) {
        Some(&c) => c as f64,
        None => plan.bin_width() as f64,
    };
    let suffix = if plan.group_count() > 1 {
        format!(", group {}", map.group.number())
    } else {
        String::new()
    };
    let peaks: Vec<f32> = (0..map.width)
        .map(|x| map.spectrum(x).iter().copied().fold(0.0f32, f32::max))
        .collect();
    render_png(out, (width, height), |root| {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "{} of camera row {}{suffix} (each pixel scaled to its maximum)",
                    if map.profile {
                        "light per column"
                    } else {
                        "c-domain"
                    },
                    map.y
                ),
                (FONT, 20),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..map.width as f64, c_max..0.0)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("camera pixel x")
            .y_desc(span_label(plan))
            .label_style((FONT, 14))
            .draw()
            .map_err(|x| e(&x))?;
        paint_row_map(root, chart.plotting_area(), |x, c| {
            let xi = (x.floor() as isize).clamp(0, map.width as isize - 1) as usize;
            let k = ((c / bin_width).round() as isize).clamp(0, map.bins() as isize - 1) as usize;
            match peaks[xi] {
                top if top > 0.0 => (map.spectrum(xi)[k] / top) as f64,
                _ => 0.0,
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::GroupCount;

    #[test]
    fn candidates_are_listed_one_a_line() {
        let mut candidates = HostCandidates::new();
        let fsm = MethodPlan::Fsm(ScanPlan::paper_efsm(GroupCount::Two));
        assert_eq!(
            candidate_lines(&fsm, 3, 4, &candidates),
            "pixel (3, 4): no candidate\n"
        );
        for (column, block) in [(300.25, 4), (512.0, 8)] {
            let c = fsm_core::Candidate {
                column,
                amplitude: 1200.0 / block as f32,
                groups: fsm_core::GroupSet(1),
                group: Group::Two,
                peak: 0,
                block,
            };
            candidates.candidates.push(c).unwrap();
        }
        assert_eq!(
            candidate_lines(&fsm, 3, 4, &candidates),
            "pixel (3, 4): column 300.250, amplitude 300.0 DN, group 2, block 4\n\
             pixel (3, 4): column 512.000, amplitude 150.0 DN, group 2, block 8\n"
        );
        let line_scan = crate::plan_file::MethodKind::LineScan.plan(768, 64, GroupCount::Two);
        let text = candidate_lines(&line_scan, 3, 4, &candidates);
        assert!(text.starts_with("pixel (3, 4): column 300.250, amplitude 300.0 DN\n"));
    }

    /// A row of `width` pixels, pixel `x` lit at column `column(x)` (1200 DN) over 100 DN.
    fn lit_row(plan: &ScanPlan, width: usize, column: impl Fn(usize) -> u32) -> Vec<u16> {
        let mut frames = vec![0u16; plan.sequence_len() * width];
        for x in 0..width {
            for (i, p) in plan.sequence().enumerate() {
                let v = 100.0 + 1200.0 * plan.intensity(p, column(x));
                frames[i * width + x] = v.round() as u16;
            }
        }
        frames
    }

    /// The pixel plot shows what the decoder reads: the column profile for the cosine search
    /// (one bin per column, its maximum on the lit column and the light marked there), the
    /// spectrum for a DFT search.
    #[test]
    fn the_c_domain_is_the_decoders_own() {
        for plan in [
            ScanPlan::paper_bfsm(),
            ScanPlan::paper_efsm(GroupCount::Two),
        ] {
            let frames = lit_row(&plan, 3, |x| 300 + 7 * x as u32);
            let view = pixel_view(&plan, &frames, 3, 12, 1, 0).unwrap();
            for gv in &view.groups {
                assert!(gv.profile);
                let span = plan.span_columns() as usize;
                assert_eq!(gv.bin_columns.len(), span + 1);
                assert_eq!(gv.magnitudes.len(), span + 1);
                let top = (0..=span)
                    .max_by(|&a, &b| gv.magnitudes[a].total_cmp(&gv.magnitudes[b]))
                    .unwrap();
                let (light, _, _) = gv.peaks[0];
                assert!((light - top as f32).abs() < 1.0, "{light} vs {top}");
                // BFSM: the column itself; EFSM: its local column in the group's blocks.
                let local = (307 + plan.group_shift(gv.group) as usize) % span;
                assert!(top.abs_diff(local) <= 1, "{top} vs {local}");
            }
            assert!((view.candidates.strongest().unwrap().column - 307.0).abs() < 0.1);
            let map = row_map(&plan, &frames, 3, 12, 0, Group::One).unwrap();
            assert!(map.profile);
            assert_eq!(map.magnitudes.len(), 3 * map.bins());
            assert_eq!(map.spectrum(1), view.groups[0].magnitudes.as_slice());
        }
        let plan = ScanPlan::paper_bfsm().with_clean();
        let frames = lit_row(&plan, 1, |_| 300);
        let view = pixel_view(&plan, &frames, 1, 12, 0, 0).unwrap();
        assert!(!view.groups[0].profile);
        assert_eq!(view.groups[0].bin_columns.len(), plan.bin_count());
    }
}
