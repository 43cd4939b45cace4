//! Test-only crate: Haply's own Rust client (`haply` 1.3.1) as the peer of
//! frictionlab's Inverse3 driver and emulated Inverse Service (issue 43).
//! The tests are in `tests/`.
