//! Frames: one message per frame, `0x00 COBS(version ‖ postcard message ‖ CRC-32) 0x00`.
//!
//! COBS removes every zero byte from the frame's content, so a zero always ends a frame and a
//! receiver that lost bytes resynchronises at the next one. The leading zero (an empty frame,
//! skipped by receivers) ends whatever a truncated previous frame left behind, so that
//! damage to one frame never costs the next one. The CRC-32 (ISO-HDLC, the one of
//! `fsm_core::wire::crc32`, little-endian) covers the version byte and the message; a frame
//! whose CRC, COBS structure, version or message does not check is rejected as a whole.

use core::fmt;

use postcard::ser_flavors::{crc::CrcModifier, Cobs, Slice};
use serde::{Deserialize, Serialize};

use crate::PROTOCOL_VERSION;

/// The frame delimiter.
pub const DELIMITER: u8 = 0;
/// Bytes a frame adds around its message before COBS: version (1) and CRC (4).
pub const FRAME_OVERHEAD: usize = 5;

/// CRC-32/ISO-HDLC, streaming (postcard's CRC flavor needs a digest).
static CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Why a frame was rejected (or could not be written).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FrameError {
    /// The frame is longer than the receive buffer (or the output buffer, when writing).
    TooLong {
        /// Bytes the buffer holds.
        limit: u32,
    },
    /// The bytes are not valid COBS.
    Cobs,
    /// Fewer bytes than a version, a message and a CRC.
    TooShort {
        /// Decoded bytes.
        len: u32,
    },
    /// The CRC does not match the frame's bytes.
    Crc {
        /// CRC in the frame.
        stored: u32,
        /// CRC of the bytes received.
        computed: u32,
    },
    /// Another protocol version.
    Version {
        /// Version in the frame.
        got: u8,
        /// The version this build speaks.
        supported: u8,
    },
    /// The content is not a message of this protocol (unknown tag, bad field, bytes left over).
    Message,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            FrameError::TooLong { limit } => write!(f, "frame longer than {limit} bytes"),
            FrameError::Cobs => write!(f, "frame is not valid COBS"),
            FrameError::TooShort { len } => write!(
                f,
                "frame of {len} bytes is too short for a version, a message and a CRC"
            ),
            FrameError::Crc { stored, computed } => write!(
                f,
                "frame corrupted (CRC stored {stored:08x}, computed {computed:08x})"
            ),
            FrameError::Version { got, supported } => write!(
                f,
                "protocol version {got} is not supported (this side speaks version {supported})"
            ),
            FrameError::Message => write!(f, "frame does not hold a message of this protocol"),
        }
    }
}

/// Longest frame (both delimiters included) of a message whose postcard encoding has
/// `message_len` bytes: COBS adds one byte per 254 and one more.
pub const fn max_frame_len(message_len: usize) -> usize {
    let content = message_len + FRAME_OVERHEAD;
    1 + content + content / 254 + 1 + 1
}

/// Writes the frame of `message` into `out`; returns its length (delimiters included).
pub fn encode<T: Serialize + ?Sized>(message: &T, out: &mut [u8]) -> Result<usize, FrameError> {
    let limit = out.len() as u32;
    let too_long = FrameError::TooLong { limit };
    let (lead, rest) = out.split_first_mut().ok_or(too_long)?;
    *lead = DELIMITER;
    let cobs = Cobs::try_new(Slice::new(rest)).map_err(|_| too_long)?;
    let flavor = CrcModifier::new(cobs, CRC32.digest());
    match postcard::serialize_with_flavor(&(PROTOCOL_VERSION, message), flavor) {
        Ok(frame) => Ok(1 + frame.len()),
        Err(postcard::Error::SerializeBufferFull) => Err(too_long),
        Err(_) => Err(FrameError::Message),
    }
}

/// The frame of `message` as a new vector.
#[cfg(feature = "std")]
pub fn encode_vec<T: Serialize + ?Sized>(message: &T) -> Result<Vec<u8>, FrameError> {
    use postcard::ser_flavors::AllocVec;
    let cobs = Cobs::try_new(AllocVec::new()).map_err(|_| FrameError::Message)?;
    let flavor = CrcModifier::new(cobs, CRC32.digest());
    let mut frame = postcard::serialize_with_flavor(&(PROTOCOL_VERSION, message), flavor)
        .map_err(|_| FrameError::Message)?;
    frame.insert(0, DELIMITER);
    Ok(frame)
}

/// Checks a frame's content (delimiter removed, still COBS-encoded) in place and returns its
/// message bytes.
pub fn open(frame: &mut [u8]) -> Result<&[u8], FrameError> {
    let message = open_range(frame)?;
    Ok(&frame[message])
}

/// [`open`], returning where the message lies in `frame`.
fn open_range(frame: &mut [u8]) -> Result<core::ops::Range<usize>, FrameError> {
    let len = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let content = &frame[..len];
    if len < FRAME_OVERHEAD + 1 {
        return Err(FrameError::TooShort { len: len as u32 });
    }
    let (checked, crc) = content.split_at(len - 4);
    let stored = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    let computed = fsm_core::wire::crc32(checked);
    if stored != computed {
        return Err(FrameError::Crc { stored, computed });
    }
    if checked[0] != PROTOCOL_VERSION {
        return Err(FrameError::Version {
            got: checked[0],
            supported: PROTOCOL_VERSION,
        });
    }
    Ok(1..len - 4)
}

/// Decodes the message bytes of a checked frame; every byte must belong to the message.
pub fn decode<'a, T: Deserialize<'a>>(message: &'a [u8]) -> Result<T, FrameError> {
    match postcard::take_from_bytes::<T>(message) {
        Ok((value, [])) => Ok(value),
        _ => Err(FrameError::Message),
    }
}

/// Collects received bytes into frames, in a buffer the caller provides (a static one on the
/// camera). A frame longer than the buffer is skipped up to its delimiter and reported.
#[derive(Debug)]
pub struct FrameReader<B> {
    buf: B,
    len: usize,
    overflow: bool,
    /// The last push ended a frame: start afresh on the next.
    ended: bool,
    /// The checked message of the last frame, within `buf`.
    message: core::ops::Range<usize>,
}

impl<B: AsMut<[u8]> + AsRef<[u8]>> FrameReader<B> {
    /// A reader that holds frames of up to `buf.len()` bytes (delimiter excluded).
    pub fn new(buf: B) -> Self {
        FrameReader {
            buf,
            len: 0,
            overflow: false,
            ended: false,
            message: 0..0,
        }
    }

    /// Takes bytes up to and including the next delimiter. Returns how many bytes it took
    /// and, if they ended a frame, whether the frame checked (its message is then
    /// [`FrameReader::message`]) or why it was rejected. Empty frames (two delimiters in a
    /// row) are skipped.
    pub fn push(&mut self, bytes: &[u8]) -> (usize, Option<Result<(), FrameError>>) {
        if self.ended {
            self.len = 0;
            self.overflow = false;
            self.ended = false;
            self.message = 0..0;
        }
        let end = bytes.iter().position(|&b| b == DELIMITER);
        let data = &bytes[..end.unwrap_or(bytes.len())];
        let buf = self.buf.as_mut();
        if !self.overflow {
            match buf.get_mut(self.len..self.len + data.len()) {
                Some(dst) => {
                    dst.copy_from_slice(data);
                    self.len += data.len();
                }
                None => self.overflow = true,
            }
        }
        let Some(end) = end else {
            return (bytes.len(), None);
        };
        self.ended = true;
        let taken = end + 1;
        if self.overflow {
            let limit = buf.len() as u32;
            return (taken, Some(Err(FrameError::TooLong { limit })));
        }
        if self.len == 0 {
            return (taken, None);
        }
        match open_range(&mut buf[..self.len]) {
            Ok(range) => {
                self.message = range;
                (taken, Some(Ok(())))
            }
            Err(e) => (taken, Some(Err(e))),
        }
    }

    /// The message bytes of the last frame that checked (empty before one did, and after
    /// the next push).
    pub fn message(&self) -> &[u8] {
        &self.buf.as_ref()[self.message.clone()]
    }

    /// Bytes of an unfinished frame held so far.
    pub fn pending(&self) -> usize {
        if self.ended {
            0
        } else {
            self.len
        }
    }

    /// Whether a frame has begun and not ended (one too long to hold included).
    pub fn in_frame(&self) -> bool {
        !self.ended && (self.len > 0 || self.overflow)
    }

    /// Most bytes of a frame it holds.
    pub fn capacity(&self) -> usize {
        self.buf.as_ref().len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::Request;

    #[test]
    fn crc_is_the_one_of_core() {
        let bytes: [u8; 9] = *b"123456789";
        assert_eq!(CRC32.checksum(&bytes), fsm_core::wire::crc32(&bytes));
        assert_eq!(fsm_core::wire::crc32(&bytes), 0xCBF4_3926);
    }

    #[test]
    fn frame_layout() {
        // Hello is tag 0: content = [version 1, tag 0, crc32 of [1, 0] LE].
        let mut out = [0u8; 32];
        let n = encode(&Request::Hello, &mut out).unwrap();
        let crc = fsm_core::wire::crc32(&[PROTOCOL_VERSION, 0]).to_le_bytes();
        let mut content = vec![PROTOCOL_VERSION, 0];
        content.extend_from_slice(&crc);
        let mut expected = vec![0u8; max_frame_len(1)];
        let m = cobs::encode(&content, &mut expected[1..]);
        expected.truncate(1 + m);
        expected.push(0);
        assert_eq!(&out[..n], &expected[..]);
        assert!(n <= max_frame_len(1));
    }

    #[test]
    fn reader_resynchronises_after_an_overlong_frame() {
        let mut frame = [0u8; 32];
        let n = encode(&Request::EndScan, &mut frame).unwrap();
        let mut stream = vec![7u8; 40];
        stream.push(0);
        stream.extend_from_slice(&frame[..n]);
        let mut reader = FrameReader::new([0u8; 16]);
        let (taken, got) = reader.push(&stream);
        assert_eq!(taken, 41);
        assert_eq!(got, Some(Err(FrameError::TooLong { limit: 16 })));
        // The frame's leading delimiter is an empty frame, skipped.
        let (lead, got) = reader.push(&stream[taken..]);
        assert_eq!((lead, got), (1, None));
        let (taken2, got) = reader.push(&stream[taken + 1..]);
        assert_eq!(taken2, n - 1);
        assert_eq!(got, Some(Ok(())));
        assert_eq!(decode::<Request>(reader.message()), Ok(Request::EndScan));
    }
}
