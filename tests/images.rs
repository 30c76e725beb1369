//! Images a scene names, as users' downloads have them: percent-encoded glTF URIs, missing and
//! unreadable images (a warning naming the image and the material, which keeps its factors),
//! KTX2 (Basis Universal) images, FIFOs and directories where files belong, negative float
//! texels, and the smaller cases of MTL files (map names with spaces, `map_d` channels, Kd > 1)
//! and OBJ files (line continuation, UTF-16).

use crate::gltf::{Bin, textured_quad};
use crate::support::temp_dir;
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::load_scene;
use glam::DVec3;
use serde_json::json;
use std::path::Path;
use std::time::{Duration, Instant};

fn srgb(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A PNG file of one grey texel.
fn grey_png(path: &Path, level: u8) {
    image::GrayImage::from_raw(1, 1, vec![level])
        .unwrap()
        .save(path)
        .unwrap();
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo {}", path.display());
}

/// The unit quad in z = 0 with material 'Lamp' (emissiveFactor 2, its emissiveTexture the
/// document's texture 0): `textures`, `images` and `required` as given.
fn lamp_gltf(
    dir: &Path,
    name: &str,
    textures: serde_json::Value,
    images: serde_json::Value,
    required: &[&str],
) -> std::path::PathBuf {
    let mut bin = Bin::default();
    let (pos, uv, idx) = textured_quad(&mut bin);
    let extra = json!({
        "extensionsUsed": required,
        "extensionsRequired": required,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": 0}]}],
        "materials": [{"name": "Lamp", "emissiveFactor": [2.0, 2.0, 2.0],
            "emissiveTexture": {"index": 0},
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}}],
        "textures": textures,
        "images": images,
    });
    bin.write_embedded(dir, name, extra)
}

/// The emission seen at the quad's centre.
fn emitted(scene: &Scene) -> f64 {
    let hit = scene
        .intersect(DVec3::new(0.5, 0.5, 1.0), -DVec3::Z, f64::INFINITY)
        .unwrap();
    scene.emitted(&hit, DVec3::Z).x
}

/// A percent-encoded URI (`my%20tex.png`) names the file `my tex.png`; a missing image and a KTX2
/// (Basis Universal) image that this build does not decode each leave a warning naming the image
/// and the material, whose emission falls back to its factor (2), and refuse nothing; a FIFO
/// named as an image is refused at once, naming it, without being opened.
#[test]
fn gltf_images_percent_decoded_or_warned_about_with_factor_fallback() {
    let dir = temp_dir("images", "gltf_images");
    grey_png(&dir.join("my tex.png"), 128);
    let simple = json!([{"source": 0}]);
    let path = lamp_gltf(
        &dir,
        "encoded.gltf",
        simple.clone(),
        json!([{"uri": "my%20tex.png"}]),
        &[],
    );
    let scene = load_scene(&path).unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    assert!((emitted(&scene) - 2.0 * srgb(128.0 / 255.0)).abs() < 1e-6);

    let check_fallback = |path: &Path, image: &str, why: &str| {
        let t = Instant::now();
        let scene = load_scene(path).unwrap();
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "{image}: {:?}",
            t.elapsed()
        );
        let w = scene.report.warnings.join("\n");
        assert!(
            w.contains(image) && w.contains(why) && w.contains("material 'Lamp'"),
            "{image}: {w}"
        );
        assert_eq!(emitted(&scene), 2.0, "{image}: the factor alone");
    };
    let path = lamp_gltf(
        &dir,
        "missing.gltf",
        simple.clone(),
        json!([{"uri": "gone.png"}]),
        &[],
    );
    check_fallback(&path, "gone.png", "cannot open");

    // KHR_texture_basisu, required, with no fallback source: the texture's image is the KTX2 one.
    let mut ktx2 = b"\xABKTX 20\xBB\r\n\x1A\n".to_vec();
    ktx2.extend([0u8; 68]);
    std::fs::write(dir.join("t.ktx2"), ktx2).unwrap();
    let path = lamp_gltf(
        &dir,
        "basisu.gltf",
        json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]),
        json!([{"uri": "t.ktx2", "mimeType": "image/ktx2"}]),
        &["KHR_texture_basisu"],
    );
    check_fallback(&path, "t.ktx2", "KTX2");

    #[cfg(unix)]
    {
        mkfifo(&dir.join("pipe.png"));
        let path = lamp_gltf(&dir, "fifo.gltf", simple, json!([{"uri": "pipe.png"}]), &[]);
        let t = Instant::now();
        let msg = format!("{:#}", load_scene(&path).err().unwrap());
        assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
        assert!(
            msg.contains("fifo.gltf") && msg.contains("pipe.png") && msg.contains("FIFO"),
            "{msg}"
        );
    }
}

/// A scene file that is a FIFO or a directory is refused at once, naming it and what it is; so
/// is a FIFO named as an OBJ texture, naming it and its material.
#[cfg(unix)]
#[test]
fn fifos_and_directories_are_refused_before_they_are_opened() {
    let dir = temp_dir("images", "fifo");
    for name in ["model.obj", "model.gltf"] {
        let p = dir.join(name);
        mkfifo(&p);
        let t = Instant::now();
        let e = load_scene(&p).err().unwrap();
        assert!(t.elapsed() < Duration::from_secs(20));
        let msg = format!("{e:#}");
        assert!(msg.contains(name) && msg.contains("FIFO"), "{msg}");
    }
    let sub = dir.join("folder.obj");
    std::fs::create_dir(&sub).unwrap();
    let msg = format!("{:#}", load_scene(&sub).err().unwrap());
    assert!(
        msg.contains("folder.obj") && msg.contains("directory"),
        "{msg}"
    );

    mkfifo(&dir.join("pipe.png"));
    std::fs::write(
        dir.join("m.mtl"),
        "newmtl Wall\nKd 0.5 0.5 0.5\nmap_Kd pipe.png\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl Wall\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let t = Instant::now();
    let msg = format!("{:#}", load_scene(&dir.join("quad.obj")).err().unwrap());
    assert!(t.elapsed() < Duration::from_secs(20));
    assert!(
        msg.contains("quad.obj")
            && msg.contains("pipe.png")
            && msg.contains("FIFO")
            && msg.contains("'Wall'"),
        "{msg}"
    );
}

/// An OBJ whose `map_Kd` is a float EXR with negative and NaN texels: they become 0, with a
/// warning that names the file and counts them, so no albedo (and no fluence) is negative.
#[test]
fn negative_exr_texture_is_cleared_with_a_warning() {
    use exr::prelude::*;
    let dir = temp_dir("images", "negative_exr");
    let (w, h) = (4usize, 2usize);
    write_rgb_file(dir.join("neg.exr"), w, h, |x, y| {
        let k = y * w + x;
        match k {
            1 => (-0.5f32, 0.2, 0.2),
            6 => (0.3, f32::NAN, 0.3),
            _ => (0.25, 0.5, 0.75),
        }
    })
    .unwrap();
    std::fs::write(dir.join("m.mtl"), "newmtl Wall\nmap_Kd neg.exr\n").unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl Wall\n\
         f 1/1 2/2 3/3\n",
    )
    .unwrap();
    let scene = load_scene(&dir.join("quad.obj")).unwrap();
    let warning = scene.report.warnings.join("\n");
    assert!(
        warning.contains("neg.exr") && warning.contains("2 of 8 texels"),
        "{warning}"
    );
    let t = &scene.textures.textures[0];
    for i in 0..w * h {
        assert!(
            t.texel(i).iter().all(|c| *c >= 0.0 && c.is_finite()),
            "texel {i}"
        );
    }
    assert_eq!(t.texel(1)[0], 0.0);
    assert_eq!(t.texel(6)[1], 0.0);
}

/// The smaller MTL and OBJ cases: a map name with spaces after options; `map_d` on an opaque RGBA
/// image reads its alpha channel, on an RGB image its red channel with a warning; Kd > 1 is
/// clamped with a warning; `\` continues an OBJ line; a UTF-16 OBJ is refused by name.
#[test]
fn mtl_and_obj_details_are_read_or_named() {
    let dir = temp_dir("images", "mtl_details");
    grey_png(&dir.join("my wood.png"), 200);
    image::RgbaImage::from_raw(1, 1, vec![10, 20, 30, 255])
        .unwrap()
        .save(dir.join("opaque.png"))
        .unwrap();
    image::RgbImage::from_raw(1, 1, vec![10, 200, 30])
        .unwrap()
        .save(dir.join("rgb.png"))
        .unwrap();
    image::RgbImage::from_raw(1, 1, vec![90, 90, 90])
        .unwrap()
        .save(dir.join("grey_rgb.png"))
        .unwrap();
    std::fs::write(
        dir.join("m.mtl"),
        "newmtl Wood\nmap_Kd -s 1 1 1 my wood.png\n\
         newmtl Leaf\nKd 0.5 0.5 0.5\nmap_d opaque.png\n\
         newmtl Mask\nKd 0.5 0.5 0.5\nmap_d rgb.png\n\
         newmtl Bright\nKd 1.5 \\\n 0.2 0.2\n\
         newmtl GreyMask\nKd 0.5 0.5 0.5\nmap_d grey_rgb.png\n",
    )
    .unwrap();
    let mut obj = String::from("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 \\\n 0\n");
    obj.push_str("vt 0 0\nvt 1 0\nvt 1 1\n");
    for m in ["Wood", "Leaf", "Mask", "Bright", "GreyMask"] {
        obj.push_str(&format!("usemtl {m}\nf 1/1 2/2 \\\n  3/3\n"));
    }
    obj.push_str("f 1 3 4\n");
    std::fs::write(dir.join("scene.obj"), &obj).unwrap();
    let scene = load_scene(&dir.join("scene.obj")).unwrap();
    let w = scene.report.warnings.join("\n");
    // Five continued faces and the last one, which reaches the continued fourth vertex.
    assert_eq!(scene.triangles.len(), 6, "{w}");
    assert!(
        scene
            .positions
            .iter()
            .any(|p| p.x == 0.0 && p.y == 1.0 && p.z == 0.0),
        "the fourth vertex joined its line"
    );
    let by_name = |n: &str| scene.materials.iter().find(|m| m.name == n).unwrap();
    assert!(by_name("Wood").maps.base_color.is_some(), "{w}");
    assert_eq!(by_name("Leaf").maps.alpha.as_ref().unwrap().channel, 3);
    assert_eq!(by_name("Mask").maps.alpha.as_ref().unwrap().channel, 0);
    assert!(w.contains("rgb.png") && w.contains("red channel"), "{w}");
    assert!(
        !w.contains("grey_rgb.png"),
        "a grey RGB mask has one value to read: {w}"
    );
    assert_eq!(by_name("GreyMask").maps.alpha.as_ref().unwrap().channel, 0);
    assert!(w.contains("'Bright'") && w.contains("Kd exceeds 1"), "{w}");
    // The MTL's continued Kd line: its three numbers read across the backslash.
    assert!(
        format!("{:?}", by_name("Bright").bsdf).contains("0.2"),
        "{:?}",
        by_name("Bright").bsdf
    );

    let utf16: Vec<u8> = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        .encode_utf16()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let with_bom = [&[0xFF, 0xFE][..], &utf16].concat();
    for (name, bytes) in [("bom.obj", with_bom), ("plain.obj", utf16)] {
        std::fs::write(dir.join(name), bytes).unwrap();
        let msg = format!("{:#}", load_scene(&dir.join(name)).err().unwrap());
        assert!(msg.contains(name) && msg.contains("UTF-16"), "{msg}");
    }
}
