//! Sidecar scene file (TOML): the input is the .toml file (`mesh = "m.obj"` names a lit quad).
#![no_main]
#[path = "common.rs"]
mod common;
libfuzzer_sys::fuzz_target!(|data: &[u8]| common::load("f.toml", data, "f.toml"));
