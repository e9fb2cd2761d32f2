//! The canonical bytes of every method's plan: what `fsm upload` sends a camera, what the
//! camera stores, what `fsm plan --wire` writes.
//!
//! An FSM plan is its 80 bytes ([`crate::wire::plan`], or 64 of version 1). A baseline plan is
//! a fixed number of little-endian bytes of its own, never 64 or 80, that start with the
//! 2-byte tag its fingerprints use and a format version, and end with the sensor and zero
//! reserved bytes; [`MethodPlan::from_bytes`] tells them apart by length first, then by tag,
//! so no FSM plan can be read as a baseline's (an FSM plan starts with its column count, which
//! may spell any tag).
//!
//! Phase shift + Gray code ([`PhaseShiftPlan`]), [`PHASE_SHIFT_LEN`] = 32 bytes:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 2]` | tag `PS` |
//! | 2 | u16 | format version, 1 |
//! | 4 | u16 | `projector_columns` |
//! | 6 | u16 | `period_columns` |
//! | 8 | u8 | `steps` |
//! | 9 | u8 | `bits` |
//! | 10 | u16 | reserved, 0 |
//! | 12 | f32 | `min_modulation_dn` |
//! | 16 | f32 | `sensor.full_scale_electrons` |
//! | 20 | f32 | `sensor.read_noise_electrons` |
//! | 24 | `[u8; 8]` | reserved, 0 |
//!
//! Micro Phase Shifting ([`MicroPhaseShiftPlan`]), [`MICRO_PHASE_SHIFT_LEN`] = 96 bytes:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 2]` | tag `MP` |
//! | 2 | u16 | format version, 1 |
//! | 4 | u16 | `projector_columns` |
//! | 6 | u8 | `frequencies` |
//! | 7 | u8 | reserved, 0 |
//! | 8 | f32 | `min_modulation_dn` |
//! | 12 | f32 | `max_code_residual` |
//! | 16 | f32 × 16 | `periods_columns`; those past `frequencies` are 0 |
//! | 80 | f32 | `sensor.full_scale_electrons` |
//! | 84 | f32 | `sensor.read_noise_electrons` |
//! | 88 | `[u8; 8]` | reserved, 0 |
//!
//! Line scanning ([`LineScanPlan`]), [`LINE_SCAN_LEN`] = 32 bytes:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 2]` | tag `LS` |
//! | 2 | u16 | format version, 1 |
//! | 4 | u16 | `projector_columns` |
//! | 6 | u8 | `detector`: 0 Auto, 1 Gaussian, 2 centre of mass |
//! | 7 | u8 | centre of mass: `points` (3, 5 or 7); 0 otherwise |
//! | 8 | f32 | `noise_factor` |
//! | 12 | f32 | `sensor.full_scale_electrons` |
//! | 16 | f32 | `sensor.read_noise_electrons` |
//! | 20 | `[u8; 12]` | reserved, 0 |
//!
//! Code Ensemble ([`CodeEnsemblePlan`]), [`CODE_ENSEMBLE_LEN`] = 32 bytes:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 2]` | tag `CE` |
//! | 2 | u16 | format version, 1 |
//! | 4 | u16 | `projector_columns` |
//! | 6 | u16 | `agreement_columns` |
//! | 8 | f32 | `min_contrast_dn` |
//! | 12 | f32 | `sensor.full_scale_electrons` |
//! | 16 | f32 | `sensor.read_noise_electrons` |
//! | 20 | `[u8; 12]` | reserved, 0 |
//!
//! Every field is read back bit for bit and every reserved byte must be 0, so bytes that
//! decode re-encode to themselves. A baseline's fingerprint is not a checksum of these bytes:
//! it is the one its candidate files have always carried (`PhaseShiftPlan::fingerprint`, …),
//! which leaves out what no candidate depends on (the phase-shift, Micro Phase Shifting and
//! Code Ensemble plans' sensor).

use core::ops::Deref;

use super::MethodPlan;
use crate::baseline::code_ensemble::{CodeEnsembleError, CodeEnsemblePlan};
use crate::baseline::line_scan::{LineDetector, LineScanError, LineScanPlan};
use crate::baseline::micro_phase_shift::{
    MicroPhaseShiftError, MicroPhaseShiftPlan, MAX_FREQUENCIES,
};
use crate::baseline::phase_shift::{PhaseShiftError, PhaseShiftPlan};
use crate::plan::ScanPlan;
use crate::plan::SensorNoise;
use crate::wire::plan::{PLAN_LEN, PLAN_V1_LEN};
use crate::wire::{Reader, WireError, Writer};

/// Bytes of a phase-shift plan.
pub const PHASE_SHIFT_LEN: usize = 32;
/// Bytes of a Micro Phase Shifting plan.
pub const MICRO_PHASE_SHIFT_LEN: usize = 96;
/// Bytes of a line-scanning plan.
pub const LINE_SCAN_LEN: usize = 32;
/// Bytes of a Code Ensemble plan.
pub const CODE_ENSEMBLE_LEN: usize = 32;
/// Version of the baselines' plan encoding this build reads and writes.
pub const BASELINE_PLAN_VERSION: u16 = 1;
/// Bytes of the longest plan of any method.
pub const MAX_PLAN_LEN: usize = MICRO_PHASE_SHIFT_LEN;
/// Bytes of the shortest plan of any method.
pub const MIN_PLAN_LEN: usize = PHASE_SHIFT_LEN;
/// The lengths the plan of some method has in its current version (FSM's 80, then the
/// baselines'): what a camera checks before it reads the bytes.
pub const PLAN_LENGTHS: [usize; 5] = [
    PLAN_LEN,
    PHASE_SHIFT_LEN,
    MICRO_PHASE_SHIFT_LEN,
    LINE_SCAN_LEN,
    CODE_ENSEMBLE_LEN,
];

const _: () = assert!(MAX_PLAN_LEN >= PLAN_LEN);
// No baseline plan has an FSM plan's length: the length alone says FSM or not.
const _: () = {
    let lens = PLAN_LENGTHS;
    let mut i = 1;
    while i < lens.len() {
        assert!(lens[i] != PLAN_LEN && lens[i] != PLAN_V1_LEN && lens[i] >= MIN_PLAN_LEN);
        i += 1;
    }
};

const PS: &str = "phase-shift plan";
const MPS: &str = "Micro Phase Shifting plan";
const LS: &str = "line-scan plan";
const CE: &str = "Code Ensemble plan";
const ANY: &str = "plan";

/// Checks a baseline plan's length, tag and version; a reader after the version (offset 4).
fn open<'a>(
    what: &'static str,
    tag: &[u8; 2],
    len: usize,
    bytes: &'a [u8],
) -> Result<Reader<'a>, WireError> {
    if bytes.len() < len {
        return Err(WireError::Truncated {
            what,
            needed: len,
            got: bytes.len(),
        });
    }
    if bytes.len() > len {
        return Err(WireError::Field {
            what,
            field: "length",
            value: bytes.len() as u64,
        });
    }
    if &bytes[..2] != tag {
        return Err(WireError::Magic { what });
    }
    let mut r = Reader::new(bytes);
    r.at = 2;
    let version = r.u16();
    if version != BASELINE_PLAN_VERSION {
        return Err(WireError::Version {
            what,
            version,
            supported: BASELINE_PLAN_VERSION,
        });
    }
    Ok(r)
}

/// Writes the tag and the version, leaving the writer at offset 4.
fn begin<'a>(tag: &[u8; 2], out: &'a mut [u8]) -> Writer<'a> {
    let mut w = Writer::new(out);
    w.put(tag);
    w.u16(BASELINE_PLAN_VERSION);
    w
}

/// The first non-zero byte of a reserved span, as the error naming it.
fn reserved(what: &'static str, bytes: &[u8]) -> Result<(), WireError> {
    match bytes.iter().find(|&&b| b != 0) {
        Some(&b) => Err(WireError::Field {
            what,
            field: "reserved",
            value: b as u64,
        }),
        None => Ok(()),
    }
}

fn sensor(r: &mut Reader<'_>) -> SensorNoise {
    SensorNoise {
        full_scale_electrons: r.f32(),
        read_noise_electrons: r.f32(),
    }
}

fn put_sensor(w: &mut Writer<'_>, s: &SensorNoise) {
    w.f32(s.full_scale_electrons);
    w.f32(s.read_noise_electrons);
}

fn rule(what: &'static str, field: &'static str, value: f32, rule: &'static str) -> WireError {
    WireError::Rule {
        what,
        field,
        value,
        rule,
    }
}

impl PhaseShiftPlan {
    /// The canonical bytes of the plan (the table of [`crate::methods::wire`]).
    pub fn to_bytes(&self) -> [u8; PHASE_SHIFT_LEN] {
        let mut out = [0u8; PHASE_SHIFT_LEN];
        let mut w = begin(b"PS", &mut out);
        w.u16(self.projector_columns);
        w.u16(self.period_columns);
        w.u8(self.steps);
        w.u8(self.bits);
        w.u16(0);
        w.f32(self.min_modulation_dn);
        put_sensor(&mut w, &self.sensor);
        out
    }

    /// Decodes and validates canonical plan bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, WireError> {
        let mut r = open(PS, b"PS", PHASE_SHIFT_LEN, bytes)?;
        let (projector_columns, period_columns, steps, bits) = (r.u16(), r.u16(), r.u8(), r.u8());
        reserved(PS, &r.take::<2>())?;
        let plan = PhaseShiftPlan {
            projector_columns,
            period_columns,
            steps,
            bits,
            min_modulation_dn: r.f32(),
            sensor: sensor(&mut r),
        };
        reserved(PS, &bytes[r.at..])?;
        plan.validate().map_err(|e| match e {
            PhaseShiftError::Steps { steps } => rule(
                PS,
                "steps",
                steps as f32,
                "at least 3 phase offsets are needed",
            ),
            PhaseShiftError::Period { period_columns } => rule(
                PS,
                "period_columns",
                period_columns as f32,
                "the fringe period must be at least 2 columns",
            ),
            PhaseShiftError::Bits { bits, .. } => rule(
                PS,
                "bits",
                bits as f32,
                "the Gray code must count every half period of the projector, in at most 16 bits",
            ),
            PhaseShiftError::Threshold { field, value } => {
                rule(PS, field, value, "must be a finite number, not below 0")
            }
            PhaseShiftError::Sensor { field, value } => rule(PS, field, value, SensorNoise::RULE),
        })?;
        Ok(plan)
    }
}

impl MicroPhaseShiftPlan {
    /// The canonical bytes of the plan (the table of [`crate::methods::wire`]); the periods
    /// past `frequencies`, which nothing reads, are written 0.
    pub fn to_bytes(&self) -> [u8; MICRO_PHASE_SHIFT_LEN] {
        let mut out = [0u8; MICRO_PHASE_SHIFT_LEN];
        let mut w = begin(b"MP", &mut out);
        w.u16(self.projector_columns);
        w.u8(self.frequencies);
        w.u8(0);
        w.f32(self.min_modulation_dn);
        w.f32(self.max_code_residual);
        let used = self.periods().len();
        for (i, p) in self.periods_columns.iter().enumerate() {
            w.f32(if i < used { *p } else { 0.0 });
        }
        put_sensor(&mut w, &self.sensor);
        out
    }

    /// Decodes and validates canonical plan bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, WireError> {
        let mut r = open(MPS, b"MP", MICRO_PHASE_SHIFT_LEN, bytes)?;
        let (projector_columns, frequencies) = (r.u16(), r.u8());
        reserved(MPS, &[r.u8()])?;
        let (min_modulation_dn, max_code_residual) = (r.f32(), r.f32());
        let mut periods_columns = [0.0f32; MAX_FREQUENCIES];
        for p in periods_columns.iter_mut() {
            *p = r.f32();
        }
        let used = (frequencies as usize).min(MAX_FREQUENCIES);
        if let Some(p) = periods_columns[used..].iter().find(|p| p.to_bits() != 0) {
            return Err(rule(
                MPS,
                "periods_columns",
                *p,
                "a period past `frequencies` must be 0",
            ));
        }
        let plan = MicroPhaseShiftPlan {
            projector_columns,
            periods_columns,
            frequencies,
            min_modulation_dn,
            max_code_residual,
            sensor: sensor(&mut r),
        };
        reserved(MPS, &bytes[r.at..])?;
        plan.validate().map_err(|e| match e {
            MicroPhaseShiftError::Frequencies { frequencies } => rule(
                MPS,
                "frequencies",
                frequencies as f32,
                "Micro Phase Shifting takes 2 to 16",
            ),
            MicroPhaseShiftError::Period { period_columns, .. } => rule(
                MPS,
                "periods_columns",
                period_columns,
                "a period is 2 columns or more and at most the projector's width",
            ),
            MicroPhaseShiftError::RepeatedPeriod { index } => rule(
                MPS,
                "periods_columns",
                periods_columns[index as usize],
                "repeats an earlier period: every frequency must differ",
            ),
            MicroPhaseShiftError::Threshold { field, value } => {
                rule(MPS, field, value, "must be a finite number, not below 0")
            }
            MicroPhaseShiftError::Sensor { field, value } => {
                rule(MPS, field, value, SensorNoise::RULE)
            }
        })?;
        Ok(plan)
    }
}

impl LineScanPlan {
    /// The canonical bytes of the plan (the table of [`crate::methods::wire`]).
    pub fn to_bytes(&self) -> [u8; LINE_SCAN_LEN] {
        let mut out = [0u8; LINE_SCAN_LEN];
        let mut w = begin(b"LS", &mut out);
        w.u16(self.projector_columns);
        let (detector, points) = match self.detector {
            LineDetector::Auto => (0, 0),
            LineDetector::Gaussian => (1, 0),
            LineDetector::CentreOfMass { points } => (2, points),
        };
        w.u8(detector);
        w.u8(points);
        w.f32(self.noise_factor);
        put_sensor(&mut w, &self.sensor);
        out
    }

    /// Decodes and validates canonical plan bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, WireError> {
        let mut r = open(LS, b"LS", LINE_SCAN_LEN, bytes)?;
        let projector_columns = r.u16();
        let field = |field, value: u8| WireError::Field {
            what: LS,
            field,
            value: value as u64,
        };
        let detector = match (r.u8(), r.u8()) {
            (0, 0) => LineDetector::Auto,
            (1, 0) => LineDetector::Gaussian,
            (2, points) => LineDetector::CentreOfMass { points },
            (0 | 1, points) => return Err(field("points", points)),
            (d, _) => return Err(field("detector", d)),
        };
        let plan = LineScanPlan {
            projector_columns,
            detector,
            noise_factor: r.f32(),
            sensor: sensor(&mut r),
        };
        reserved(LS, &bytes[r.at..])?;
        plan.validate().map_err(|e| match e {
            LineScanError::Columns { projector_columns } => rule(
                LS,
                "projector_columns",
                projector_columns as f32,
                "line scanning needs at least 3 columns",
            ),
            LineScanError::DetectorPoints { points } => rule(
                LS,
                "points",
                points as f32,
                "the centre of mass takes 3, 5 or 7 samples",
            ),
            LineScanError::NoiseFactor { noise_factor } => rule(
                LS,
                "noise_factor",
                noise_factor,
                "must be a positive number",
            ),
            LineScanError::Sensor { field, value } => rule(LS, field, value, SensorNoise::RULE),
        })?;
        Ok(plan)
    }
}

impl CodeEnsemblePlan {
    /// The canonical bytes of the plan (the table of [`crate::methods::wire`]).
    pub fn to_bytes(&self) -> [u8; CODE_ENSEMBLE_LEN] {
        let mut out = [0u8; CODE_ENSEMBLE_LEN];
        let mut w = begin(b"CE", &mut out);
        w.u16(self.projector_columns);
        w.u16(self.agreement_columns);
        w.f32(self.min_contrast_dn);
        put_sensor(&mut w, &self.sensor);
        out
    }

    /// Decodes and validates canonical plan bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, WireError> {
        let mut r = open(CE, b"CE", CODE_ENSEMBLE_LEN, bytes)?;
        let plan = CodeEnsemblePlan {
            projector_columns: r.u16(),
            agreement_columns: r.u16(),
            min_contrast_dn: r.f32(),
            sensor: sensor(&mut r),
        };
        reserved(CE, &bytes[r.at..])?;
        plan.validate().map_err(|e| match e {
            CodeEnsembleError::Columns { projector_columns } => rule(
                CE,
                "projector_columns",
                projector_columns as f32,
                "at least 2 columns are needed",
            ),
            CodeEnsembleError::Agreement { agreement_columns } => rule(
                CE,
                "agreement_columns",
                agreement_columns as f32,
                "must be at most a quarter of the 1024 codewords",
            ),
            CodeEnsembleError::Threshold { value } => rule(
                CE,
                "min_contrast_dn",
                value,
                "must be a finite number, not below 0",
            ),
            CodeEnsembleError::Sensor { field, value } => rule(CE, field, value, SensorNoise::RULE),
        })?;
        Ok(plan)
    }
}

/// The canonical bytes of a plan of any method ([`MethodPlan::to_bytes`]): up to
/// [`MAX_PLAN_LEN`] bytes, no allocation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanBytes {
    bytes: [u8; MAX_PLAN_LEN],
    len: usize,
}

impl PlanBytes {
    fn of(bytes: &[u8]) -> Self {
        let mut out = PlanBytes {
            bytes: [0; MAX_PLAN_LEN],
            len: bytes.len(),
        };
        out.bytes[..bytes.len()].copy_from_slice(bytes);
        out
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        &self.bytes[..self.len]
    }
}

impl Deref for PlanBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl AsRef<[u8]> for PlanBytes {
    fn as_ref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl MethodPlan {
    /// Bytes of the plan's canonical form: 80 for FSM, [`PHASE_SHIFT_LEN`] … for a baseline.
    pub fn wire_len(&self) -> usize {
        match self {
            MethodPlan::Fsm(_) => PLAN_LEN,
            MethodPlan::PhaseShift(_) => PHASE_SHIFT_LEN,
            MethodPlan::MicroPhaseShift(_) => MICRO_PHASE_SHIFT_LEN,
            MethodPlan::LineScan(_) => LINE_SCAN_LEN,
            MethodPlan::CodeEnsemble(_) => CODE_ENSEMBLE_LEN,
        }
    }

    /// The plan's canonical bytes (an FSM plan's are [`ScanPlan::to_bytes`], as always).
    pub fn to_bytes(&self) -> PlanBytes {
        match self {
            MethodPlan::Fsm(p) => PlanBytes::of(&p.to_bytes()),
            MethodPlan::PhaseShift(p) => PlanBytes::of(&p.to_bytes()),
            MethodPlan::MicroPhaseShift(p) => PlanBytes::of(&p.to_bytes()),
            MethodPlan::LineScan(p) => PlanBytes::of(&p.to_bytes()),
            MethodPlan::CodeEnsemble(p) => PlanBytes::of(&p.to_bytes()),
        }
    }

    /// Writes the canonical bytes at the start of `out`; returns their length.
    pub fn write_bytes(&self, out: &mut [u8]) -> Result<usize, WireError> {
        let bytes = self.to_bytes();
        let got = out.len();
        let out = out
            .get_mut(..bytes.len())
            .ok_or(WireError::BufferTooSmall {
                what: ANY,
                needed: bytes.len(),
                got,
            })?;
        out.copy_from_slice(&bytes);
        Ok(bytes.len())
    }

    /// Decodes and validates a plan of any method: 80 bytes (or 64, version 1) are an FSM
    /// plan, as [`ScanPlan::from_bytes`] reads them; any other length is a baseline's, named
    /// by its tag and of that baseline's length.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, WireError> {
        let len = bytes.len();
        if len == PLAN_LEN || len == PLAN_V1_LEN {
            return ScanPlan::from_bytes(bytes).map(MethodPlan::Fsm);
        }
        if len < MIN_PLAN_LEN {
            return Err(WireError::Truncated {
                what: ANY,
                needed: MIN_PLAN_LEN,
                got: len,
            });
        }
        match &[bytes[0], bytes[1]] {
            b"PS" => PhaseShiftPlan::from_bytes(bytes).map(MethodPlan::PhaseShift),
            b"MP" => MicroPhaseShiftPlan::from_bytes(bytes).map(MethodPlan::MicroPhaseShift),
            b"LS" => LineScanPlan::from_bytes(bytes).map(MethodPlan::LineScan),
            b"CE" => CodeEnsemblePlan::from_bytes(bytes).map(MethodPlan::CodeEnsemble),
            tag if [PHASE_SHIFT_LEN, MICRO_PHASE_SHIFT_LEN].contains(&len) => {
                Err(WireError::Field {
                    what: ANY,
                    field: "tag",
                    value: u16::from_le_bytes(*tag) as u64,
                })
            }
            _ => Err(WireError::Field {
                what: ANY,
                field: "length",
                value: len as u64,
            }),
        }
    }
}
