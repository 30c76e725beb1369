//! Binary glTF: the input is the .glb file.
#![no_main]
#[path = "common.rs"]
mod common;
libfuzzer_sys::fuzz_target!(|data: &[u8]| common::load("f.glb", data, "f.glb"));
