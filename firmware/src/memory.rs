//! The camera's buffers: one static [`Storage`] on the target, the same sizes allocated once
//! on the host (the emulator, tests); the loop only ever sees [`Memory`], borrowed slices.

use crate::limits::*;

/// Every buffer the loop uses, borrowed.
pub struct Memory<'m> {
    /// Decoder tables of the loaded plan (`Decoder::tables_len` floats used).
    pub tables: &'m mut [f32],
    /// Decoder scratch, reused from pixel to pixel.
    pub scratch: &'m mut [f32],
    /// Samples of the slice of the current row being decoded, sample-major (`frames[i·S + x]`
    /// for a slice of `S` pixels; `scan::decode_row`).
    pub samples: &'m mut [u16],
    /// Candidates of every pixel of the current row.
    pub pixels: &'m mut [Pixel],
    /// The record being sent: candidates, or a raw row.
    pub record: &'m mut [u8],
    /// The request frame being received.
    pub rx: &'m mut [u8],
    /// The response frame being sent.
    pub tx: &'m mut [u8],
}

/// Bytes of all buffers together ([`Storage`]).
pub const MEMORY_BYTES: usize = core::mem::size_of::<Storage>();

/// The buffers as one statically sized block (in `.bss` on the target).
pub struct Storage {
    tables: [f32; MAX_TABLE_FLOATS],
    scratch: [f32; MAX_SCRATCH_FLOATS],
    samples: [u16; SLICE_SAMPLES],
    pixels: [Pixel; MAX_WIDTH],
    record: [u8; MAX_RECORD],
    rx: [u8; MAX_REQUEST_FRAME],
    tx: [u8; MAX_RESPONSE_FRAME],
}

impl Storage {
    /// Zeroed buffers (a `static` initialiser).
    #[allow(clippy::new_without_default)] // far too large for the stack: only for statics
    pub const fn new() -> Self {
        Storage {
            tables: [0.0; MAX_TABLE_FLOATS],
            scratch: [0.0; MAX_SCRATCH_FLOATS],
            samples: [0; SLICE_SAMPLES],
            pixels: [const { Pixel::new() }; MAX_WIDTH],
            record: [0; MAX_RECORD],
            rx: [0; MAX_REQUEST_FRAME],
            tx: [0; MAX_RESPONSE_FRAME],
        }
    }

    /// Borrows every buffer.
    pub fn memory(&mut self) -> Memory<'_> {
        Memory {
            tables: &mut self.tables,
            scratch: &mut self.scratch,
            samples: &mut self.samples,
            pixels: &mut self.pixels,
            record: &mut self.record,
            rx: &mut self.rx,
            tx: &mut self.tx,
        }
    }
}

/// The same buffers on the host, allocated once (the emulator has the camera's limits).
#[cfg(not(target_os = "none"))]
pub struct HostStorage {
    tables: Vec<f32>,
    scratch: Vec<f32>,
    samples: Vec<u16>,
    pixels: Vec<Pixel>,
    record: Vec<u8>,
    rx: Vec<u8>,
    tx: Vec<u8>,
}

#[cfg(not(target_os = "none"))]
impl Default for HostStorage {
    fn default() -> Self {
        HostStorage {
            tables: vec![0.0; MAX_TABLE_FLOATS],
            scratch: vec![0.0; MAX_SCRATCH_FLOATS],
            samples: vec![0; SLICE_SAMPLES],
            pixels: vec![Pixel::new(); MAX_WIDTH],
            record: vec![0; MAX_RECORD],
            rx: vec![0; MAX_REQUEST_FRAME],
            tx: vec![0; MAX_RESPONSE_FRAME],
        }
    }
}

#[cfg(not(target_os = "none"))]
impl HostStorage {
    /// Borrows every buffer.
    pub fn memory(&mut self) -> Memory<'_> {
        Memory {
            tables: &mut self.tables,
            scratch: &mut self.scratch,
            samples: &mut self.samples,
            pixels: &mut self.pixels,
            record: &mut self.record,
            rx: &mut self.rx,
            tx: &mut self.tx,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_bytes_is_the_buffers() {
        let mut host = HostStorage::default();
        let m = host.memory();
        let bytes = m.tables.len() * 4
            + m.scratch.len() * 4
            + m.samples.len() * 2
            + core::mem::size_of_val(&*m.pixels)
            + m.record.len()
            + m.rx.len()
            + m.tx.len();
        // The same buffers, up to the alignment padding between them.
        assert!(
            bytes <= MEMORY_BYTES && MEMORY_BYTES < bytes + 16,
            "{bytes} {MEMORY_BYTES}"
        );
    }
}
