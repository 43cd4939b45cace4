//! The integration tests that run on the simulated clock, or on no clock:
//! each file of `tests/` named below is a module (Cargo.toml says why the
//! tests are four binaries). `cargo test --test suite wire::` runs one
//! file's tests.
#[macro_use]
mod common;

mod analysis;
mod analysis_against_logs;
mod analysis_sync;
mod cli_render;
mod closed_output;
mod design_values;
mod discrimination;
mod engine;
mod friction_core;
mod gui_results;
mod identify;
mod interruptions;
mod kind_columns;
mod layers;
mod magnitude_scaling;
mod numbers;
mod power;
mod protocols;
mod rerender;
mod seed000_god_object;
mod seed001_nakano;
mod seed002_dahl;
mod seed002_karnopp;
mod sessions;
mod sim_participants;
mod validation;
mod wire;
