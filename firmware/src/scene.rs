//! A small scene with interreflections, rendered as a row dump (host only).
//!
//! A plane lit by a defocused projector spot, and a mirror beside it that relays a second,
//! sharper spot onto part of every row: those pixels see two projector columns, the direct one
//! and the mirrored one (the situation of paper Fig. 1). Pixels are rendered through the one
//! pattern function `ScanPlan::intensity`, with ambient light, deterministic noise and a
//! shadow at the end of the row. Any method's plan renders through its frames
//! (`PatternSequence::frame_intensity`), so the baselines' rows come from the same scene.
//!
//! It stands in for the simulator's `plane_mirror` dump in the cross-check: anything that
//! writes a row dump of the same plan can replace it (see `scripts/crosscheck-arm.sh`).

use fsm_core::wire::row_dump;
use fsm_core::MethodPlan;

/// The scene's parameters. Columns are projector columns (SPEC §1), light in sensor DN.
#[derive(Clone, Debug, PartialEq)]
pub struct MirrorScene {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Sensor bit depth.
    pub bit_depth: u8,
    /// Column seen directly at pixel (0, 0).
    pub direct_first: f64,
    /// Change of the direct column per pixel along the row.
    pub direct_per_pixel: f64,
    /// Change of the direct column per row.
    pub direct_per_row: f64,
    /// Defocus of the direct spot: Gaussian sigma, columns.
    pub direct_blur: f64,
    /// Modulation of the direct light, DN.
    pub direct_dn: f64,
    /// Pixels `[first, last)` of every row that the mirror also lights.
    pub mirror_pixels: (u32, u32),
    /// Column the mirror relays to the first mirror pixel.
    pub mirror_first: f64,
    /// Change of the mirrored column per pixel (a mirror reverses the direction).
    pub mirror_per_pixel: f64,
    /// Blur of the mirrored spot, columns.
    pub mirror_blur: f64,
    /// Modulation of the mirrored light, DN.
    pub mirror_dn: f64,
    /// Unmodulated light on every pixel, DN.
    pub ambient_dn: f64,
    /// Noise: uniform in `±noise_dn`, DN.
    pub noise_dn: f64,
    /// Pixels at the end of each row in shadow (ambient light only).
    pub shadow_pixels: u32,
    /// Seed of the noise.
    pub seed: u64,
}

impl MirrorScene {
    /// A scene of `width × height` pixels spanning most of `plan`'s projector columns.
    pub fn for_plan(plan: impl Into<MethodPlan>, width: u32, height: u32) -> Self {
        let cmax = plan.into().projector_columns() as f64;
        let lit = width.saturating_sub(width / 8).max(1);
        MirrorScene {
            width,
            height,
            bit_depth: 12,
            direct_first: 0.08 * cmax,
            direct_per_pixel: 0.8 * cmax / lit as f64,
            direct_per_row: 0.37,
            direct_blur: 0.7,
            direct_dn: 1500.0,
            mirror_pixels: (width / 4, width / 4 + width / 3),
            mirror_first: 0.95 * cmax,
            mirror_per_pixel: -0.3 * cmax / lit as f64,
            mirror_blur: 0.45,
            mirror_dn: 650.0,
            ambient_dn: 40.0,
            noise_dn: 2.0,
            shadow_pixels: width / 8,
            seed: 0x5EED_F5A1,
        }
    }

    /// The columns lighting pixel `(x, y)`: direct, and mirrored if any (`None` in shadow).
    pub fn truth(&self, x: u32, y: u32) -> Option<(f64, Option<f64>)> {
        if x >= self.width - self.shadow_pixels.min(self.width) {
            return None;
        }
        let direct =
            self.direct_first + self.direct_per_pixel * x as f64 + self.direct_per_row * y as f64;
        let (first, last) = self.mirror_pixels;
        let mirror = (first..last)
            .contains(&x)
            .then(|| self.mirror_first + self.mirror_per_pixel * (x - first) as f64);
        Some((direct, mirror))
    }

    /// The samples of row `y`, sample-major (`frames[i·W + x]`, frame `i` in plan order).
    pub fn row_samples(&self, plan: impl Into<MethodPlan>, y: u32) -> Vec<u16> {
        let plan: MethodPlan = plan.into();
        let frames_of = plan.patterns();
        let w = self.width as usize;
        let frames = plan.frame_count();
        let max = ((1u32 << self.bit_depth) - 1) as f64;
        let mut out = vec![0u16; frames * w];
        let mut spots: Vec<(i64, f64)> = Vec::new();
        for x in 0..self.width {
            spots.clear();
            if let Some((direct, mirror)) = self.truth(x, y) {
                spread(direct, self.direct_blur, self.direct_dn, &mut spots);
                if let Some(m) = mirror {
                    spread(m, self.mirror_blur, self.mirror_dn, &mut spots);
                }
            }
            for i in 0..frames {
                let light: f64 = spots
                    .iter()
                    .filter(|(j, _)| *j >= 0)
                    .map(|&(j, w)| w * frames_of.frame_intensity(i, j as u32) as f64)
                    .sum();
                let noise = self.noise_dn * noise(self.seed, y, x, i as u32);
                let v = (self.ambient_dn + light + noise).round().clamp(0.0, max);
                out[i * w + x as usize] = v as u16;
            }
        }
        out
    }

    /// The row dump of the scene under `plan`: header and one record per row, in row order.
    pub fn dump(&self, plan: impl Into<MethodPlan>) -> Vec<u8> {
        let plan: MethodPlan = plan.into();
        let header = plan.row_dump_header(self.width, self.height, self.bit_depth);
        let record_len = header.record_len().expect("scene rows fit in memory");
        let mut out = Vec::with_capacity(64 + record_len * self.height as usize);
        out.extend_from_slice(&header.encode());
        let mut record = vec![0u8; record_len];
        for y in 0..self.height {
            let samples = self.row_samples(plan, y);
            let n = row_dump::encode_record(&header, y, &samples, &mut record)
                .expect("record of the header's geometry");
            out.extend_from_slice(&record[..n]);
        }
        out
    }
}

/// A candidate file against the scene's truth ([`MirrorScene::check`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TruthCheck {
    /// Records in the file.
    pub rows: usize,
    /// Candidates in all.
    pub candidates: usize,
    /// Pixels the projector lights directly (not flagged), and those with a candidate at
    /// their column.
    pub lit: usize,
    /// See `lit`.
    pub direct_found: usize,
    /// Pixels the mirror lights as well, and those with a candidate at the mirrored column.
    pub mirrored: usize,
    /// See `mirrored`.
    pub mirror_found: usize,
    /// Lit pixels the mirror does not light (not flagged), and those with a candidate at their
    /// column: what a method that sees one light per pixel must get right.
    pub single_lit: usize,
    /// See `single_lit`.
    pub single_found: usize,
    /// Pixels in shadow, and those without a candidate.
    pub shadow: usize,
    /// See `shadow`.
    pub shadow_dark: usize,
    /// Candidates farther than the tolerance from every light of their pixel.
    pub stray: usize,
    /// Lit pixels the decoder flagged as mixtures ([`fsm_core::PixelFlags::is_mixed`]): a
    /// scan gives them no point, so their candidates are not held to the truth.
    pub flagged: usize,
}

impl TruthCheck {
    /// Every row present; the direct light found in at least 99% of the lit pixels that are
    /// not flagged, the mirrored light in 95% of theirs; at most 10% of the lit pixels
    /// flagged; no candidate in shadow. Stray candidates are counted, not held against the
    /// file: EFSM lists a light once per block its groups cannot rule out, by design.
    ///
    /// Measured with `fsm-firmware truth` on 48 × 32 pixels: BFSM all lights found, nothing
    /// flagged or stray; EFSM with two groups 1288/1288 direct, 455/456 mirrored, 56 of 1344
    /// flagged.
    pub fn passes(&self, rows: u32) -> bool {
        let lit = self.lit + self.flagged;
        self.rows == rows as usize
            && self.lit > 0
            && 100 * self.direct_found >= 99 * self.lit
            && 100 * self.mirror_found >= 95 * self.mirrored
            && 10 * self.flagged <= lit
            && self.shadow_dark == self.shadow
    }
}

impl TruthCheck {
    /// The test of a method that decodes one light per pixel (the baselines: phase shift,
    /// Micro Phase Shifting, Code Ensemble, line scanning), which the mirror's second light
    /// misleads by design (paper eq. 3): every row present; the light found in at least 95%
    /// of the pixels lit by one light; at least 95% of the shadow without a candidate (a fixed
    /// modulation threshold lets the odd noisy pixel through: phase shift, measured on the
    /// mirror scene at 48 × 16, 95 of 96).
    pub fn passes_single_light(&self, rows: u32) -> bool {
        self.rows == rows as usize
            && self.single_lit > 0
            && 100 * self.single_found >= 95 * self.single_lit
            && 100 * self.shadow_dark >= 95 * self.shadow
    }
}

impl core::fmt::Display for TruthCheck {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{} rows, {} candidates; direct light found in {}/{} lit pixels ({} more flagged as \
             mixtures; {}/{} of those lit once), mirrored light in {}/{}, {}/{} shadow pixels \
             without a candidate, {} stray candidates",
            self.rows,
            self.candidates,
            self.direct_found,
            self.lit,
            self.flagged,
            self.single_found,
            self.single_lit,
            self.mirror_found,
            self.mirrored,
            self.shadow_dark,
            self.shadow,
            self.stray
        )
    }
}

impl MirrorScene {
    /// Compares a candidate file of this scene with its truth: a light counts as found when a
    /// candidate of its pixel lies within `tolerance_columns` of its column.
    pub fn check(&self, candidates: &[u8], tolerance_columns: f64) -> Result<TruthCheck, String> {
        let (header, records) = crate::reference::records(candidates).map_err(|e| e.to_string())?;
        if (header.width, header.height) != (self.width, self.height) {
            return Err(format!(
                "the candidates are {}x{} pixels, the scene {}x{}",
                header.width, header.height, self.width, self.height
            ));
        }
        let mut check = TruthCheck {
            rows: records.len(),
            ..TruthCheck::default()
        };
        for (y, pixels) in &records {
            for (x, p) in pixels.iter().enumerate() {
                check.candidates += p.candidates.len();
                let found = |c: f64| {
                    p.candidates
                        .iter()
                        .any(|k| (k.column as f64 - c).abs() <= tolerance_columns)
                };
                let lights: &[f64] = &match self.truth(x as u32, *y) {
                    None => {
                        check.shadow += 1;
                        check.shadow_dark += p.candidates.is_empty() as usize;
                        [f64::NAN; 2]
                    }
                    Some(_) if p.flags.is_mixed() => {
                        check.flagged += 1;
                        continue;
                    }
                    Some((direct, mirror)) => {
                        check.lit += 1;
                        check.direct_found += found(direct) as usize;
                        if let Some(m) = mirror {
                            check.mirrored += 1;
                            check.mirror_found += found(m) as usize;
                        } else {
                            check.single_lit += 1;
                            check.single_found += found(direct) as usize;
                        }
                        [direct, mirror.unwrap_or(f64::NAN)]
                    }
                };
                check.stray += p
                    .candidates
                    .iter()
                    .filter(|k| {
                        lights
                            .iter()
                            .all(|c| c.is_nan() || (k.column as f64 - c).abs() > tolerance_columns)
                    })
                    .count();
            }
        }
        Ok(check)
    }
}

/// Adds the integer columns around `centre` with Gaussian weights summing to `dn`.
fn spread(centre: f64, sigma: f64, dn: f64, out: &mut Vec<(i64, f64)>) {
    let start = out.len();
    let c = centre.round() as i64;
    let mut total = 0.0;
    for j in c - 4..=c + 4 {
        let d = (j as f64 - centre) / sigma;
        let w = (-0.5 * d * d).exp();
        total += w;
        out.push((j, w));
    }
    for (_, w) in &mut out[start..] {
        *w *= dn / total;
    }
}

/// Uniform in `[-1, 1]`, a fixed function of its arguments (SplitMix64).
fn noise(seed: u64, y: u32, x: u32, frame: u32) -> f64 {
    let mut z = seed
        ^ (y as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (x as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (frame as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::wire::row_dump::RowDumpHeader;
    use fsm_core::ScanPlan;
    use fsm_core::{Decoder, GroupCount, PixelCandidates, Row};

    /// The scene is what it claims: every lit pixel decodes to its direct column, and the
    /// mirror pixels to their mirrored column as well.
    #[test]
    fn decodes_to_its_truth() {
        for plan in [
            ScanPlan::paper_bfsm(),
            ScanPlan::paper_efsm(GroupCount::Two),
        ] {
            let scene = MirrorScene::for_plan(plan, 32, 2);
            let mut tables = vec![0.0; Decoder::tables_len(&plan)];
            let decoder = Decoder::new(&plan, &mut tables).unwrap();
            let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
            let y = 1;
            let samples = scene.row_samples(plan, y);
            let row = Row {
                frames: &samples,
                width: 32,
                bit_depth: 12,
                column_limits: None,
            };
            let mut out = vec![PixelCandidates::<16>::new(); 32];
            decoder.decode_row(&row, &mut scratch, &mut out).unwrap();
            let (mut lit, mut mirrored) = (0, 0);
            for (x, p) in out.iter().enumerate() {
                let near = |c: f64| {
                    p.candidates
                        .iter()
                        .any(|k| (k.column as f64 - c).abs() < 0.5)
                };
                match scene.truth(x as u32, y) {
                    None => assert!(p.candidates.is_empty(), "shadow pixel {x}: {p:?}"),
                    Some((direct, mirror)) => {
                        assert!(near(direct), "pixel {x}: direct {direct} not in {p:?}");
                        lit += 1;
                        if let Some(m) = mirror {
                            assert!(near(m), "pixel {x}: mirror {m} not in {p:?}");
                            mirrored += 1;
                        }
                    }
                }
            }
            assert_eq!((lit, mirrored), (28, 10));
        }
    }

    /// The truth check passes the host's decode and fails a decode half a column off, a
    /// file without rows, and one with a row missing.
    #[test]
    fn the_truth_check_fails_a_decode_that_is_off() {
        use fsm_core::wire::candidates::{encode_record, record_len};
        let plan = ScanPlan::paper_bfsm();
        let (w, h) = (24, 4);
        let scene = MirrorScene::for_plan(plan, w, h);
        let good = crate::reference::decode_dump(plan, &scene.dump(plan)).unwrap();
        assert!(scene.check(&good, 0.5).unwrap().passes(h));
        let (header, records) = crate::reference::records(&good).unwrap();
        let write = |shift: f32, rows: usize| {
            let mut out = header.encode().to_vec();
            for (row, pixels) in records.iter().take(rows) {
                let mut pixels = pixels.clone();
                for p in &mut pixels {
                    for c in &mut p.candidates {
                        c.column += shift;
                    }
                }
                let mut record = vec![0; record_len(&pixels)];
                encode_record(&header, *row, &pixels, &mut record).unwrap();
                out.extend_from_slice(&record);
            }
            out
        };
        assert!(scene.check(&write(0.0, 4), 0.5).unwrap().passes(h));
        let off = scene.check(&write(0.6, 4), 0.5).unwrap();
        assert!(!off.passes(h) && off.direct_found == 0, "{off}");
        assert!(!scene.check(&write(0.0, 0), 0.5).unwrap().passes(h));
        assert!(!scene.check(&write(0.0, 3), 0.5).unwrap().passes(h));
    }

    #[test]
    fn dump_reads_back() {
        let plan = ScanPlan::paper_efsm(GroupCount::One);
        let scene = MirrorScene::for_plan(plan, 8, 3);
        let dump = scene.dump(plan);
        let header = RowDumpHeader::decode(&dump).unwrap();
        header.check_plan(&plan).unwrap();
        let len = header.record_len().unwrap();
        assert_eq!(dump.len(), 64 + 3 * len);
        for (y, record) in dump[64..].chunks_exact(len).enumerate() {
            let r = row_dump::decode_record(&header, record).unwrap();
            assert_eq!(r.row, y as u32);
            let mut samples = vec![0; r.len()];
            r.copy_to(&mut samples).unwrap();
            assert_eq!(samples, scene.row_samples(plan, y as u32));
        }
    }

    /// A baseline sees one light per pixel: held to the pixels the mirror does not light, it
    /// passes; held to FSM's test (the mirrored light too), it does not.
    #[test]
    fn a_baseline_is_held_to_the_pixels_lit_once() {
        let plan = fsm_core::CodeEnsemblePlan::for_projector(128);
        let scene = MirrorScene::for_plan(plan, 24, 4);
        let host = crate::reference::decode_dump(plan, &scene.dump(plan)).unwrap();
        let check = scene.check(&host, 1.0).unwrap();
        assert!(check.single_lit > 0 && check.mirrored > 0, "{check}");
        assert!(check.passes_single_light(4), "{check}");
        assert!(!check.passes(4), "{check}");
        assert!(!check.passes_single_light(5), "{check}");
    }
}
