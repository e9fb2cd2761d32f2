//! Candidate rows: the decoded candidates of every pixel of a row, as the camera streams them
//! and as `fsm decode` stores them. The same bytes whichever side decoded the row.
//!
//! A candidate file is a 64-byte header followed by one record per row. Little-endian.
//!
//! Header:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 8]` | magic `FSMCAND\0` |
//! | 8 | u16 | version, 1 |
//! | 10 | u16 | header length, 64 |
//! | 12 | u16 | capacity: most candidates a pixel may carry |
//! | 14 | u16 | reserved, 0 |
//! | 16 | u64 | plan fingerprint |
//! | 24 | u32 | width `W` |
//! | 28 | u32 | height `H` |
//! | 32 | `[u8; 28]` | reserved, 0 |
//! | 60 | u32 | CRC-32 of bytes 0–59 |
//!
//! Record:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | u32 | row index `y < H` |
//! | 4 | u32 | payload length `P` |
//! | 8 | `[u8; P]` | `W` pixels, each: u8 flags, u8 count `n`, f32 noise (DN), then `n` candidates |
//! | 8 + P | u32 | CRC-32 of bytes 0 to 8 + P |
//!
//! Pixel flags ([`PixelFlags`]): bit 0 saturated, bit 1 truncated (more candidates than the
//! capacity), bit 2 aliased (EFSM lights unresolved modulo the block width), bit 3 unresolved
//! (two touching lights the cosine search could not split), bit 4 no data (the row was corrupt
//! or missing in the capture and skipped on request; no light was looked for); other bits 0.
//!
//! Candidate (16 bytes): f32 column, f32 amplitude (DN), u16 block, u8 groups (bit 0 group 1,
//! bit 1 group 2), u8 source group (1 or 2), u8 peak rank, 3 reserved bytes (0).

use super::{
    begin_header, check_record, open_header, seal_header, seal_record, stored_crc, Reader,
    WireError, HEADER_LEN, RECORD_CRC_LEN,
};
use crate::candidate::{Candidate, GroupSet, PixelCandidates, PixelFlags};
use crate::plan::sequence::Group;

/// Magic bytes of a candidate file.
pub const MAGIC: [u8; 8] = *b"FSMCAND\0";
/// Version this build writes and reads.
pub const VERSION: u16 = 1;
/// Bytes of one candidate.
pub const CANDIDATE_LEN: usize = 16;
/// Bytes of a pixel's fixed part (flags, count, noise).
pub const PIXEL_LEN: usize = 6;
/// Bytes of a record around its payload (row, length, CRC).
pub const RECORD_OVERHEAD: usize = 12;

const WHAT: &str = "candidate rows";

/// The header of a candidate file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CandidateHeader {
    /// Most candidates per pixel.
    pub capacity: u16,
    /// Fingerprint of the plan the candidates were decoded with.
    pub plan_fingerprint: u64,
    /// Pixels per row.
    pub width: u32,
    /// Rows in the scan.
    pub height: u32,
}

impl CandidateHeader {
    /// The 64 header bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let mut w = begin_header(&MAGIC, VERSION, &mut out);
        w.u16(self.capacity);
        w.u16(0);
        w.u64(self.plan_fingerprint);
        w.u32(self.width);
        w.u32(self.height);
        seal_header(&mut out);
        out
    }

    /// Reads and checks a header.
    pub fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        let (_, mut r) = open_header(WHAT, &MAGIC, VERSION, bytes)?;
        let capacity = r.u16();
        let _reserved = r.u16();
        let header = CandidateHeader {
            capacity,
            plan_fingerprint: r.u64(),
            width: r.u32(),
            height: r.u32(),
        };
        if header.width == 0 {
            return Err(WireError::Field {
                what: WHAT,
                field: "width",
                value: 0,
            });
        }
        if header.capacity == 0 || header.capacity > u8::MAX as u16 {
            return Err(WireError::Field {
                what: WHAT,
                field: "capacity",
                value: capacity as u64,
            });
        }
        Ok(header)
    }

    /// Largest record this header allows, or `None` if it would not fit in memory addresses.
    pub fn max_record_len(&self) -> Option<usize> {
        (self.capacity as usize * CANDIDATE_LEN + PIXEL_LEN)
            .checked_mul(self.width as usize)?
            .checked_add(RECORD_OVERHEAD)
    }
}

/// Bytes the record of `pixels` takes.
pub fn record_len<const K: usize>(pixels: &[PixelCandidates<K>]) -> usize {
    RECORD_OVERHEAD
        + pixels
            .iter()
            .map(|p| PIXEL_LEN + CANDIDATE_LEN * p.candidates.len())
            .sum::<usize>()
}

/// Writes the record of row `row` into `out`; returns its length.
pub fn encode_record<const K: usize>(
    header: &CandidateHeader,
    row: u32,
    pixels: &[PixelCandidates<K>],
    out: &mut [u8],
) -> Result<usize, WireError> {
    if pixels.len() != header.width as usize {
        return Err(WireError::Field {
            what: WHAT,
            field: "width",
            value: pixels.len() as u64,
        });
    }
    if row >= header.height {
        return Err(WireError::RowOutOfRange {
            what: WHAT,
            row,
            height: header.height,
        });
    }
    // One pass for the length and the largest count (the camera's loop counts every pass).
    let (len, most) = pixels.iter().fold((RECORD_OVERHEAD, 0), |(len, most), p| {
        let n = p.candidates.len();
        (len + PIXEL_LEN + CANDIDATE_LEN * n, most.max(n))
    });
    if most > header.capacity as usize {
        // The first pixel over the capacity is the one named.
        let count = pixels
            .iter()
            .map(|p| p.candidates.len())
            .find(|&n| n > header.capacity as usize)
            .unwrap_or(most) as u64;
        return Err(WireError::Field {
            what: WHAT,
            field: "count",
            value: count,
        });
    }
    let got = out.len();
    let out = out.get_mut(..len).ok_or(WireError::BufferTooSmall {
        what: WHAT,
        needed: len,
        got,
    })?;
    let (head, mut rest) = out.split_at_mut(8);
    head[..4].copy_from_slice(&row.to_le_bytes());
    head[4..].copy_from_slice(&((len - RECORD_OVERHEAD) as u32).to_le_bytes());
    // `len` counted every pixel's bytes: each pixel and candidate goes in with one
    // fixed-size copy, not a range check per field (the camera's loop counts every
    // instruction here: `firmware/README.md`).
    for p in pixels {
        let (bytes, tail) = rest.split_at_mut(PIXEL_LEN);
        bytes.copy_from_slice(&pixel_bytes(p));
        rest = tail;
        for c in &p.candidates {
            let (bytes, tail) = rest.split_at_mut(CANDIDATE_LEN);
            bytes.copy_from_slice(&candidate_bytes(c));
            rest = tail;
        }
    }
    seal_record(out, len);
    Ok(len)
}

/// A pixel's bytes before its candidates: flags, count, noise (DN).
fn pixel_bytes<const K: usize>(p: &PixelCandidates<K>) -> [u8; PIXEL_LEN] {
    let noise = p.noise_dn.to_le_bytes();
    [
        p.flags.0,
        p.candidates.len() as u8,
        noise[0],
        noise[1],
        noise[2],
        noise[3],
    ]
}

/// A candidate's bytes: column, amplitude, block, groups, group, peak, 3 reserved zeros.
fn candidate_bytes(c: &Candidate) -> [u8; CANDIDATE_LEN] {
    let column = c.column.to_le_bytes();
    let amplitude = c.amplitude.to_le_bytes();
    let block = c.block.to_le_bytes();
    [
        column[0],
        column[1],
        column[2],
        column[3],
        amplitude[0],
        amplitude[1],
        amplitude[2],
        amplitude[3],
        block[0],
        block[1],
        c.groups.0,
        c.group.number(),
        c.peak,
        0,
        0,
        0,
    ]
}

/// A checked record: its row and its payload.
#[derive(Clone, Copy, Debug)]
pub struct CandidateRecord<'a> {
    /// Camera row.
    pub row: u32,
    payload: &'a [u8],
    /// Bytes the record took, header to CRC.
    pub len: usize,
}

/// Reads the record at the start of `bytes`: length, CRC, row range and the structure of every
/// pixel are checked before anything is returned.
pub fn decode_record<'a>(
    header: &CandidateHeader,
    bytes: &'a [u8],
) -> Result<CandidateRecord<'a>, WireError> {
    if bytes.len() < 8 {
        return Err(WireError::Truncated {
            what: WHAT,
            needed: 8,
            got: bytes.len(),
        });
    }
    let mut r = Reader::new(bytes);
    let row = r.u32();
    let payload_len = r.u32() as usize;
    let max = header.max_record_len().unwrap_or(usize::MAX) - RECORD_OVERHEAD;
    if payload_len > max {
        return Err(WireError::Field {
            what: WHAT,
            field: "payload_len",
            value: payload_len as u64,
        });
    }
    let len = payload_len + RECORD_OVERHEAD;
    if bytes.len() < len {
        return Err(WireError::Truncated {
            what: WHAT,
            needed: len,
            got: bytes.len(),
        });
    }
    let framed = &bytes[..len];
    let body = &framed[..len - RECORD_CRC_LEN];
    check_record(WHAT, header.height, row, &[body], stored_crc(framed))?;
    let record = CandidateRecord {
        row,
        payload: &body[8..],
        len,
    };
    record.walk(header, |_, _| Ok(()))?;
    Ok(record)
}

impl CandidateRecord<'_> {
    /// Decodes every pixel into `out` (length `W`); fails if a pixel has more than `K`.
    pub fn read_into<const K: usize>(
        &self,
        header: &CandidateHeader,
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), WireError> {
        if out.len() != header.width as usize {
            return Err(WireError::BufferTooSmall {
                what: WHAT,
                needed: header.width as usize,
                got: out.len(),
            });
        }
        for p in out.iter_mut() {
            p.clear();
        }
        self.walk(header, |x, item| {
            let p = &mut out[x];
            match item {
                Item::Pixel { flags, noise_dn } => {
                    p.flags = flags;
                    p.noise_dn = noise_dn;
                    Ok(())
                }
                Item::Candidate(c) => p.candidates.push(c).map_err(|_| WireError::Field {
                    what: WHAT,
                    field: "count",
                    value: K as u64 + 1,
                }),
            }
        })
    }

    /// Visits every pixel and candidate in order, checking each field.
    fn walk(
        &self,
        header: &CandidateHeader,
        mut visit: impl FnMut(usize, Item) -> Result<(), WireError>,
    ) -> Result<(), WireError> {
        let field = |field: &'static str, value: u64| WireError::Field {
            what: WHAT,
            field,
            value,
        };
        let truncated = |needed: usize| WireError::Truncated {
            what: WHAT,
            needed,
            got: self.payload.len(),
        };
        let mut r = Reader::new(self.payload);
        for x in 0..header.width as usize {
            if r.at + PIXEL_LEN > self.payload.len() {
                return Err(truncated(r.at + PIXEL_LEN));
            }
            let flags = r.u8();
            let count = r.u8();
            let noise_dn = r.f32();
            if count as u16 > header.capacity {
                return Err(field("count", count as u64));
            }
            if !noise_dn.is_finite() {
                return Err(field("noise_dn", noise_dn.to_bits() as u64));
            }
            visit(
                x,
                Item::Pixel {
                    flags: PixelFlags(flags),
                    noise_dn,
                },
            )?;
            let needed = r.at + count as usize * CANDIDATE_LEN;
            if needed > self.payload.len() {
                return Err(truncated(needed));
            }
            for _ in 0..count {
                let column = r.f32();
                let amplitude = r.f32();
                let block = r.u16();
                let groups = r.u8();
                let group = match r.u8() {
                    1 => Group::One,
                    2 => Group::Two,
                    g => return Err(field("group", g as u64)),
                };
                let peak = r.u8();
                let reserved: [u8; 3] = r.take();
                if groups == 0 || groups > 3 || groups & (1 << group.index()) == 0 {
                    return Err(field("groups", groups as u64));
                }
                if reserved != [0; 3] {
                    return Err(field("reserved", 0));
                }
                if !column.is_finite() {
                    return Err(field("column", column.to_bits() as u64));
                }
                if !amplitude.is_finite() {
                    return Err(field("amplitude", amplitude.to_bits() as u64));
                }
                let c = Candidate {
                    column,
                    amplitude,
                    groups: GroupSet(groups),
                    group,
                    peak,
                    block,
                };
                visit(x, Item::Candidate(c))?;
            }
        }
        if r.at != self.payload.len() {
            return Err(field("payload_len", self.payload.len() as u64));
        }
        Ok(())
    }
}

enum Item {
    Pixel { flags: PixelFlags, noise_dn: f32 },
    Candidate(Candidate),
}
