//! Shared by the fuzz targets: a scratch directory per process holding the files that inputs may
//! refer to, and a loader call that writes the input under a given name first.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A quad at y = 0 with a small area light above it, for inputs that name a mesh.
const MESH_OBJ: &str = "mtllib m.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n\
v -0.1 1 -0.1\nv 0.1 1 -0.1\nv 0.1 1 0.1\nv -0.1 1 0.1\n\
usemtl floor\nf 1 4 3 2\nusemtl light\nf 5 6 7 8\n";
const MESH_MTL: &str = "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0 0 0\nKe 5 5 5\n";

/// The binary buffer of a quad: 4 VEC3 f32 positions, then 6 u16 indices (0 1 2 0 2 3), padded to
/// 60 bytes (positions at 0..48, indices at 48..60).
fn quad_bin() -> Vec<u8> {
    let mut b = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for x in p {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// A 2 × 2 RGBA PNG (opaque and transparent texels), for texture maps to name.
const RGBA_PNG: &[u8] = include_bytes!("../seeds/image/rgba_2x2.png");

/// This process's scratch directory, with `m.obj`, `m.mtl`, `b.bin`, `t.png` and `bad.png` in it.
pub fn dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("ftpd3d-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("m.obj"), MESH_OBJ).unwrap();
        std::fs::write(d.join("m.mtl"), MESH_MTL).unwrap();
        std::fs::write(d.join("b.bin"), quad_bin()).unwrap();
        std::fs::write(d.join("t.png"), RGBA_PNG).unwrap();
        std::fs::write(d.join("bad.png"), &RGBA_PNG[..RGBA_PNG.len() / 2]).unwrap();
        d
    })
}

/// Writes `data` as `name` in the scratch directory and loads `load` (which may be another file
/// there) as a scene: any error is fine, a panic is a finding.
pub fn load(name: &str, data: &[u8], load: &str) {
    let d = dir();
    std::fs::write(d.join(name), data).unwrap();
    let _ = ftpd3d::scene::load::load_scene(&d.join(load));
}
