//! Synthetic pixels for the core tests: a camera pixel that sees given projector columns.
#![allow(dead_code)]

use fsm_core::{Decoder, PixelCandidates, Row, ScanPlan, SensorNoise};

/// The sensor the synthetic pixels come from, as a plan states it: 1 DN of read noise at 12
/// bits and no shot noise (a full-scale charge so large that its shot noise vanishes).
pub const SYNTHETIC_SENSOR: SensorNoise = SensorNoise {
    full_scale_electrons: 4095.0e6,
    read_noise_electrons: 1.0e6,
};

/// `plan` told that its samples come from [`SYNTHETIC_SENSOR`].
pub fn synthetic(mut plan: ScanPlan) -> ScanPlan {
    plan.decoding.sensor = SYNTHETIC_SENSOR;
    plan
}

/// Deterministic normal deviates (splitmix64 + Box–Muller): tests need no extra crates.
pub struct Noise {
    state: u64,
    spare: Option<f64>,
}

impl Noise {
    pub fn new(seed: u64) -> Self {
        Noise {
            state: seed ^ 0x9e37_79b9_7f4a_7c15,
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let (u, v) = (self.uniform(), self.uniform());
        let r = (-2.0 * u.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * v).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}

/// What a pixel sees: weights of integer projector columns, in DN of full projector output.
#[derive(Clone, Debug)]
pub struct Pixel {
    /// `(column, DN at full output)`.
    pub lights: Vec<(u32, f64)>,
    /// Ambient light, DN.
    pub ambient: f64,
}

impl Pixel {
    /// Light from one column.
    pub fn column(column: u32, dn: f64) -> Self {
        Pixel {
            lights: vec![(column, dn)],
            ambient: 20.0,
        }
    }

    /// Light from a blurred spot at fractional `centre`: Gaussian weights of std `sigma` columns
    /// over the integer columns (what a defocused projector and a camera footprint give).
    pub fn spot(centre: f64, sigma: f64, dn: f64) -> Self {
        let mut lights = Vec::new();
        let lo = (centre - 5.0 * sigma - 1.0).floor().max(0.0) as u32;
        let hi = (centre + 5.0 * sigma + 1.0).ceil() as u32;
        let mut sum = 0.0;
        for j in lo..=hi {
            let d = (j as f64 - centre) / sigma;
            let w = (-0.5 * d * d).exp();
            sum += w;
            lights.push((j, w));
        }
        for l in lights.iter_mut() {
            l.1 *= dn / sum;
        }
        Pixel {
            lights,
            ambient: 20.0,
        }
    }

    /// Adds the lights of another pixel (e.g. a mirror's indirect light).
    pub fn plus(mut self, other: Pixel) -> Self {
        self.lights.extend(other.lights);
        self
    }

    /// Light-weighted column of the lights near `around` (within 6 columns).
    pub fn centroid_near(&self, around: f64) -> f64 {
        let (mut s, mut m) = (0.0, 0.0);
        for &(j, w) in &self.lights {
            if (j as f64 - around).abs() <= 6.0 {
                s += w;
                m += w * j as f64;
            }
        }
        m / s
    }

    /// Noise-free intensity of every frame of `plan`, DN.
    pub fn intensities(&self, plan: &ScanPlan) -> Vec<f64> {
        plan.sequence()
            .map(|p| {
                self.ambient
                    + self
                        .lights
                        .iter()
                        .map(|&(j, w)| w * plan.intensity(p, j) as f64)
                        .sum::<f64>()
            })
            .collect()
    }

    /// Quantised samples with Gaussian noise of std `sigma` DN, clipped to `bits`.
    pub fn samples(&self, plan: &ScanPlan, sigma: f64, bits: u8, noise: &mut Noise) -> Vec<u16> {
        let max = ((1u32 << bits) - 1) as f64;
        self.intensities(plan)
            .into_iter()
            .map(|v| (v + sigma * noise.normal()).round().clamp(0.0, max) as u16)
            .collect()
    }
}

/// Interleaves per-pixel samples into a sample-major row.
pub fn row_frames(pixels: &[Vec<u16>]) -> Vec<u16> {
    let w = pixels.len();
    let frames = pixels[0].len();
    let mut out = vec![0u16; frames * w];
    for (x, p) in pixels.iter().enumerate() {
        for (i, &s) in p.iter().enumerate() {
            out[i * w + x] = s;
        }
    }
    out
}

/// A decoder with its own tables (built once, kept for the test's lifetime) and scratch.
pub struct Harness {
    pub plan: ScanPlan,
    decoder: Decoder<'static>,
    scratch: Vec<f32>,
}

impl Harness {
    /// A decoder of `plan` told the noise of the synthetic pixels ([`synthetic`]).
    pub fn new(plan: ScanPlan) -> Self {
        let plan = synthetic(plan);
        let tables: &'static mut [f32] =
            Box::leak(vec![0.0; Decoder::tables_len(&plan)].into_boxed_slice());
        let decoder = Decoder::new(&plan, tables).expect("valid plan");
        let scratch = vec![0.0; Decoder::scratch_len(&plan)];
        Harness {
            plan,
            decoder,
            scratch,
        }
    }

    /// Decodes a row of pixels given as per-pixel sample vectors.
    pub fn decode<const K: usize>(
        &mut self,
        pixels: &[Vec<u16>],
        bits: u8,
    ) -> Vec<PixelCandidates<K>> {
        let frames = row_frames(pixels);
        let row = Row {
            frames: &frames,
            width: pixels.len(),
            bit_depth: bits,
            column_limits: None,
        };
        let mut out = vec![PixelCandidates::<K>::new(); pixels.len()];
        self.decoder
            .decode_row(&row, &mut self.scratch, &mut out)
            .expect("row decodes");
        out
    }

    /// Decodes one pixel.
    pub fn decode_one<const K: usize>(
        &mut self,
        samples: Vec<u16>,
        bits: u8,
    ) -> PixelCandidates<K> {
        self.decode::<K>(&[samples], bits).pop().unwrap()
    }

    /// Peaks of one group's spectrum of one pixel.
    pub fn peaks(
        &mut self,
        samples: &[u16],
        group: fsm_core::Group,
        bits: u8,
    ) -> fsm_core::PeakList {
        let row = Row {
            frames: samples,
            width: 1,
            bit_depth: bits,
            column_limits: None,
        };
        self.decoder
            .peaks(&row, 0, group, &mut self.scratch)
            .expect("row decodes")
    }
}

/// Decodes one row of `pixels` with `plan`: 12-bit samples, 1 DN read noise from `seed`.
pub fn decode_all<const K: usize>(
    plan: ScanPlan,
    pixels: &[Pixel],
    seed: u64,
) -> Vec<PixelCandidates<K>> {
    let mut h = Harness::new(plan);
    let mut noise = Noise::new(seed);
    let samples: Vec<Vec<u16>> = pixels
        .iter()
        .map(|p| p.samples(&plan, 1.0, 12, &mut noise))
        .collect();
    h.decode::<K>(&samples, 12)
}

/// Error of the candidate nearest to `truth`, or infinity without candidates.
pub fn nearest_error<const K: usize>(p: &PixelCandidates<K>, truth: f64) -> f64 {
    p.candidates
        .iter()
        .map(|c| (c.column as f64 - truth).abs())
        .fold(f64::INFINITY, f64::min)
}
