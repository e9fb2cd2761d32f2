//! Host side of the Frequency Shift Method scanner (see the README).
