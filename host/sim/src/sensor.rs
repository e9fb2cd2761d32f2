//! The camera's sensor: exposure, shot and read noise, gain, black level, quantisation and
//! saturation.
//!
//! A pixel receiving `s` reference whites collects on average `s · white_electrons`
//! photo-electrons; their count is Poisson (shot noise; the normal approximation above 50
//! electrons). A pixel that reaches the full well reads the top code — the saturation the
//! decoder flags. Otherwise the ADC adds Gaussian read noise, converts with
//! `gain_dn_per_electron` over a `black_level_dn` offset, rounds and clamps to the bit depth.

/// Sensor parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// ADC bits, 8–16 (10 or 12 for machine-vision cameras).
    pub bit_depth: u8,
    /// Electrons a pixel holds before clipping.
    pub full_well_electrons: f64,
    /// DN per electron.
    pub gain_dn_per_electron: f64,
    /// Read noise std, electrons.
    pub read_noise_electrons: f64,
    /// Offset of a dark pixel, DN (keeps the read noise of dark pixels unclipped).
    pub black_level_dn: f64,
    /// Electrons of a reference white (exposure × projector power).
    pub white_electrons: f64,
    /// Photon shot noise on/off (off with `read_noise_electrons = 0` gives noise-free frames,
    /// still quantised).
    pub shot_noise: bool,
}

impl Default for Sensor {
    /// 12-bit, full well 20 000 e⁻ mapped to the top code, read noise 8 e⁻ (≈ 1.6 DN),
    /// black level 64 DN, a reference white at half the full well (≈ 2000 DN), shot noise on.
    fn default() -> Self {
        Sensor::with_bit_depth(12)
    }
}

impl Sensor {
    /// The default sensor at another bit depth (the paper's camera: 10 bits); the full well
    /// still maps to the top code.
    pub fn with_bit_depth(bit_depth: u8) -> Sensor {
        let full_well = 20_000.0;
        let max_code = ((1u32 << bit_depth.clamp(1, 16)) - 1) as f64;
        let black = (max_code / 64.0).round();
        Sensor {
            bit_depth,
            full_well_electrons: full_well,
            gain_dn_per_electron: (max_code - black) / full_well,
            read_noise_electrons: 8.0,
            black_level_dn: black,
            white_electrons: 10_000.0,
            shot_noise: true,
        }
    }

    /// The same sensor without shot or read noise (quantisation and saturation remain).
    pub fn noiseless(self) -> Sensor {
        Sensor {
            read_noise_electrons: 0.0,
            shot_noise: false,
            ..self
        }
    }

    /// What this sensor's datasheet says, in the form a plan states it for the decoder's
    /// threshold (`decoding.sensor`): the charge at the top code and the read noise. Without
    /// shot noise, a full-scale charge so large that its shot noise vanishes.
    pub fn datasheet(&self) -> fsm_core::SensorNoise {
        let full_scale = if self.shot_noise {
            self.max_code() as f64 / self.gain_dn_per_electron
        } else {
            1e12
        };
        fsm_core::SensorNoise {
            full_scale_electrons: full_scale as f32,
            read_noise_electrons: self.read_noise_electrons as f32,
        }
    }

    /// The highest code, `2^bits − 1`.
    pub fn max_code(&self) -> u16 {
        ((1u32 << self.bit_depth) - 1) as u16
    }

    /// Mean DN of a pixel receiving `signal` reference whites (before noise, clipping and
    /// rounding).
    pub fn expected_dn(&self, signal: f64) -> f64 {
        self.black_level_dn + self.gain_dn_per_electron * signal * self.white_electrons
    }

    /// Checks the numbers; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        if !(8..=16).contains(&self.bit_depth) {
            return Err(format!(
                "sensor.bit_depth = {}: must be in 8..=16",
                self.bit_depth
            ));
        }
        let positive = [
            ("full_well_electrons", self.full_well_electrons),
            ("gain_dn_per_electron", self.gain_dn_per_electron),
            ("white_electrons", self.white_electrons),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("sensor.{name} = {v}: must be finite and above 0"));
            }
        }
        let non_negative = [
            ("read_noise_electrons", self.read_noise_electrons),
            ("black_level_dn", self.black_level_dn),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "sensor.{name} = {v}: must be finite and not negative"
                ));
            }
        }
        Ok(())
    }
}
