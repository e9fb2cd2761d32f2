//! Light-transport simulator (see the README).
