//! Scenes for the tests: the shipped ones by name, and scenes built in code from triangles.

use ftpd3d::math::Rgb;
use ftpd3d::scene::flat::Flatland;
use ftpd3d::scene::{Material, Scene};
use ftpd3d::transport::bsdf::Bsdf;
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

/// The path of the shipped scene `name` (under `scenes/`).
pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// A scene of `triangles` over `positions` (no shading normals, an empty load report), its
/// triangles of `materials[tri_material[i]]`, built with its Embree structure; `name` stands for
/// the file it would have come from.
pub fn scene_of(
    name: &str,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    tri_material: Vec<u32>,
    materials: Vec<Material>,
) -> Scene {
    Scene::build(
        Path::new(name),
        positions,
        Vec::new(),
        triangles,
        tri_material,
        materials,
        Default::default(),
    )
    .unwrap()
}

/// `scene` rebuilt translated by `offset`.
pub fn translated(scene: &Scene, offset: Vec3) -> Scene {
    Scene::build(
        &scene.source,
        scene.positions.iter().map(|p| *p + offset).collect(),
        scene.normals.clone(),
        scene.triangles.to_vec(),
        scene.tri_material.clone(),
        scene.materials.clone(),
        Default::default(),
    )
    .unwrap()
}

/// A material named `name` that scatters by `bsdf` and emits nothing.
pub fn material(name: &str, bsdf: Bsdf) -> Material {
    Material {
        name: name.into(),
        bsdf,
        emission: Rgb::ZERO,
        maps: Default::default(),
    }
}

/// An axis-aligned box from `lo` to `hi` as 12 triangles, faces outward (or inward, for a room).
pub fn cuboid(lo: DVec3, hi: DVec3, inward: bool) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let pos = (0..8)
        .map(|i| {
            let pick = |bit: usize, a: f64, b: f64| if i & bit == 0 { a } else { b };
            DVec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            )
            .as_vec3()
        })
        .collect();
    // Counter-clockwise seen from outside.
    let quads = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    let tris = quads
        .iter()
        .flat_map(|&[a, b, c, d]| {
            if inward {
                [[a, c, b], [a, d, c]]
            } else {
                [[a, b, c], [a, c, d]]
            }
        })
        .collect();
    (pos, tris)
}

// ------------------------------------------------------------------------------------------------
// Furnaces: closed enclosures of uniform emission and albedo, where L = Le / (1 − a) exactly

/// Icosphere of unit radius with `subdiv` midpoint subdivisions (20·4^subdiv triangles), vertices
/// shared by index, every triangle wound to face the centre.
fn inward_icosphere(subdiv: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdiv {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut m = |a: u32, b: u32, v: &mut Vec<DVec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(4 * f.len());
        for [a, b, c] in f {
            let (ab, bc, ca) = (m(a, b, &mut v), m(b, c, &mut v), m(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    for t in &mut f {
        let [a, b, c] = t.map(|i| v[i as usize]);
        if (b - a).cross(c - a).dot(a + b + c) > 0.0 {
            t.swap(1, 2);
        }
    }
    (v.iter().map(|p| p.as_vec3()).collect(), f)
}

/// The furnace: a closed inward-facing icosphere (1280 triangles) of diffuse albedo `a` whose walls
/// emit `le` towards the inside.
pub fn furnace(a: f64, le: f64) -> Scene {
    let (p, t) = inward_icosphere(3);
    // Exactly closed: every directed edge appears once, and its reverse once.
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for &[a, b, c] in &t {
        for e in [(a, b), (b, c), (c, a)] {
            *edges.entry(e).or_default() += 1;
        }
    }
    assert!(
        edges
            .iter()
            .all(|(&(a, b), &k)| k == 1 && edges.get(&(b, a)) == Some(&1))
    );
    let n = t.len();
    let wall = Material {
        name: "wall".into(),
        bsdf: Bsdf::Diffuse { kd: Rgb::splat(a) },
        emission: Rgb::splat(le),
        maps: Default::default(),
    };
    let scene = scene_of("furnace", p, t, vec![0; n], vec![wall]);
    assert_eq!(scene.report.degenerate_dropped, 0);
    assert!(scene.triangles.len() >= 1000);
    // Inward: every front side faces the centre.
    for (tri, ng) in scene.triangles.iter().zip(scene.tri_normals()) {
        let c: DVec3 = tri
            .iter()
            .map(|&i| scene.positions[i as usize].as_dvec3())
            .sum();
        assert!(ng.dot(c) < 0.0);
    }
    assert_eq!(scene.lights.lights.len(), n);
    scene
}

/// The plane z = 0 spanned by x and y (what `--slice z=0` gives).
pub fn z0() -> Flatland {
    Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y)
}

/// A 2D polyline: its points, whether it is closed, its material.
pub type Path2 = (Vec<(f64, f64)>, bool, u32);

/// A scene of 2D polylines extruded along the normal of `pl` over [−1, 1]: each path is
/// (points, closed, material); every segment a → b becomes a quad facing to the right of a → b
/// (outward for counter-clockwise polygons, inward for clockwise ones).
pub fn extruded(pl: &Flatland, paths: &[Path2], materials: Vec<Material>) -> Scene {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut tri_material = Vec::new();
    for (pts, closed, m) in paths {
        let n = pts.len();
        let edges = if *closed { n } else { n - 1 };
        for k in 0..edges {
            let (a, b) = (pts[k], pts[(k + 1) % n]);
            let base = positions.len() as u32;
            for (p, z) in [(a, -1.0), (b, -1.0), (b, 1.0), (a, 1.0)] {
                let v = pl.e1 * p.0 + pl.e2 * p.1 + pl.normal * z;
                positions.push(v.as_vec3());
            }
            triangles.push([base, base + 1, base + 2]);
            triangles.push([base, base + 2, base + 3]);
            tri_material.extend([*m, *m]);
        }
    }
    scene_of("test-flat", positions, triangles, tri_material, materials)
}

/// The flatland furnace: a closed regular 64-gon, extruded, facing inward, every wall emitting
/// `le` and reflecting diffusely with albedo `a`, prepared for flatland in z = 0.
pub fn flat_furnace(le: Rgb, a: f64) -> Scene {
    let k = 64;
    // Clockwise, so that the walls face inward.
    let pts: Vec<(f64, f64)> = (0..k)
        .map(|i| {
            let t = -TAU * i as f64 / k as f64;
            (t.cos(), t.sin())
        })
        .collect();
    let wall = Material {
        name: "wall".into(),
        bsdf: Bsdf::Diffuse { kd: Rgb::splat(a) },
        emission: le,
        maps: Default::default(),
    };
    let mut scene = extruded(&z0(), &[(pts, true, 0)], vec![wall]);
    scene.prepare_flatland(z0(), "z=0").unwrap();
    scene
}

/// Render options of `spp` samples per cell in 8 batches with `seed`, on every core, quietly.
pub fn render_opts(spp: u32, seed: u64) -> ftpd3d::render::RenderOptions {
    ftpd3d::render::RenderOptions {
        spp,
        batches: 8,
        seed,
        threads: 0,
        progress: false,
        ..Default::default()
    }
}
