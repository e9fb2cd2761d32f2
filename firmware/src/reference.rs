//! The host's side of the cross-check (host only): decode a row dump with `fsm_core` as
//! `fsm decode` does, and compare two candidate files, naming the first difference.
//!
//! [`decode_dump`] is written directly against `fsm_core` (its own buffers, `decode_row`,
//! `wire::candidates`), not through this crate's loop, so that comparing the firmware's output
//! with it checks the loop as well as the target's arithmetic.

use std::fmt;

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::row_dump::{self, RowDumpHeader};
use fsm_core::wire::{WireError, HEADER_LEN};
use fsm_core::{MethodDecoder, MethodPlan, PixelCandidates, Row};

use crate::limits::CANDIDATE_CAPACITY;

/// The candidate file of `dump` decoded on the host with `plan` (any method's: FSM's
/// `Decoder::decode_row`, a baseline's `PixelDecoder::decode_row`, whole rows at once): the
/// header, then one record per row in the dump's order.
pub fn decode_dump(plan: impl Into<MethodPlan>, dump: &[u8]) -> Result<Vec<u8>, String> {
    let plan: MethodPlan = plan.into();
    let header = RowDumpHeader::decode(dump).map_err(|e| e.to_string())?;
    plan.check_row_dump(&header).map_err(|e| e.to_string())?;
    let record_len = header.record_len().ok_or("row dump: rows too large")?;
    let body = &dump[HEADER_LEN..];
    if !body.len().is_multiple_of(record_len) {
        return Err(format!(
            "row dump: {} bytes of records is not a whole number of {record_len}-byte records",
            body.len()
        ));
    }
    let mut tables = vec![0.0; plan.tables_len()];
    let decoder = MethodDecoder::new(&plan, &mut tables).map_err(|e| e.to_string())?;
    let mut scratch = vec![0.0; plan.scratch_len_lanes::<{ fsm_core::decoder::MAX_LANES }>()];
    let width = header.width as usize;
    let mut samples = vec![0u16; header.samples_per_row()];
    let mut pixels = vec![PixelCandidates::<CANDIDATE_CAPACITY>::new(); width];
    let out_header = CandidateHeader {
        capacity: CANDIDATE_CAPACITY as u16,
        plan_fingerprint: plan.fingerprint(),
        width: header.width,
        height: header.height,
    };
    let max = out_header
        .max_record_len()
        .ok_or("candidate rows too large")?;
    let mut record = vec![0u8; max];
    let mut out = out_header.encode().to_vec();
    for bytes in body.chunks_exact(record_len) {
        let r = row_dump::decode_record(&header, bytes).map_err(|e| e.to_string())?;
        r.copy_to(&mut samples).map_err(|e| e.to_string())?;
        let row = Row {
            frames: &samples,
            width,
            bit_depth: header.bit_depth,
            column_limits: None,
        };
        decoder
            .decode_row(&row, &mut scratch, &mut pixels)
            .map_err(|e| format!("row {}: {e}", r.row))?;
        let n = candidates::encode_record(&out_header, r.row, &pixels, &mut record)
            .map_err(|e| e.to_string())?;
        out.extend_from_slice(&record[..n]);
    }
    Ok(out)
}

/// The first place two candidate files differ.
#[derive(Clone, Debug, PartialEq)]
pub enum Difference {
    /// A file does not read as a candidate file (`which`: "expected" or "actual").
    Unreadable {
        /// Which file.
        which: &'static str,
        /// Why.
        error: WireError,
    },
    /// The headers differ.
    Header {
        /// The expected header.
        expected: CandidateHeader,
        /// The actual header.
        actual: CandidateHeader,
    },
    /// The files hold different numbers of records.
    Records {
        /// Records expected.
        expected: usize,
        /// Records present.
        actual: usize,
    },
    /// Record `index` is of another row.
    Row {
        /// Record index.
        index: usize,
        /// Row expected.
        expected: u32,
        /// Row present.
        actual: u32,
    },
    /// A pixel differs.
    Pixel {
        /// Row.
        row: u32,
        /// Pixel.
        x: usize,
        /// The expected pixel.
        expected: String,
        /// The actual pixel.
        actual: String,
    },
    /// The bytes differ although every decoded value is equal (cannot happen with one encoder).
    Bytes {
        /// Offset of the first differing byte.
        offset: usize,
    },
}

impl fmt::Display for Difference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Difference::Unreadable { which, error } => write!(f, "{which} file: {error}"),
            Difference::Header { expected, actual } => {
                write!(
                    f,
                    "headers differ: expected {expected:?}, actual {actual:?}"
                )
            }
            Difference::Records { expected, actual } => {
                write!(f, "{actual} records, expected {expected}")
            }
            Difference::Row {
                index,
                expected,
                actual,
            } => write!(
                f,
                "record {index} is of row {actual}, expected row {expected}"
            ),
            Difference::Pixel {
                row,
                x,
                expected,
                actual,
            } => write!(
                f,
                "row {row}, pixel {x}: expected {expected}, actual {actual}"
            ),
            Difference::Bytes { offset } => write!(f, "files differ at byte {offset}"),
        }
    }
}

/// A pixel's candidates as a file holds them (any capacity up to the format's 255).
pub type Pixel = PixelCandidates<{ u8::MAX as usize }>;
/// A candidate file read: its header and each record's row and pixels.
pub type Records = (CandidateHeader, Vec<(u32, Vec<Pixel>)>);

/// Reads a whole candidate file.
pub fn records(bytes: &[u8]) -> Result<Records, WireError> {
    read(bytes, "candidates").map_err(|d| match d {
        Difference::Unreadable { error, .. } => error,
        _ => unreachable!("read only reports unreadable files"),
    })
}

/// Reads a candidate file: its header and every record's pixels.
fn read(bytes: &[u8], which: &'static str) -> Result<Records, Difference> {
    let unreadable = |error| Difference::Unreadable { which, error };
    let header = CandidateHeader::decode(bytes).map_err(unreadable)?;
    let mut at = HEADER_LEN;
    let mut records = Vec::new();
    while at < bytes.len() {
        let r = candidates::decode_record(&header, &bytes[at..]).map_err(unreadable)?;
        let mut pixels = vec![Pixel::new(); header.width as usize];
        r.read_into(&header, &mut pixels).map_err(unreadable)?;
        records.push((r.row, pixels));
        at += r.len;
    }
    Ok((header, records))
}

/// Describes a pixel with every bit that the file holds.
fn describe(p: &Pixel) -> String {
    let mut s = format!(
        "flags {:#04x} noise {} ({:#010x}), {} candidates",
        p.flags.0,
        p.noise_dn,
        p.noise_dn.to_bits(),
        p.candidates.len()
    );
    for c in &p.candidates {
        s += &format!(
            " [column {} ({:#010x}) amplitude {} ({:#010x}) block {} groups {} group {} peak {}]",
            c.column,
            c.column.to_bits(),
            c.amplitude,
            c.amplitude.to_bits(),
            c.block,
            c.groups.0,
            c.group.number(),
            c.peak
        );
    }
    s
}

/// `Ok` if the two candidate files are byte for byte equal, else the first difference.
pub fn compare(expected: &[u8], actual: &[u8]) -> Result<(), Difference> {
    if expected == actual {
        return Ok(());
    }
    let (eh, er) = read(expected, "expected")?;
    let (ah, ar) = read(actual, "actual")?;
    if eh != ah {
        return Err(Difference::Header {
            expected: eh,
            actual: ah,
        });
    }
    for (index, ((erow, ep), (arow, ap))) in er.iter().zip(&ar).enumerate() {
        if erow != arow {
            return Err(Difference::Row {
                index,
                expected: *erow,
                actual: *arow,
            });
        }
        for (x, (e, a)) in ep.iter().zip(ap).enumerate() {
            let (de, da) = (describe(e), describe(a));
            if de != da {
                return Err(Difference::Pixel {
                    row: *erow,
                    x,
                    expected: de,
                    actual: da,
                });
            }
        }
    }
    if er.len() != ar.len() {
        return Err(Difference::Records {
            expected: er.len(),
            actual: ar.len(),
        });
    }
    let offset = expected
        .iter()
        .zip(actual)
        .position(|(a, b)| a != b)
        .unwrap_or(expected.len().min(actual.len()));
    Err(Difference::Bytes { offset })
}

/// What a candidate file holds, for reports: rows, pixels, and pixels by candidate count.
pub fn census(bytes: &[u8]) -> Result<Census, WireError> {
    let (header, records) = records(bytes)?;
    let mut census = Census {
        width: header.width,
        rows: records.len(),
        ..Census::default()
    };
    for (_, pixels) in &records {
        for p in pixels {
            census.by_count[p.candidates.len().min(3)] += 1;
        }
    }
    Ok(census)
}

/// See [`census`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Census {
    /// Pixels per row.
    pub width: u32,
    /// Records.
    pub rows: usize,
    /// Pixels with 0, 1, 2 and 3 or more candidates.
    pub by_count: [usize; 4],
}

impl fmt::Display for Census {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [a, b, c, d] = self.by_count;
        write!(
            f,
            "{} rows x {} pixels; pixels with 0/1/2/3+ candidates: {a}/{b}/{c}/{d}",
            self.rows, self.width
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MirrorScene;
    use fsm_core::GroupCount;
    use fsm_core::ScanPlan;

    #[test]
    fn compare_names_the_first_difference() {
        let plan = ScanPlan::paper_efsm(GroupCount::Two);
        let dump = MirrorScene::for_plan(plan, 16, 3).dump(plan);
        let a = decode_dump(plan, &dump).unwrap();
        assert_eq!(compare(&a, &a), Ok(()));
        let c = census(&a).unwrap();
        assert_eq!(c.rows, 3);
        assert_eq!(c.by_count.iter().sum::<usize>(), 48);

        // Change one candidate's column (and fix the record's CRC): named by row and pixel.
        let header = CandidateHeader::decode(&a).unwrap();
        let first = candidates::decode_record(&header, &a[64..]).unwrap();
        let second_at = 64 + first.len;
        let mut b = a.clone();
        let mut pixels = vec![PixelCandidates::<CANDIDATE_CAPACITY>::new(); 16];
        candidates::decode_record(&header, &b[second_at..])
            .unwrap()
            .read_into(&header, &mut pixels)
            .unwrap();
        let x = pixels
            .iter()
            .position(|p| !p.candidates.is_empty())
            .unwrap();
        pixels[x].candidates[0].column += 0.25;
        candidates::encode_record(&header, 1, &pixels, &mut b[second_at..]).unwrap();
        match compare(&a, &b) {
            Err(Difference::Pixel { row: 1, x: got, .. }) => assert_eq!(got, x),
            other => panic!("{other:?}"),
        }
        // A missing record.
        assert_eq!(
            compare(&a, &a[..second_at]),
            Err(Difference::Records {
                expected: 3,
                actual: 1
            })
        );
        // A damaged byte: the actual file is unreadable, and says where.
        let mut c = a.clone();
        c[second_at + 20] ^= 1;
        assert!(matches!(
            compare(&a, &c),
            Err(Difference::Unreadable {
                which: "actual",
                error: WireError::RecordCrc { row: 1, .. }
            })
        ));
    }
}
