//! haze's integration tests, compiled as one binary with shared helpers in `common`.

mod analytic;
mod api;
mod bad_scenes;
mod bias;
mod budget;
mod cli;
mod common;
mod converge;
mod determinism;
mod distributed;
mod environment;
mod fuzz_corpus;
mod independent;
mod layers;
mod media;
mod output;
mod references;
mod reliability;
mod sampling;
mod scenes;
mod stability;
mod tiles;
mod validation;
mod vdb;
