//! MTL text: the input is the material library of a fixed OBJ file that uses materials a, b, c.
#![no_main]
#[path = "common.rs"]
mod common;

const OBJ: &str = "mtllib f.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
usemtl a\nf 1 2 3\nusemtl b\nf 1 3 4\nusemtl c\nf 1 2 5\n";

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let d = common::dir();
    let obj = d.join("uses_f_mtl.obj");
    if !obj.exists() {
        std::fs::write(&obj, OBJ).unwrap();
    }
    common::load("f.mtl", data, "uses_f_mtl.obj");
});
