//! The shipped outdoor scene `scenes/courtyard/` (made by `scenes/generate_courtyard.py`): it loads
//! through its sidecar without a warning, with the sun, the sky map, its camera and named slices,
//! textured materials and alpha-masked leaf cards, and a small run of a named slice through the
//! binary gives a finite field, the same to the bit whichever instruction set Embree runs with.
//! Nothing is regenerated here.

use crate::support::scene_path;
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::load_scene;

fn courtyard() -> Scene {
    load_scene(&scene_path("courtyard/courtyard.toml")).unwrap()
}

#[test]
fn courtyard_loads_without_warnings_with_sun_sky_camera_slices_and_cutouts() {
    let scene = courtyard();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    // The run summary names the textures and their memory: four 64 × 64 8-bit images, 4 B each.
    let line = ftpd3d::cli::report::scene_line(
        std::path::Path::new("courtyard.toml"),
        &scene,
        std::time::Duration::ZERO,
    );
    assert!(line.contains("4 textures (65.5 kB)"), "{line}");
    let f = scene.features;
    assert!(f.sun, "the [[sun]]: {f}");
    assert!(f.sky, "the [environment] map: {f}");
    assert!(f.diffuse && !f.area_lights && !f.point_lights, "{f}");
    assert!(f.cutouts, "the leaf cards' map_d: {f}");
    assert!(
        scene.triangles.len() < 20_000,
        "small enough for tests: {} triangles",
        scene.triangles.len()
    );
    assert_eq!(scene.cameras.len(), 1);
    assert_eq!(scene.cameras[0].name, "arcade");
    let slices: Vec<&str> = scene.named_slices.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(slices, ["ground", "walk", "tree"]);
    // The maps are read (the files decode): colour maps on floor, stone and leaf, and the leaf's
    // coverage from its mask.
    let material = |name: &str| {
        scene
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap_or_else(|| panic!("material {name}"))
    };
    for name in ["floor", "stone", "leaf"] {
        assert!(material(name).maps.base_color.is_some(), "{name}: map_Kd");
    }
    let alpha = material("leaf").maps.alpha.as_ref().expect("leaf: map_d");
    assert!(alpha.map.is_some() && alpha.factor == 1.0);
}

/// Needs the OBJ loader's texture coordinates (`vt`): without them no map can be looked up.
#[test]
fn courtyard_has_textures_and_leaf_cards_span_their_texture() {
    let scene = courtyard();
    assert!(
        scene.features.textures,
        "floor, stone and leaves are textured: {}",
        scene.features
    );
    let leaf = scene
        .materials
        .iter()
        .position(|m| m.name == "leaf")
        .unwrap() as u32;
    let cards: Vec<u32> = (0..scene.triangles.len() as u32)
        .filter(|&t| scene.tri_material[t as usize] == leaf)
        .collect();
    assert_eq!(cards.len(), 2 * 240, "240 leaf cards of two triangles");
    for t in cards {
        for uv in scene.corner_uvs(t) {
            assert!(
                [uv.x, uv.y].iter().all(|c| *c == 0.0 || *c == 1.0),
                "leaf card corners at uv 0 or 1: {uv}"
            );
        }
    }
}

/// A tiny run of a named slice through the binary, as a user would start it: no warning, a
/// finite field, and light on the ground.
#[test]
fn courtyard_named_slice_runs_and_writes_finite_values() {
    let dir = crate::support::temp_dir("courtyard", "slice");
    let scene = scene_path("courtyard/courtyard.toml");
    let out = dir.join("ground.exr");
    let r = crate::support::ftpd3d(&[
        "--scene",
        scene.to_str().unwrap(),
        "--slice",
        "ground",
        "--res",
        "16",
        "--spp",
        "4",
        "--no-png",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(r.ok, "{}", r.err);
    assert!(
        !r.err.lines().any(|l| l.starts_with("warning: ")),
        "{}",
        r.err
    );
    let (w, h, sigma) = ftpd3d::output::exr::read_channel(&out, "ftpd").unwrap();
    assert_eq!((w, h), (16, 16));
    assert!(
        sigma.iter().all(|s| s.is_finite() && *s >= 0.0),
        "{sigma:?}"
    );
    assert!(
        sigma.iter().filter(|s| **s > 0.0).count() > w * h / 2,
        "most cells of the sunlit ground see deflected light: {sigma:?}"
    );
}

/// Every channel of every part of an EXR file: part, name and samples as bits.
type Channels = Vec<(usize, String, Vec<u64>)>;

/// The samples of every channel of every part of an EXR file, as bits, by part and name.
fn channel_bits(path: &std::path::Path) -> Channels {
    use exr::prelude::FlatSamples;
    let mut out = Vec::new();
    for (k, part) in crate::support::exr_parts(path).iter().enumerate() {
        for ch in &part.channel_data.list {
            let bits = match &ch.sample_data {
                FlatSamples::F16(v) => v.iter().map(|x| x.to_bits() as u64).collect(),
                FlatSamples::F32(v) => v.iter().map(|x| x.to_bits() as u64).collect(),
                FlatSamples::U32(v) => v.iter().map(|x| *x as u64).collect(),
            };
            out.push((k, ch.name.to_string(), bits));
        }
    }
    out
}

/// The courtyard (the shipped scene with cut-outs, textures and shading normals) run with Embree
/// forced to each instruction set this CPU has (`FTPD3D_EMBREE_CONFIG=isa=...`) gives the same
/// bits in every channel of both parts: nothing the run decides reads Embree's own barycentrics,
/// which differ in their last bits between SSE4.2 and AVX2 (the cut-out test read them, and the
/// courtyard's digest differed on a machine whose Embree picked another instruction set).
#[test]
fn courtyard_outputs_do_not_depend_on_embrees_instruction_set() {
    let mut isas = vec!["sse4.2"];
    for (isa, has) in [
        ("avx", std::arch::is_x86_feature_detected!("avx")),
        ("avx2", std::arch::is_x86_feature_detected!("avx2")),
        ("avx512", std::arch::is_x86_feature_detected!("avx512f")),
    ] {
        if has {
            isas.push(isa);
        }
    }
    if isas.len() < 2 {
        eprintln!("skipped: this CPU has no instruction set beyond SSE4.2 to compare with");
        return;
    }
    let dir = crate::support::temp_dir("courtyard", "isa");
    let scene = scene_path("courtyard/courtyard.toml");
    let mut first: Option<(String, Channels)> = None;
    let mut compared = 0;
    for isa in isas {
        let out = dir.join(format!("{isa}.exr"));
        let config = format!("isa={isa}");
        let r = crate::support::ftpd3d_with_env(
            &[
                "--scene",
                scene.to_str().unwrap(),
                "--slice",
                "y=1",
                "--res",
                "20",
                "--spp",
                "8",
                "--seed",
                "6",
                "--no-png",
                "--quiet",
                "-o",
                out.to_str().unwrap(),
            ],
            (ftpd3d::accel::EMBREE_CONFIG_VAR, &config),
        );
        if !r.ok && r.err.contains("rtcNewDevice failed") {
            // The CPU has it, the installed Embree was built without it.
            eprintln!("skipped {isa}: {}", r.err.trim());
            continue;
        }
        assert!(r.ok, "{isa}: {}", r.err);
        let bits = channel_bits(&out);
        assert!(bits.len() > 10, "{isa}: {} channels", bits.len());
        match &first {
            None => first = Some((isa.to_string(), bits)),
            Some((isa0, bits0)) => {
                for ((k, name, a), (_, _, b)) in bits0.iter().zip(&bits) {
                    assert!(a == b, "part {k} channel {name}: {isa0} and {isa} differ");
                }
                assert_eq!(bits0.len(), bits.len());
                eprintln!("{isa}: {} channels as with {isa0}", bits.len());
                compared += 1;
            }
        }
    }
    assert!(
        compared > 0 || !crate::support::in_ci(),
        "no two instruction sets of Embree could be compared"
    );
}
