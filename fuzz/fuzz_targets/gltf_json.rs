//! glTF JSON: the input is the .gltf file (buffers may be data URIs, or b.bin, a quad's buffer).
#![no_main]
#[path = "common.rs"]
mod common;
libfuzzer_sys::fuzz_target!(|data: &[u8]| common::load("f.gltf", data, "f.gltf"));
