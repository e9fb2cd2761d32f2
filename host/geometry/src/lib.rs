//! Camera and projector geometry (SPEC §5).
