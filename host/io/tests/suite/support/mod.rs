//! Test support shared by the library tests (`host/io/tests`) and the CLI tests
//! (`host/cli/tests`, included by path): a flat white wall in front of the projector.
//!
//! Identity light transport: camera pixel `(x, y)` sees projector column `x` and nothing else.
//! The "captures" are made from the pattern images `fsm patterns` wrote (not from the plan), so
//! the round trip exercises the files end to end: projector code → light (linear projector) →
//! sensor DN = dark + gain·light + Gaussian noise, quantised to the sensor's bit depth and
//! stored right-aligned in 16-bit PNGs.
#![allow(dead_code)] // each test binary uses part of it

use std::path::{Path, PathBuf};

use fsm_io::image_files;
use fsm_io::patterns::{Manifest, MANIFEST_NAME};
use rand::{RngExt, SeedableRng};
use rand_distr::Normal;

/// A camera looking at a flat white wall.
#[derive(Clone, Copy, Debug)]
pub struct FlatWall {
    /// Sensor bit depth (10 or 12 in a 16-bit container).
    pub bits: u8,
    /// Dark level, DN.
    pub dark_dn: f64,
    /// DN for full projector light.
    pub white_dn: f64,
    /// Read noise RMS, DN.
    pub noise_dn: f64,
    /// Noise seed.
    pub seed: u64,
}

impl FlatWall {
    /// A 12-bit camera: dark 40 DN, white 3400 DN, 1.5 DN noise.
    pub fn twelve_bit() -> Self {
        FlatWall {
            bits: 12,
            dark_dn: 40.0,
            white_dn: 3400.0,
            noise_dn: 1.5,
            seed: 12,
        }
    }

    /// A 10-bit camera: dark 12 DN, white 900 DN, 0.8 DN noise.
    pub fn ten_bit() -> Self {
        FlatWall {
            bits: 10,
            dark_dn: 12.0,
            white_dn: 900.0,
            noise_dn: 0.8,
            seed: 10,
        }
    }

    /// Reads the pattern set in `patterns` and writes one capture per pattern into
    /// `captures` (created), named like the patterns. Returns the captures' size.
    pub fn capture(&self, patterns: &Path, captures: &Path) -> (u32, u32) {
        let manifest: Manifest =
            serde_json::from_str(&std::fs::read_to_string(patterns.join(MANIFEST_NAME)).unwrap())
                .unwrap();
        std::fs::create_dir_all(captures).unwrap();
        let full = if manifest.bit_depth == 16 {
            65535.0
        } else {
            255.0
        };
        let max = ((1u32 << self.bits) - 1) as f64;
        let mut rng = rand::rngs::StdRng::seed_from_u64(self.seed);
        let noise = Normal::new(0.0, self.noise_dn).unwrap();
        for frame in &manifest.frames {
            let (info, codes) = image_files::read_image(&patterns.join(&frame.file)).unwrap();
            let samples: Vec<u16> = codes
                .iter()
                .map(|&code| {
                    let light = code as f64 / full;
                    let dn =
                        self.dark_dn + (self.white_dn - self.dark_dn) * light + rng.sample(noise);
                    dn.round().clamp(0.0, max) as u16
                })
                .collect();
            let name = Path::new(&frame.file).with_extension("png");
            let file = std::fs::File::create(captures.join(name)).unwrap();
            image_files::write_png_gray16(
                std::io::BufWriter::new(file),
                info.width,
                info.height,
                &samples,
            )
            .unwrap();
        }
        (manifest.width, manifest.height)
    }
}

/// Every entry of `dir` (to show that nothing partial was left behind).
pub fn entries(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}
