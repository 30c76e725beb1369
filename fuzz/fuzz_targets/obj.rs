//! OBJ text: the input is the .obj file (it may name m.mtl, or other files).
#![no_main]
#[path = "common.rs"]
mod common;
libfuzzer_sys::fuzz_target!(|data: &[u8]| common::load("f.obj", data, "f.obj"));
