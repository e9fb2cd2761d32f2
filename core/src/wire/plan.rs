//! The canonical 80-byte encoding of a scan plan, and its fingerprint.
//!
//! Every file and message that depends on a decode carries the plan's fingerprint (CRC-64/XZ of
//! these bytes), so candidates decoded with one plan cannot be scanned with another; a row dump
//! carries the fingerprint of the plan's patterns alone ([`ScanPlan::pattern_fingerprint`]), so
//! it decodes with any settings of the decoder. The same
//! bytes are the compact form a camera stores. Little-endian (version 2; version 1 was the
//! first 64 bytes alone, and is still read):
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | u16 | `projector_columns` (`cmax`) |
//! | 2 | u16 | `transform_size` (`N`) |
//! | 4 | u32 | `band.period_columns` (`L`) |
//! | 8 | u32 | `band.first_harmonic` (`n₁`) |
//! | 12 | u16 | `band.count` (`M`) |
//! | 14 | u8 | method: 0 BFSM, 1 EFSM |
//! | 15 | u8 | EFSM groups: 1 or 2 (0 for BFSM) |
//! | 16 | u16 | EFSM `block_width` (0 for BFSM) |
//! | 18 | u8 | peak search: 0 CLEAN, 1 local maxima, 2 cosine (version 2) |
//! | 19 | u8 | reserved, 0 |
//! | 20 | f32 | EFSM `border_guard` (0 for BFSM) |
//! | 24 | f32 | `levels.offset` (`PA`) |
//! | 28 | f32 | `levels.amplitude` (`PB`) |
//! | 32 | u8 | references: bit 0 dark, bit 1 white |
//! | 33 | u8 | window: 0 rectangular, 1 Hann |
//! | 34 | u8 | estimator: 0 deconvolution, 1 Gaussian, 2 parabolic, 3 Blais–Rioux 4, 4 Blais–Rioux 8 |
//! | 35 | u8 | `max_peaks` |
//! | 36 | f32 × 6 | `noise_factor`, `relative_floor`, `min_amplitude_dn`, `mask_noise_factor`, `mask_relative_floor`, `merge_tolerance` |
//! | 60 | u16 | format version, 2 |
//! | 62 | u16 | reserved, 0 |
//! | 64 | f32 | `sensor.full_scale_electrons` |
//! | 68 | f32 | `sensor.read_noise_electrons` |
//! | 72 | `[u8; 8]` | reserved, 0 |
//!
//! A version-1 plan reads as the same plan with [`SensorNoise::default`] (the fields it lacks
//! only matter to the cosine search, which version 1 cannot name), and keeps its fingerprint
//! for the files recorded with it: [`ScanPlan::legacy_fingerprint`].

use super::{Reader, WireError, Writer, CRC64};
use crate::plan::{
    BlockCoding, DecodeSettings, FringeBand, GroupCount, Method, PatternLevels, PeakEstimator,
    PeakSearch, References, ScanPlan, SensorNoise, Window,
};

/// Length of an encoded plan.
pub const PLAN_LEN: usize = 80;
/// Version of the plan encoding this build writes (it also reads version 1).
pub const PLAN_VERSION: u16 = 2;
/// Length of a version-1 plan.
pub const PLAN_V1_LEN: usize = 64;

const WHAT: &str = "scan plan";

impl ScanPlan {
    /// The canonical bytes of the plan.
    pub fn to_bytes(&self) -> [u8; PLAN_LEN] {
        let mut out = [0u8; PLAN_LEN];
        self.write_common(&mut out, PLAN_VERSION);
        let mut w = Writer::new(&mut out[PLAN_V1_LEN..]);
        w.f32(self.decoding.sensor.full_scale_electrons);
        w.f32(self.decoding.sensor.read_noise_electrons);
        out
    }

    /// The version-1 bytes of a plan that version 1 can express (not the cosine search, the
    /// default sensor): what files recorded before version 2 carry the fingerprint of.
    fn v1_bytes(&self) -> Option<[u8; PLAN_V1_LEN]> {
        let expressible = self.decoding.search != PeakSearch::Cosine
            && self.decoding.sensor == SensorNoise::default();
        expressible.then(|| {
            let mut out = [0u8; PLAN_V1_LEN];
            self.write_common(&mut out, 1);
            out
        })
    }

    /// Bytes 0..64, shared by both versions.
    fn write_common(&self, out: &mut [u8], version: u16) {
        let mut w = Writer::new(&mut out[..PLAN_V1_LEN]);
        w.u16(self.projector_columns);
        w.u16(self.transform_size);
        w.u32(self.band.period_columns);
        w.u32(self.band.first_harmonic);
        w.u16(self.band.count);
        let (method, groups, width, guard) = match self.method {
            Method::Bfsm => (0, 0, 0, 0.0),
            Method::Efsm(b) => {
                let g = match b.groups {
                    GroupCount::One => 1,
                    GroupCount::Two => 2,
                };
                (1, g, b.block_width, b.border_guard)
            }
        };
        w.u8(method);
        w.u8(groups);
        w.u16(width);
        w.u8(match self.decoding.search {
            PeakSearch::Clean => 0,
            PeakSearch::LocalMaxima => 1,
            PeakSearch::Cosine => 2,
        });
        w.u8(0);
        w.f32(guard);
        w.f32(self.levels.offset);
        w.f32(self.levels.amplitude);
        w.u8(self.references.dark as u8 | (self.references.white as u8) << 1);
        let d = self.decoding;
        w.u8(match d.window {
            Window::Rectangular => 0,
            Window::Hann => 1,
        });
        w.u8(match d.estimator {
            PeakEstimator::Deconvolution => 0,
            PeakEstimator::Gaussian => 1,
            PeakEstimator::Parabolic => 2,
            PeakEstimator::BlaisRioux4 => 3,
            PeakEstimator::BlaisRioux8 => 4,
        });
        w.u8(d.max_peaks);
        for v in [
            d.noise_factor,
            d.relative_floor,
            d.min_amplitude_dn,
            d.mask_noise_factor,
            d.mask_relative_floor,
            d.merge_tolerance,
        ] {
            w.f32(v);
        }
        w.u16(version);
        w.u16(0);
    }

    /// Decodes and validates canonical plan bytes: version 2 (80 bytes), or version 1 (64).
    pub fn from_bytes(bytes: &[u8]) -> Result<ScanPlan, WireError> {
        let truncated = |needed: usize| WireError::Truncated {
            what: WHAT,
            needed,
            got: bytes.len(),
        };
        if bytes.len() < PLAN_V1_LEN {
            return Err(truncated(PLAN_V1_LEN));
        }
        let field = |field: &'static str, value: u64| WireError::Field {
            what: WHAT,
            field,
            value,
        };
        let version = Reader::new(&bytes[60..62]).u16();
        let sensor = match version {
            1 => SensorNoise::default(),
            PLAN_VERSION => {
                let extension = bytes
                    .get(PLAN_V1_LEN..PLAN_LEN)
                    .ok_or(truncated(PLAN_LEN))?;
                let mut r = Reader::new(extension);
                let sensor = SensorNoise {
                    full_scale_electrons: r.f32(),
                    read_noise_electrons: r.f32(),
                };
                if let Some(&b) = extension[8..].iter().find(|&&b| b != 0) {
                    return Err(field("reserved", b as u64));
                }
                sensor
            }
            _ => {
                return Err(WireError::Version {
                    what: WHAT,
                    version,
                    supported: PLAN_VERSION,
                })
            }
        };
        let mut r = Reader::new(&bytes[..PLAN_V1_LEN]);
        let projector_columns = r.u16();
        let transform_size = r.u16();
        let band = FringeBand {
            period_columns: r.u32(),
            first_harmonic: r.u32(),
            count: r.u16(),
        };
        let (method, groups, block_width, search, reserved, border_guard) =
            (r.u8(), r.u8(), r.u16(), r.u8(), r.u8(), r.f32());
        let search = match (search, version) {
            (0, _) => PeakSearch::Clean,
            (1, _) => PeakSearch::LocalMaxima,
            (2, PLAN_VERSION) => PeakSearch::Cosine,
            (v, _) => return Err(field("search", v as u64)),
        };
        if reserved != 0 {
            return Err(field("reserved", reserved as u64));
        }
        let method = match (method, groups) {
            // BFSM leaves the EFSM fields zero, bit for bit: a -0.0 guard would decode but
            // re-encode as +0.0, and the fingerprint would not be that of the bytes received.
            (0, 0) if block_width != 0 => return Err(field("block_width", block_width as u64)),
            (0, 0) if border_guard.to_bits() != 0 => {
                return Err(field("border_guard", border_guard.to_bits() as u64))
            }
            (0, 0) => Method::Bfsm,
            (1, 1 | 2) => Method::Efsm(BlockCoding {
                block_width,
                groups: if groups == 1 {
                    GroupCount::One
                } else {
                    GroupCount::Two
                },
                border_guard,
            }),
            (0 | 1, _) => return Err(field("groups", groups as u64)),
            _ => return Err(field("method", method as u64)),
        };
        let levels = PatternLevels {
            offset: r.f32(),
            amplitude: r.f32(),
        };
        let references = r.u8();
        if references > 3 {
            return Err(field("references", references as u64));
        }
        let references = References {
            dark: references & 1 != 0,
            white: references & 2 != 0,
        };
        let window = match r.u8() {
            0 => Window::Rectangular,
            1 => Window::Hann,
            v => return Err(field("window", v as u64)),
        };
        let estimator = match r.u8() {
            0 => PeakEstimator::Deconvolution,
            1 => PeakEstimator::Gaussian,
            2 => PeakEstimator::Parabolic,
            3 => PeakEstimator::BlaisRioux4,
            4 => PeakEstimator::BlaisRioux8,
            v => return Err(field("estimator", v as u64)),
        };
        let decoding = DecodeSettings {
            search,
            window,
            estimator,
            max_peaks: r.u8(),
            noise_factor: r.f32(),
            relative_floor: r.f32(),
            min_amplitude_dn: r.f32(),
            mask_noise_factor: r.f32(),
            mask_relative_floor: r.f32(),
            merge_tolerance: r.f32(),
            sensor,
        };
        let _version = r.u16();
        let reserved = r.u16();
        if reserved != 0 {
            return Err(field("reserved", reserved as u64));
        }
        let plan = ScanPlan {
            projector_columns,
            band,
            transform_size,
            method,
            levels,
            references,
            decoding,
        };
        plan.validate().map_err(WireError::Plan)?;
        Ok(plan)
    }

    /// CRC-64/XZ of the canonical bytes: the identity every dependent file and message carries.
    pub fn fingerprint(&self) -> u64 {
        CRC64.checksum(&self.to_bytes())
    }

    /// The fingerprint files recorded before plan version 2 carry for this plan (CRC-64 of its
    /// version-1 bytes), or `None` where version 1 cannot express it.
    pub fn legacy_fingerprint(&self) -> Option<u64> {
        self.v1_bytes().map(|b| CRC64.checksum(&b))
    }

    /// Whether a file or message stating `fingerprint` was made with this plan: its
    /// fingerprint, or its version-1 one.
    pub fn has_fingerprint(&self, fingerprint: u64) -> bool {
        self.identity().has_plan_fingerprint(fingerprint)
    }

    /// The fingerprint of the frames alone ([`super::pattern_fingerprint`], tag `FS`): what
    /// row dumps carry, so that a capture decodes again under other decoder settings. Its
    /// fields are those [`ScanPlan::intensity`] and the sequence read: `projector_columns`,
    /// the band (`L`, `n₁`, `M`), the method with its groups and block width, the levels
    /// (`PA`, `PB`) and the references; not `transform_size`, the border guard or any
    /// [`DecodeSettings`] field.
    pub fn pattern_fingerprint(&self) -> u64 {
        let mut fields = [0u8; 24];
        let mut w = Writer::new(&mut fields);
        w.u16(self.projector_columns);
        w.u32(self.band.period_columns);
        w.u32(self.band.first_harmonic);
        w.u16(self.band.count);
        let (groups, block_width) = match self.method {
            Method::Bfsm => (0, 0),
            Method::Efsm(b) => (b.groups as u8 + 1, b.block_width),
        };
        w.u8(groups);
        w.u16(block_width);
        w.f32(self.levels.offset);
        w.f32(self.levels.amplitude);
        w.u8(self.references.dark as u8 | (self.references.white as u8) << 1);
        debug_assert_eq!(w.at, fields.len());
        super::pattern_fingerprint(b"FS", &fields)
    }

    /// Every fingerprint of the plan.
    pub fn identity(&self) -> super::PlanIdentity {
        super::PlanIdentity {
            patterns: self.pattern_fingerprint(),
            plan: self.fingerprint(),
            legacy_plan: self.legacy_fingerprint(),
        }
    }
}
