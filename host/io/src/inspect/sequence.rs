//! What the baselines' decoders see (phase shift, Micro Phase Shifting, Code Ensemble, line
//! scanning), drawn as the FSM views are:
//!
//! - one pixel: its samples frame by frame, grouped as its method's decoder reads them — the
//!   phase-shift fringes by phase offset and the Gray-code bits against their threshold; the
//!   Micro Phase Shifting fringes by period; each Code Ensemble code's bits, pattern beside
//!   inverse; line scanning's temporal profile against the lit column — with the candidates
//!   the decoder found;
//! - one row: the candidates of every pixel against projector column, pixel `x` across; for
//!   line scanning over the samples themselves (frame `2 + j` lights column `j`), where direct
//!   and reflected light draw separate lines as in the FSM row map.
//!
//! The candidates are `fsm_core`'s (the same decoder as `fsm decode`); the frames' roles are
//! the pattern manifest's ([`describe_frame`]).

use std::path::Path;

use fsm_core::Row;
use plotters::prelude::*;

use super::{candidates_title, paint_row_map, render_png};
use crate::candidate_file::HostCandidates;
use crate::decode::RowDecoder;
use crate::error::{Error, Result};
use crate::map_picture::FONT;
use crate::patterns::{describe_frame, ManifestPattern};
use crate::plan_file::MethodPlan;

/// One curve of a panel: points `(x, sample DN)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend.
    pub name: String,
    /// The points, in frame order.
    pub points: Vec<(f64, f64)>,
}

/// One chart of the pixel plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// Caption.
    pub title: String,
    /// What the x axis is.
    pub x_desc: &'static str,
    /// The samples, one curve per kind of frame.
    pub series: Vec<Series>,
    /// Horizontal reference lines: (legend, DN).
    pub levels: Vec<(String, f64)>,
    /// Vertical marks where the x axis is the projector column: the candidates' columns.
    pub marks: Vec<f64>,
}

/// Everything the pixel plot of a baseline shows.
#[derive(Clone, Debug)]
pub struct SequenceView {
    /// Camera pixel.
    pub x: u32,
    /// Camera row.
    pub y: u32,
    /// The pixel's samples in sequence order, DN.
    pub samples: Vec<u16>,
    /// The charts.
    pub panels: Vec<Panel>,
    /// The decoder's candidates for the pixel.
    pub candidates: HostCandidates,
}

/// The candidates of every pixel of a temporal row (`frames[i·W + x]`) scanned with the
/// baseline `plan`: the same decoder as `fsm decode`. An FSM plan has its own views
/// ([`super::pixel_view`], [`super::row_map`]).
pub fn row_candidates(
    plan: &MethodPlan,
    frames: &[u16],
    width: usize,
    bit_depth: u8,
    y: u32,
) -> Result<Vec<HostCandidates>> {
    if let MethodPlan::Fsm(_) = plan {
        return Err(Error::Usage(
            "an FSM plan's views are its spectra and profiles (inspect::pixel_view)".into(),
        ));
    }
    let mut tables = Vec::new();
    let decoder = RowDecoder::new(plan, &mut tables)?;
    let row = Row {
        frames,
        width,
        bit_depth,
        column_limits: None,
    };
    let mut scratch = vec![0.0f32; decoder.scratch_len()];
    let mut pixels = vec![HostCandidates::new(); width];
    decoder
        .decode_row(&row, &mut scratch, &mut pixels)
        .map_err(|e| Error::Usage(format!("row {y}: {e}")))?;
    Ok(pixels)
}

/// What the decoder of `plan` (a baseline) sees at pixel `x` of a temporal row.
pub fn sequence_view(
    plan: &MethodPlan,
    frames: &[u16],
    width: usize,
    bit_depth: u8,
    x: u32,
    y: u32,
) -> Result<SequenceView> {
    let count = plan.frame_count();
    let samples: Vec<u16> = (0..count).map(|i| frames[i * width + x as usize]).collect();
    // The decoders are per pixel: the pixel alone decodes as it does in its row.
    let candidates = row_candidates(plan, &samples, 1, bit_depth, y)?.remove(0);
    let panels = panels(plan, &samples, &candidates);
    Ok(SequenceView {
        x,
        y,
        samples,
        panels,
        candidates,
    })
}

/// A panel without marks.
fn panel(title: String, x_desc: &'static str, series: Vec<Series>) -> Panel {
    Panel {
        title,
        x_desc,
        series,
        levels: Vec::new(),
        marks: Vec::new(),
    }
}

/// The charts of a baseline pixel: its samples grouped by what the frames show.
fn panels(plan: &MethodPlan, samples: &[u16], candidates: &HostCandidates) -> Vec<Panel> {
    let roles: Vec<ManifestPattern> = (0..samples.len())
        .map(|i| describe_frame(plan, i))
        .collect();
    let frames = || roles.iter().zip(samples.iter().map(|&s| s as f64));
    let reference =
        |kind: fn(&ManifestPattern) -> bool| frames().find(|(r, _)| kind(r)).map(|f| f.1);
    let dark = reference(|r| matches!(r, ManifestPattern::Dark));
    let white = reference(|r| matches!(r, ManifestPattern::White));
    let references: Vec<(String, f64)> = [("dark frame", dark), ("white frame", white)]
        .into_iter()
        .filter_map(|(name, level)| Some((format!("{name} ({:.0} DN)", level?), level?)))
        .collect();
    match plan {
        MethodPlan::Fsm(_) => Vec::new(),
        MethodPlan::PhaseShift(_) => {
            let fringes = frames()
                .filter_map(|(r, s)| match r {
                    // The step's offset, from 0 up (`+ 0.0`: no "-0" on the axis).
                    ManifestPattern::PhaseFringe { offset_turns, .. } => {
                        Some((-offset_turns + 0.0, s))
                    }
                    _ => None,
                })
                .collect();
            let bits = frames()
                .filter_map(|(r, s)| match r {
                    ManifestPattern::GrayBit { bit } => Some((*bit as f64, s)),
                    _ => None,
                })
                .collect();
            let mut fringe_panel = panel(
                "phase-shift fringes: the phase within a period".into(),
                "phase offset of the fringe (turns)",
                vec![Series {
                    name: "fringe".into(),
                    points: fringes,
                }],
            );
            fringe_panel.levels = references.clone();
            let mut gray_panel = panel(
                "Gray-code bits: the period (a bit is 1 above (dark + white) / 2)".into(),
                "bit (0 = most significant)",
                vec![Series {
                    name: "Gray-code frame".into(),
                    points: bits,
                }],
            );
            gray_panel.levels = references;
            if let (Some(d), Some(w)) = (dark, white) {
                gray_panel.levels.push((
                    format!("threshold ({:.0} DN)", 0.5 * (d + w)),
                    0.5 * (d + w),
                ));
            }
            vec![fringe_panel, gray_panel]
        }
        MethodPlan::MicroPhaseShift(_) => {
            // The first period is shown three times (its phase offsets), then each other once.
            let mut shifted = Vec::new();
            let mut single = Vec::new();
            for (i, (r, s)) in frames().enumerate() {
                if let ManifestPattern::PhaseFringe { .. } = r {
                    if i < 3 { &mut shifted } else { &mut single }.push((i as f64, s));
                }
            }
            vec![panel(
                "Micro Phase Shifting: three phase offsets of the first period, then one frame \
                 of each other period"
                    .into(),
                "frame",
                vec![
                    Series {
                        name: "first period, three offsets".into(),
                        points: shifted,
                    },
                    Series {
                        name: "one frame per other period".into(),
                        points: single,
                    },
                ],
            )]
        }
        MethodPlan::CodeEnsemble(_) => {
            // One panel per code, its frames in order: bit by bit, pattern then inverse.
            let mut codes: Vec<(String, Panel)> = Vec::new();
            for (r, s) in frames() {
                if let ManifestPattern::CodeBit { code, bit, inverse } = r {
                    if codes.last().is_none_or(|c| &c.0 != code) {
                        let series = ["pattern", "inverse"].map(|name| Series {
                            name: name.into(),
                            points: Vec::new(),
                        });
                        let title = format!(
                            "{code} code: a bit is 1 where the pattern is above its inverse"
                        );
                        codes.push((code.clone(), panel(title, "bit", series.into())));
                    }
                    let series = &mut codes.last_mut().expect("pushed above").1.series;
                    series[*inverse as usize].points.push((*bit as f64, s));
                }
            }
            codes.into_iter().map(|(_, p)| p).collect()
        }
        MethodPlan::LineScan(_) => {
            let profile = frames()
                .filter_map(|(r, s)| match r {
                    ManifestPattern::Line { column } => Some((*column as f64, s)),
                    _ => None,
                })
                .collect();
            let mut p = panel(
                "line scanning: the temporal profile, one frame per lit column, candidates marked"
                    .into(),
                "projector column lit by the frame",
                vec![Series {
                    name: "sample".into(),
                    points: profile,
                }],
            );
            p.levels = references;
            p.marks = candidates
                .candidates
                .iter()
                .map(|c| c.column as f64)
                .collect();
            vec![p]
        }
    }
}

/// Draws a baseline pixel's view.
pub fn plot_sequence(plan: &MethodPlan, view: &SequenceView, out: &Path) -> Result<()> {
    let rows = view.panels.len().max(1);
    let (width, height) = (1200u32, 60 + 330 * rows as u32);
    let title = candidates_title(
        &format!("{}, pixel ({}, {})", plan.name(), view.x, view.y),
        &view.candidates,
    );
    let top = view.samples.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.08;
    render_png(out, (width, height), |root| {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let (head, body) = root.split_vertically(50);
        head.draw(&Text::new(title.as_str(), (20, 15), (FONT, 22).into_font()))
            .map_err(|x| e(&x))?;
        let areas = body.split_evenly((rows, 1));
        for (area, p) in areas.iter().zip(&view.panels) {
            let xs = p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0));
            let (x_lo, x_hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
            let (x_lo, x_hi) = if x_lo <= x_hi {
                let pad = if x_hi > x_lo {
                    (x_hi - x_lo) * 0.05
                } else {
                    0.5
                };
                // Room on the right for the legend, beside the last points.
                (x_lo - pad, x_hi + 4.0 * pad)
            } else {
                (0.0, 1.0)
            };
            let mut chart = ChartBuilder::on(area)
                .caption(p.title.as_str(), (FONT, 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(x_lo..x_hi, 0.0..top)
                .map_err(|x| e(&x))?;
            chart
                .configure_mesh()
                .x_desc(p.x_desc)
                .y_desc("sample (DN)")
                .label_style((FONT, 14))
                .draw()
                .map_err(|x| e(&x))?;
            let palette = [BLUE, RED, GREEN, MAGENTA];
            for (k, s) in p.series.iter().enumerate() {
                let color = palette[k % palette.len()];
                chart
                    .draw_series(LineSeries::new(s.points.iter().copied(), color.mix(0.5)))
                    .map_err(|x| e(&x))?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
                if s.points.len() <= 256 {
                    chart
                        .draw_series(s.points.iter().map(|&q| Circle::new(q, 3, color.filled())))
                        .map_err(|x| e(&x))?;
                }
            }
            let level_colors = [BLACK, RED, CYAN];
            for (k, (name, level)) in p.levels.iter().enumerate() {
                let color = level_colors[k % level_colors.len()];
                chart
                    .draw_series(LineSeries::new(
                        [(x_lo, *level), (x_hi, *level)],
                        color.mix(0.4),
                    ))
                    .map_err(|x| e(&x))?
                    .label(name.as_str())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
            }
            for &c in &p.marks {
                chart
                    .draw_series(LineSeries::new([(c, 0.0), (c, top)], RED.stroke_width(2)))
                    .map_err(|x| e(&x))?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font((FONT, 14))
                .draw()
                .map_err(|x| e(&x))?;
        }
        Ok(())
    })
}

/// Draws a row's candidates (the strongest of each pixel red, the others orange) over, for
/// line scanning, each pixel's temporal profile scaled to its maximum.
pub fn plot_sequence_row(
    plan: &MethodPlan,
    y: u32,
    frames: &[u16],
    width: usize,
    pixels: &[HostCandidates],
    out: &Path,
) -> Result<()> {
    let columns = plan.patterns().projector_columns() as f64;
    // Line scanning: the frame that lights each column.
    let line_frames: Vec<(u32, usize)> = match plan {
        MethodPlan::LineScan(_) => (0..plan.frame_count())
            .filter_map(|i| match describe_frame(plan, i) {
                ManifestPattern::Line { column } => Some((column, i)),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    };
    let peaks: Vec<u16> = (0..width)
        .map(|x| {
            line_frames
                .iter()
                .map(|&(_, i)| frames[i * width + x])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let caption = if line_frames.is_empty() {
        format!(
            "{}: candidates of camera row {y} (strongest red)",
            plan.name()
        )
    } else {
        format!(
            "{}: camera row {y}, each pixel's samples scaled to its maximum, candidates \
             (strongest red)",
            plan.name()
        )
    };
    render_png(out, (1200, 800), |root| {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let mut chart = ChartBuilder::on(root)
            .caption(caption.as_str(), (FONT, 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..width.max(1) as f64, columns..0.0)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("camera pixel x")
            .y_desc("projector column c")
            .label_style((FONT, 14))
            .draw()
            .map_err(|x| e(&x))?;
        if !line_frames.is_empty() {
            paint_row_map(root, chart.plotting_area(), |x, c| {
                let xi = (x.floor() as isize).clamp(0, width as isize - 1) as usize;
                let k = (c.round() as isize).clamp(0, line_frames.len() as isize - 1) as usize;
                match peaks[xi] {
                    0 => 0.0,
                    top => frames[line_frames[k].1 * width + xi] as f64 / top as f64,
                }
            })?;
        }
        for (x, pixel) in pixels.iter().enumerate() {
            for (rank, c) in pixel.candidates.iter().enumerate() {
                let color = if rank == 0 {
                    RED
                } else {
                    RGBColor(255, 165, 0)
                };
                chart
                    .draw_series([Circle::new(
                        (x as f64 + 0.5, c.column as f64),
                        2,
                        color.filled(),
                    )])
                    .map_err(|x| e(&x))?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::{CodeEnsemblePlan, LineScanPlan, MicroPhaseShiftPlan, PhaseShiftPlan};

    /// A row of `width` pixels, pixel `x` lit at column `column(x)` (2000 DN) over 100 DN.
    fn lit_row(plan: &MethodPlan, width: usize, column: impl Fn(usize) -> u32) -> Vec<u16> {
        let patterns = plan.patterns();
        let frames = patterns.frame_count();
        let mut out = vec![0u16; frames * width];
        for x in 0..width {
            for i in 0..frames {
                let v = 100.0 + 2000.0 * patterns.frame_intensity(i, column(x));
                out[i * width + x] = v.round() as u16;
            }
        }
        out
    }

    /// Each baseline's pixel view holds every coding frame once, grouped as its decoder reads
    /// them, and the candidate its decoder finds (a lit column, within a column).
    #[test]
    fn every_baseline_shows_its_frames_and_its_candidate() {
        let plans = [
            MethodPlan::PhaseShift(PhaseShiftPlan::for_projector(256)),
            MethodPlan::MicroPhaseShift(MicroPhaseShiftPlan::spread(256, 16.0, 2.0, 5)),
            MethodPlan::CodeEnsemble(CodeEnsemblePlan::for_projector(256)),
            MethodPlan::LineScan(LineScanPlan {
                projector_columns: 256,
                ..LineScanPlan::paper()
            }),
        ];
        for plan in plans {
            let frames = lit_row(&plan, 3, |x| 100 + 9 * x as u32);
            let view = sequence_view(&plan, &frames, 3, 12, 1, 4).unwrap();
            let name = plan.name();
            let best = view.candidates.strongest().expect(name).column;
            assert!((best - 109.0).abs() <= 1.0, "{name}: {best}");
            let shown: usize = view
                .panels
                .iter()
                .flat_map(|p| &p.series)
                .map(|s| s.points.len())
                .sum();
            let references = (0..plan.frame_count())
                .filter(|&i| {
                    matches!(
                        describe_frame(&plan, i),
                        ManifestPattern::Dark | ManifestPattern::White
                    )
                })
                .count();
            assert_eq!(shown + references, plan.frame_count(), "{name}");
            // Every point is a sample of the pixel.
            for s in view.panels.iter().flat_map(|p| &p.series) {
                for &(_, v) in &s.points {
                    assert!(view.samples.contains(&(v as u16)), "{name}");
                }
            }
            if let MethodPlan::LineScan(_) = plan {
                let p = &view.panels[0];
                assert_eq!(p.marks, vec![best as f64]);
                // The profile peaks on the lit column.
                let top = p.series[0]
                    .points
                    .iter()
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap();
                assert_eq!(top.0, 109.0);
            }
        }
    }

    #[test]
    fn an_fsm_plan_is_not_drawn_as_a_sequence() {
        let plan = MethodPlan::Fsm(fsm_core::ScanPlan::bfsm(256));
        let frames = vec![0u16; plan.frame_count()];
        let e = sequence_view(&plan, &frames, 1, 12, 0, 0).unwrap_err();
        assert!(e.to_string().contains("FSM"), "{e}");
    }
}
