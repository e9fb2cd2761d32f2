//! A simulated capture: every frame of a pattern sequence rendered through a scene's light
//! transport and the sensor, row by row, on demand.
//!
//! Rows are rendered when asked for, so a capture of any size costs the memory of its light
//! transport only. Each row's noise comes from its own generator seeded by `(seed, row)`, so a
//! row is the same whether rendered alone, in any order, or as part of a whole dump.
//!
//! What the projector emits for a pattern value is [`System::emitted`] of it. To render a
//! projector driven with other codes than the pattern values (a gamma pre-correction), wrap the
//! sequence in [`DrivenCodes`]; [`UniformLevels`] is the grey-level sequence of a projector
//! response measurement.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use fsm_core::wire::row_dump::{self, RecordedWith, RowDumpHeader};
use fsm_io::outputs::StagedFile;
use fsm_io::progress::Progress;
use rand::{RngExt, SeedableRng};
use rand_distr::{Poisson, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

use crate::sensor::Sensor;
use crate::system::System;
use crate::transport::LightTransport;
use crate::truth::GroundTruth;
use crate::SimError;
use fsm_core::PatternSequence;

/// Below this mean the shot noise is drawn from the Poisson law itself.
const POISSON_EXACT_BELOW_ELECTRONS: f64 = 50.0;
/// Rows rendered in parallel between two writes of a dump.
const DUMP_CHUNK_ROWS: u32 = 16;

/// The frames of one pattern sequence seen through one scene.
#[derive(Clone, Debug)]
pub struct Capture {
    transport: Arc<LightTransport>,
    /// Emitted value of column `j` in frame `i` at `i·cmax + j` (gamma and black level applied).
    emitted: Vec<f32>,
    frames: usize,
    sensor: Sensor,
    seed: u64,
    /// The patterns' fingerprint, which its row dump carries.
    pattern_fingerprint: u64,
}

impl Capture {
    /// Prepares the capture of `patterns` by `system` (whose transport is `transport`) with
    /// `sensor`; noise seeded by `seed`.
    pub fn new(
        transport: Arc<LightTransport>,
        patterns: &(impl PatternSequence + ?Sized),
        system: &System,
        sensor: Sensor,
        seed: u64,
    ) -> Result<Capture, SimError> {
        sensor.validate().map_err(SimError::Sensor)?;
        system.validate().map_err(SimError::System)?;
        let columns = transport.columns();
        if patterns.projector_columns() as u32 != columns {
            return Err(SimError::ProjectorColumns {
                plan: patterns.projector_columns() as u32,
                system: columns,
            });
        }
        let frames = patterns.frame_count();
        if frames == 0 {
            return Err(SimError::Settings(
                "the pattern sequence has no frame".into(),
            ));
        }
        let mut emitted = Vec::with_capacity(frames * columns as usize);
        for i in 0..frames {
            for j in 0..columns {
                emitted.push(system.emitted(patterns.frame_intensity(i, j)));
            }
        }
        Ok(Capture {
            transport,
            emitted,
            frames,
            sensor,
            seed,
            pattern_fingerprint: patterns.pattern_fingerprint(),
        })
    }

    /// Camera image width `W`.
    pub fn width(&self) -> u32 {
        self.transport.width()
    }

    /// Camera image height.
    pub fn height(&self) -> u32 {
        self.transport.height()
    }

    /// Frames per row `M`.
    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// Sensor bit depth.
    pub fn bit_depth(&self) -> u8 {
        self.sensor.bit_depth
    }

    /// The sensor.
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// Rows that can be rendered.
    pub fn rows(&self) -> std::ops::Range<u32> {
        self.transport.rows()
    }

    /// Ground truth of the renderable rows.
    pub fn ground_truth(&self) -> &GroundTruth {
        self.transport.ground_truth()
    }

    /// The light transport.
    pub fn transport(&self) -> &LightTransport {
        &self.transport
    }

    fn check_row(&self, y: u32) -> Result<(), SimError> {
        if self.rows().contains(&y) {
            Ok(())
        } else {
            Err(SimError::Rows {
                rows: y..y + 1,
                height: self.height(),
            })
        }
    }

    fn check_len(&self, len: usize) -> Result<(), SimError> {
        let expected = self.frames * self.width() as usize;
        if len == expected {
            Ok(())
        } else {
            Err(SimError::BufferLength {
                expected,
                actual: len,
            })
        }
    }

    /// Noise-free signal of row `y`, reference whites, sample-major (`out[i·W + x]`).
    pub fn signal_row(&self, y: u32, out: &mut [f32]) -> Result<(), SimError> {
        self.check_row(y)?;
        self.check_len(out.len())?;
        let columns = self.transport.columns() as usize;
        let w = self.width() as usize;
        for (i, frame) in out.chunks_exact_mut(w).enumerate() {
            let emitted = &self.emitted[i * columns..(i + 1) * columns];
            self.transport.shade_row(y, emitted, frame);
        }
        Ok(())
    }

    /// Row `y` as the camera delivers it: `out[i·W + x]` is frame `i` at pixel `x`, sensor
    /// codes (what [`fsm_core::Decoder::decode_row`] takes).
    pub fn render_row(&self, y: u32, out: &mut [u16]) -> Result<(), SimError> {
        self.check_row(y)?;
        self.check_len(out.len())?;
        let columns = self.transport.columns() as usize;
        let w = self.width() as usize;
        let s = &self.sensor;
        let mut rng = Pcg64Mcg::seed_from_u64(row_seed(self.seed, y));
        let mut signal = vec![0.0f32; w];
        let read_dn = s.read_noise_electrons * s.gain_dn_per_electron;
        let max = s.max_code() as f64;
        for (i, frame) in out.chunks_exact_mut(w).enumerate() {
            let emitted = &self.emitted[i * columns..(i + 1) * columns];
            self.transport.shade_row(y, emitted, &mut signal);
            for (o, &sig) in frame.iter_mut().zip(&signal) {
                let mean = sig.max(0.0) as f64 * s.white_electrons;
                let mut electrons = if !s.shot_noise || mean <= 0.0 {
                    mean
                } else if mean < POISSON_EXACT_BELOW_ELECTRONS {
                    Poisson::new(mean).map_or(mean, |p| rng.sample(p))
                } else {
                    let n: f64 = rng.sample(StandardNormal);
                    mean + mean.sqrt() * n
                };
                if electrons >= s.full_well_electrons {
                    // A full pixel reads the top code (the full well maps to it).
                    *o = s.max_code();
                    continue;
                }
                electrons = electrons.max(0.0);
                let mut dn = s.black_level_dn + s.gain_dn_per_electron * electrons;
                if read_dn > 0.0 {
                    let n: f64 = rng.sample(StandardNormal);
                    dn += read_dn * n;
                }
                *o = dn.round().clamp(0.0, max) as u16;
            }
        }
        Ok(())
    }

    /// Row `y` in a new buffer.
    pub fn row(&self, y: u32) -> Result<Vec<u16>, SimError> {
        let mut out = vec![0u16; self.frames * self.width() as usize];
        self.render_row(y, &mut out)?;
        Ok(out)
    }

    /// The header of this capture's row dump.
    pub fn dump_header(&self) -> RowDumpHeader {
        RowDumpHeader {
            bit_depth: self.sensor.bit_depth,
            recorded_with: RecordedWith::Patterns(self.pattern_fingerprint),
            width: self.width(),
            height: self.height(),
            frames: self.frames as u32,
        }
    }

    /// Streams the whole capture as a row dump (SPEC §6, `fsm_core::wire::row_dump`): the
    /// header, then every row in order, each reported to `progress` (stage "rendering rows").
    /// Needs a transport of every row.
    pub fn write_row_dump(&self, mut out: impl Write, progress: &Progress) -> Result<(), SimError> {
        if self.rows() != (0..self.height()) {
            return Err(SimError::PartialCapture {
                rows: self.rows(),
                height: self.height(),
            });
        }
        let header = self.dump_header();
        let record_len = header
            .record_len()
            .ok_or(SimError::Settings("row record too large".into()))?;
        out.write_all(&header.encode()).map_err(SimError::Io)?;
        progress.start(self.height() as u64, "rendering rows");
        let mut start = 0;
        while start < self.height() {
            let end = (start + DUMP_CHUNK_ROWS).min(self.height());
            let records: Vec<Result<Vec<u8>, SimError>> = (start..end)
                .into_par_iter()
                .map(|y| {
                    let samples = self.row(y)?;
                    let mut record = vec![0u8; record_len];
                    row_dump::encode_record(&header, y, &samples, &mut record)
                        .map_err(SimError::Wire)?;
                    Ok(record)
                })
                .collect();
            for r in records {
                out.write_all(&r?).map_err(SimError::Io)?;
            }
            progress.advance((end - start) as u64);
            start = end;
        }
        progress.finish();
        Ok(())
    }

    /// Writes the row dump to `path` whole or not at all (the workspace's one atomic writer,
    /// [`fsm_io::outputs::StagedFile`]).
    pub fn write_row_dump_file(&self, path: &Path, progress: &Progress) -> Result<(), SimError> {
        let io = |e: fsm_io::Error| SimError::Io(e.into_io_error());
        let result = (|| {
            let mut file = StagedFile::create(path).map_err(io)?;
            self.write_row_dump(file.writer(), progress)?;
            file.commit().map_err(io)
        })();
        result.map_err(|e| SimError::File {
            path: path.display().to_string(),
            source: Box::new(e),
        })
    }
}

/// SplitMix64 of the seed and the row: independent, reproducible streams per row.
fn row_seed(seed: u64, row: u32) -> u64 {
    let mut z = seed ^ (row as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A pattern sequence as the projector is driven with it: every value of `patterns` first goes
/// through `code` (e.g. a gamma pre-correction rounded to the projector's 8-bit codes), and the
/// result is what the projector is given, so [`System::emitted`] (gamma, black level) applies
/// to the code: emitted light = response(code(value)). Same frames and fingerprint as
/// `patterns`, so its captures decode with the plan. `code` should map `[0, 1]` into `[0, 1]`.
///
/// ```
/// use fsm_core::ScanPlan;
/// use fsm_sim::capture::DrivenCodes;
/// use fsm_sim::PatternSequence;
///
/// let plan = ScanPlan::paper_bfsm();
/// // Pre-corrected for a projector gamma of 2.2, as 8-bit codes.
/// let driven = DrivenCodes::new(&plan, |v: f32| (v.powf(1.0 / 2.2) * 255.0).round() / 255.0);
/// assert_eq!(driven.frame_count(), plan.frame_count());
/// assert_eq!(driven.fingerprint(), plan.fingerprint());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct DrivenCodes<'a, P, F> {
    patterns: &'a P,
    code: F,
}

impl<'a, P: PatternSequence, F: Fn(f32) -> f32> DrivenCodes<'a, P, F> {
    /// `patterns` with every value passed through `code`.
    pub fn new(patterns: &'a P, code: F) -> Self {
        DrivenCodes { patterns, code }
    }
}

impl<P: PatternSequence, F: Fn(f32) -> f32> PatternSequence for DrivenCodes<'_, P, F> {
    fn projector_columns(&self) -> u16 {
        self.patterns.projector_columns()
    }

    fn frame_count(&self) -> usize {
        self.patterns.frame_count()
    }

    fn pattern_count(&self) -> usize {
        self.patterns.pattern_count()
    }

    fn frame_intensity(&self, frame: usize, column: u32) -> f32 {
        (self.code)(self.patterns.frame_intensity(frame, column))
    }

    fn fingerprint(&self) -> u64 {
        self.patterns.fingerprint()
    }

    fn pattern_fingerprint(&self) -> u64 {
        self.patterns.pattern_fingerprint()
    }
}

/// Uniform grey frames, the projector-response measurement: frame `i` shows `levels[i]` (a
/// code, fraction of full scale) on every column of a `columns`-column projector.
#[derive(Clone, Debug, PartialEq)]
pub struct UniformLevels {
    columns: u16,
    levels: Vec<f32>,
}

impl UniformLevels {
    /// The frames of `levels` on `columns` columns.
    pub fn new(columns: u16, levels: Vec<f32>) -> Self {
        UniformLevels { columns, levels }
    }

    /// The codes shown, in frame order.
    pub fn levels(&self) -> &[f32] {
        &self.levels
    }
}

impl PatternSequence for UniformLevels {
    fn projector_columns(&self) -> u16 {
        self.columns
    }

    fn frame_count(&self) -> usize {
        self.levels.len()
    }

    fn frame_intensity(&self, frame: usize, _column: u32) -> f32 {
        self.levels.get(frame).copied().unwrap_or(0.0)
    }

    /// CRC-64 of a tag, the column count and the levels' bits.
    fn fingerprint(&self) -> u64 {
        let mut bytes = b"fsm-grey-levels".to_vec();
        bytes.extend(self.columns.to_le_bytes());
        for l in &self.levels {
            bytes.extend(l.to_bits().to_le_bytes());
        }
        fsm_core::wire::crc64(&bytes)
    }

    /// The levels are the frames: the same as [`UniformLevels::fingerprint`].
    fn pattern_fingerprint(&self) -> u64 {
        self.fingerprint()
    }
}
