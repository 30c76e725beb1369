//! The shipped outdoor scene `scenes/courtyard/` (made by `scenes/generate_courtyard.py`): it loads
//! through its sidecar without a warning, with the sun, the sky map, its camera and named slices,
//! textured materials and alpha-masked leaf cards, and a small run of a named slice through the
//! binary gives a finite field. Nothing is regenerated here.

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
