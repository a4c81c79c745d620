//! haze's integration tests, compiled as one binary with shared helpers in `common`.

mod analytic;
mod bad_scenes;
mod cli;
mod common;
mod converge;
mod determinism;
mod kernel;
mod media;
mod output;
mod sampling;
mod scenes;
mod schedule;
mod stability;
mod validation;
mod vdb;
