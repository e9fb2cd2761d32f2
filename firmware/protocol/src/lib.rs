//! Host ⇄ camera protocol.
