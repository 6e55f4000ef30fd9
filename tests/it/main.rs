//! The integration tests: one crate (one link of the library, one build of `common/`), one
//! module per subject. `cargo test --test it SUBJECT::` runs one subject, e.g. `policy::` or
//! `reliability::graphs::`.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "tests and their helpers fail loudly"
)]
#![allow(
    clippy::format_collect,
    reason = "expected text and fixtures built line by line read clearer than a fold with write!"
)]
#![allow(
    clippy::float_cmp,
    reason = "numpy's streams and minigrid's calls are compared bit for bit"
)]

mod common;

// The debugger (`app` feature): its UI through egui's test harness, levels, reports.
#[cfg(feature = "app")]
mod app;
mod bench;
mod bot;
mod cli;
mod env;
mod links;
// ONNX import (`onnx` feature): imported graphs and their faithfulness.
#[cfg(feature = "onnx")]
mod onnx;
mod policy;
mod record;
mod reliability;
mod report;
mod study;
mod study_reliability;
mod study_reliability2;
mod study_typed;
mod train;
mod vendor;
