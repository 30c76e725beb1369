//! Image bytes: the input is written as `img.bin` and read as the `map_Kd`, `map_Ks` and `map_d`
//! texture of a fixed textured OBJ file (the decoder guesses PNG, JPEG, TGA, HDR or EXR from the
//! content), so every codec the loader enables sees it.
#![no_main]
#[path = "common.rs"]
mod common;

const OBJ: &str = "mtllib img.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3 4/4\n";
const MTL: &str = "newmtl a\nKd 1 1 1\nKs 0.2 0.2 0.2\nNs 20\nmap_Kd img.bin\nmap_Ks img.bin\n\
map_d img.bin\n";

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let d = common::dir();
    let obj = d.join("uses_img.obj");
    if !obj.exists() {
        std::fs::write(&obj, OBJ).unwrap();
        std::fs::write(d.join("img.mtl"), MTL).unwrap();
    }
    common::load("img.bin", data, "uses_img.obj");
});
