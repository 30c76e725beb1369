//! MTL text with texture maps: the input is the material library of a fixed OBJ file with texture
//! coordinates that uses materials a and b; the scratch directory holds a valid RGBA PNG `t.png`
//! and a truncated one `bad.png` for `map_Kd`, `map_Ks` and `map_d` statements to name.
#![no_main]
#[path = "common.rs"]
mod common;

const OBJ: &str = "mtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/4\nf 1 2 5\n";

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let d = common::dir();
    let obj = d.join("uses_tex_mtl.obj");
    if !obj.exists() {
        std::fs::write(&obj, OBJ).unwrap();
    }
    common::load("tex.mtl", data, "uses_tex_mtl.obj");
});
