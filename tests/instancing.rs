//! EXT_mesh_gpu_instancing as Embree instances of one prototype: the same scene loaded with
//! instances and flattened (one copy per instance, `LoadOptions::flatten_instances`) must give the
//! same hits (positions, geometric and shading normals, materials, texture coordinates) under
//! rotation, non-uniform scale and mirroring, and the same field.

use crate::support::temp_dir;
use base64::Engine as _;
use ftpd3d::math::Rgb;
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::{LoadOptions, load_scene_with};
use glam::{DMat3, DQuat, DVec3};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// A square pyramid (base 1 × 1 at y = 0, apex at y = 1) with smooth per-vertex normals (away from
/// its centre, so that shading normals differ from the geometric ones) and texture coordinates:
/// positions, normals, uvs, and 6 triangles (4 sides, 2 for the base).
#[allow(clippy::type_complexity)]
fn pyramid() -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[f32; 2]>, Vec<u16>) {
    let p = vec![
        [-0.5, 0.0, -0.5],
        [0.5, 0.0, -0.5],
        [0.5, 0.0, 0.5],
        [-0.5, 0.0, 0.5],
        [0.0, 1.0, 0.0],
    ];
    let n = p
        .iter()
        .map(|v: &[f32; 3]| {
            let d = DVec3::new(v[0] as f64, v[1] as f64 - 0.4, v[2] as f64).normalize();
            d.as_vec3().to_array()
        })
        .collect();
    let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]];
    // Counter-clockwise seen from outside.
    let idx = vec![0, 4, 1, 1, 4, 2, 2, 4, 3, 3, 4, 0, 0, 1, 2, 0, 2, 3];
    (p, n, uv, idx)
}

/// One instance: translation, rotation (x, y, z, w) and scale, as the extension stores them.
type Placement = ([f32; 3], [f32; 4], [f32; 3]);

/// The instances the tests place: plain, turned about a slanted axis with non-uniform scale,
/// mirrored (negative x scale) and turned, and scaled flat and tilted.
fn placements() -> Vec<Placement> {
    let q = |axis: DVec3, angle: f64| {
        let q = DQuat::from_axis_angle(axis.normalize(), angle);
        [q.x as f32, q.y as f32, q.z as f32, q.w as f32]
    };
    vec![
        ([-1.5, 0.0, -1.5], [0.0, 0.0, 0.0, 1.0], [1.0, 1.0, 1.0]),
        (
            [1.5, 0.2, -1.5],
            q(DVec3::new(1.0, 2.0, 0.5), 0.7),
            [1.6, 0.6, 1.1],
        ),
        (
            [-1.5, 0.0, 1.5],
            q(DVec3::new(0.0, 1.0, 0.0), 0.4),
            [-1.0, 1.3, 0.8],
        ),
        (
            [1.5, 0.3, 1.5],
            q(DVec3::new(1.0, 0.0, 0.3), -0.5),
            [0.7, 1.8, 1.4],
        ),
    ]
}

fn le<T: Copy, const N: usize>(v: &[[T; N]], f: impl Fn(T) -> [u8; 4]) -> Vec<u8> {
    v.iter().flatten().flat_map(|&x| f(x)).collect()
}

/// Writes the scene: a ground quad (world space, grey) and the pyramid (a textured-looking red
/// glossy material, no texture) placed by EXT_mesh_gpu_instancing at `placements`, under a node
/// turned and moved (the node's transform applies after each instance's).
fn write_scene(dir: &Path, name: &str, placements: &[Placement]) -> PathBuf {
    let mut data = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut add = |bytes: Vec<u8>, count: usize, ctype: u32, ty: &str, minmax: Option<Value>| {
        while data.len() % 4 != 0 {
            data.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": data.len(), "byteLength": bytes.len()}));
        data.extend_from_slice(&bytes);
        let mut a = json!({"bufferView": views.len() - 1, "componentType": ctype, "count": count, "type": ty});
        if let Some(Value::Array(m)) = minmax {
            a["min"] = m[0].clone();
            a["max"] = m[1].clone();
        }
        accessors.push(a);
        accessors.len() - 1
    };
    let f = |x: f32| x.to_le_bytes();
    let bounds = |p: &[[f32; 3]]| {
        let lo: Vec<f32> = (0..3)
            .map(|k| p.iter().map(|v| v[k]).fold(f32::MAX, f32::min))
            .collect();
        let hi: Vec<f32> = (0..3)
            .map(|k| p.iter().map(|v| v[k]).fold(f32::MIN, f32::max))
            .collect();
        Some(json!([lo, hi]))
    };
    let (p, n, uv, idx) = pyramid();
    let pos = add(le(&p, f), p.len(), 5126, "VEC3", bounds(&p));
    let nrm = add(le(&n, f), n.len(), 5126, "VEC3", None);
    let tex = add(le(&uv, f), uv.len(), 5126, "VEC2", None);
    let ind = add(
        idx.iter().flat_map(|i| i.to_le_bytes()).collect(),
        idx.len(),
        5123,
        "SCALAR",
        None,
    );
    let ground: Vec<[f32; 3]> = vec![
        [-4.0, 0.0, -4.0],
        [-4.0, 0.0, 4.0],
        [4.0, 0.0, 4.0],
        [4.0, 0.0, -4.0],
    ];
    let gpos = add(le(&ground, f), 4, 5126, "VEC3", bounds(&ground));
    let gind = add(
        [0u16, 1, 2, 0, 2, 3]
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect(),
        6,
        5123,
        "SCALAR",
        None,
    );
    let t: Vec<[f32; 3]> = placements.iter().map(|p| p.0).collect();
    let r: Vec<[f32; 4]> = placements.iter().map(|p| p.1).collect();
    let s: Vec<[f32; 3]> = placements.iter().map(|p| p.2).collect();
    let ta = add(le(&t, f), t.len(), 5126, "VEC3", None);
    let ra = add(le(&r, f), r.len(), 5126, "VEC4", None);
    let sa = add(le(&s, f), s.len(), 5126, "VEC3", None);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&data)
    );
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "buffers": [{"byteLength": data.len(), "uri": uri}],
        "bufferViews": views,
        "accessors": accessors,
        "materials": [
            {"name": "grey", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}},
            {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.2, 1.0],
             "metallicFactor": 0.0, "roughnessFactor": 0.4}}
        ],
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "name": "ground"},
            {"mesh": 1, "name": "trees", "translation": [0.1, 0.0, -0.2],
             "rotation": [0.0, 0.0998, 0.0, 0.995],
             "extensions": {"EXT_mesh_gpu_instancing": {"attributes":
                {"TRANSLATION": ta, "ROTATION": ra, "SCALE": sa}}}}
        ],
        "meshes": [
            {"name": "ground", "primitives": [{"attributes": {"POSITION": gpos}, "indices": gind, "material": 0}]},
            {"name": "pyramid", "primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm,
                "TEXCOORD_0": tex}, "indices": ind, "material": 1}]}
        ],
    });
    let path = dir.join(name);
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

/// The scene loaded with instances and flattened.
fn both(path: &Path) -> [Scene; 2] {
    [false, true].map(|flatten_instances| {
        let options = LoadOptions {
            flatten_instances,
            ..Default::default()
        };
        let mut s = load_scene_with(path, &[], &options).unwrap();
        s.add_point_light(DVec3::new(0.3, 3.0, 0.4), Rgb::splat(30.0));
        s
    })
}

#[test]
fn instanced_gltf_stores_the_prototype_once() {
    let dir = temp_dir("instancing", "once");
    let path = write_scene(&dir, "trees.gltf", &placements());
    let [inst, flat] = both(&path);
    assert!(inst.is_instanced() && !flat.is_instanced());
    assert_eq!(inst.triangles.len(), 2 + 6, "ground and one pyramid");
    assert_eq!(flat.triangles.len(), 2 + 4 * 6, "ground and four copies");
    assert_eq!(inst.instancing().instanced_triangles(), 4 * 6);
    // The bounds (which place slices and scale the error bounds) are the flattened scene's.
    assert_eq!(inst.bounds, flat.bounds);
    assert_eq!(inst.extent(), flat.extent());
}

/// Rays from many directions at every instance hit the same point, with the same normals,
/// material and texture coordinates as on the flattened copies: rotation with non-uniform scale
/// (normals by the inverse transpose) and a mirroring transform (winding reversed, the front
/// side kept outside).
#[test]
fn instance_hits_are_the_flattened_copies_hits() {
    let dir = temp_dir("instancing", "hits");
    let path = write_scene(&dir, "trees.gltf", &placements());
    let [inst, flat] = both(&path);
    let mut compared = 0;
    let mut on_instances = 0;
    for k in 0..4000 {
        // Directions spread over the sphere (a Fibonacci lattice), origins on a ring above.
        let z = 1.0 - 2.0 * (k as f64 + 0.5) / 4000.0;
        let phi = k as f64 * 2.399_963_229_728_653;
        let d = DVec3::new(
            (1.0 - z * z).sqrt() * phi.cos(),
            -z.abs(),
            (1.0 - z * z).sqrt() * phi.sin(),
        );
        let o = DVec3::new(
            3.0 * (0.37 * k as f64).cos(),
            2.5,
            3.0 * (0.37 * k as f64).sin(),
        );
        let d = (DVec3::new(0.0, 0.5, 0.0) - o + d * 2.0).normalize();
        let (Some(a), Some(b)) = (
            inst.intersect(o, d, f64::INFINITY),
            flat.intersect(o, d, f64::INFINITY),
        ) else {
            assert_eq!(
                inst.intersect(o, d, f64::INFINITY).is_some(),
                flat.intersect(o, d, f64::INFINITY).is_some(),
                "ray {k}: hit in one scene only"
            );
            continue;
        };
        compared += 1;
        on_instances += usize::from(a.inst != u32::MAX);
        // A ray through an edge may report either triangle: compare where both see one surface.
        assert!(
            (a.p - b.p).length() <= 4.0 * a.eps.max(b.eps),
            "ray {k}: {} vs {}",
            a.p,
            b.p
        );
        if (a.ng - b.ng).length() > 1e-9 {
            assert!(
                inst.near_edge(&a) || flat.near_edge(&b),
                "ray {k}: ng {} vs {}",
                a.ng,
                b.ng
            );
            continue;
        }
        // Shading normals and texture coordinates follow the barycentrics, which Embree computes
        // in f32 in each space (prototype and world): they differ by some f32 ulps over the
        // cosine of the incidence (more at grazing hits).
        let tol = 4e-6 / a.ng.dot(d).abs();
        assert!(
            (a.ns - b.ns).length() < tol,
            "ray {k}: ns {} vs {} instance {} barycentrics {:?} {:?}",
            a.ns,
            b.ns,
            a.inst,
            a.bary,
            b.bary
        );
        assert_eq!(a.material, b.material, "ray {k}");
        let (ua, ub) = (inst.hit_uv(a.prim, a.bary), flat.hit_uv(b.prim, b.bary));
        assert!(
            (ua[0] - ub[0]).abs() < tol && (ua[1] - ub[1]).abs() < tol,
            "ray {k}: uv"
        );
        // The front side faces the ray's origin on these closed, outward-wound pyramids.
        if a.inst != u32::MAX {
            assert!(a.ng.dot(d) < 0.0, "ray {k}: an instance seen from inside");
        }
    }
    assert!(
        compared > 3000 && on_instances > 800,
        "{compared} hits, {on_instances} on instances"
    );
}

/// The shading normal of an instance under rotation and non-uniform scale is the inverse
/// transpose of the prototype's, and a mirrored instance's geometric normal points out of the
/// mirrored pyramid, computed here independently of the loader.
#[test]
fn instance_normals_follow_the_inverse_transpose_and_mirroring() {
    let dir = temp_dir("instancing", "normals");
    let placements = placements();
    let path = write_scene(&dir, "trees.gltf", &placements);
    let [inst, _] = both(&path);
    let node = DMat3::from_quat(DQuat::from_xyzw(0.0, 0.0998, 0.0, 0.995).normalize());
    let node_t = DVec3::new(0.1, 0.0, -0.2);
    let (_, normals, _, _) = pyramid();
    for (i, (t, r, s)) in placements.iter().enumerate() {
        let q = DQuat::from_xyzw(r[0] as f64, r[1] as f64, r[2] as f64, r[3] as f64).normalize();
        let m = node * DMat3::from_quat(q) * DMat3::from_diagonal(DVec3::from(s.map(f64::from)));
        let at = |local: DVec3| node * DVec3::from(t.map(f64::from)) + node_t + m * local;
        // The centre of the side triangle 0-4-1 (facing −z in the prototype).
        let c = DVec3::new(0.0, 1.0 / 3.0, -1.0 / 3.0);
        let n_local = DVec3::new(0.0, 0.5, -1.0).normalize();
        let n_world = (m.inverse().transpose() * n_local).normalize();
        let target = at(c);
        let o = target + n_world * 0.05;
        let hit = inst.intersect(o, -n_world, f64::INFINITY).expect("hit");
        assert_eq!(hit.inst, i as u32, "instance {i}");
        assert!(
            (hit.p - target).length() < 1e-5,
            "instance {i}: {} vs {target}",
            hit.p
        );
        assert!(
            (hit.ng - n_world).length() < 1e-6,
            "instance {i}: ng {} vs {n_world}",
            hit.ng
        );
        // Shading normal: the corners' normals by the inverse transpose, renormalised,
        // interpolated at the hit's barycentrics (the triangle's corners 0, 4, 1).
        let nt = |k: usize| {
            let n = DVec3::from(normals[k].map(f64::from));
            (m.inverse().transpose() * n).normalize()
        };
        let [u, v] = hit.bary.map(f64::from);
        let ns = ((1.0 - u - v) * nt(0) + u * nt(4) + v * nt(1)).normalize();
        assert!(
            (hit.ns - ns).length() < 1e-5,
            "instance {i}: ns {} vs {ns}",
            hit.ns
        );
        if s[0] < 0.0 {
            assert!(m.determinant() < 0.0);
        }
    }
}

/// The field of the instanced scene is the flattened scene's: σ (unweighted and radiance
/// weighted) and the fluence at points among the pyramids, independent seeds, judged by
/// `assert_consistent` (false failures with probability at most `ALPHA`).
#[test]
fn instanced_field_is_the_flattened_field() {
    let dir = temp_dir("instancing", "field");
    let path = write_scene(&dir, "trees.gltf", &placements());
    let [inst, flat] = both(&path);
    let points: Vec<DVec3> = [-1.0, 0.0, 1.2]
        .into_iter()
        .flat_map(|x| [0.4, 1.1].map(|y| DVec3::new(x, y, 0.3 * x - 0.1)))
        .collect();
    let params = |weighting| crate::support::params(0.5, 1.5, 0.15, weighting, 8);
    let zs = crate::support::z_scores_of_two_scenes([&inst, &flat], &points, params, 31, 3000);
    crate::support::assert_consistent("instanced vs flattened", &zs);
}

#[test]
fn singular_instance_is_dropped_with_a_warning_naming_the_node() {
    let dir = temp_dir("instancing", "singular");
    let mut p = placements();
    p.push(([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 1.0]));
    let path = write_scene(&dir, "trees.gltf", &p);
    let [inst, _] = both(&path);
    assert_eq!(inst.instancing().instances.len(), 4);
    let w = inst.report.warnings.join("\n");
    assert!(w.contains("'trees'") && w.contains("singular"), "{w}");
}

/// Points on an instance's face are moved off it to its front side as on the flattened copy
/// (the point query reports instanced triangles), and a plane through the face is a slice
/// through a wall in both scenes.
#[test]
fn points_on_instances_move_off_them_as_on_the_flattened_copies() {
    let dir = temp_dir("instancing", "off");
    let placements = placements();
    let path = write_scene(&dir, "trees.gltf", &placements);
    let [inst, flat] = both(&path);
    let node = DMat3::from_quat(DQuat::from_xyzw(0.0, 0.0998, 0.0, 0.995).normalize());
    let node_t = DVec3::new(0.1, 0.0, -0.2);
    for (i, (t, r, s)) in placements.iter().enumerate() {
        let q = DQuat::from_xyzw(r[0] as f64, r[1] as f64, r[2] as f64, r[3] as f64).normalize();
        let m = node * DMat3::from_quat(q) * DMat3::from_diagonal(DVec3::from(s.map(f64::from)));
        let at = |local: DVec3| node * DVec3::from(t.map(f64::from)) + node_t + m * local;
        let x = at(DVec3::new(0.1, 1.0 / 3.0, -1.0 / 3.0));
        let n = (m.inverse().transpose() * DVec3::new(0.0, 0.5, -1.0)).normalize();
        let (a, b) = (inst.off_surfaces(x), flat.off_surfaces(x));
        assert!((a - x).dot(n) > 0.0, "instance {i}: not moved to the front");
        assert!(
            (a - b).length() <= 4.0 * inst.eps_at(x),
            "instance {i}: {a} vs {b}"
        );
        assert!(
            inst.surface_in_plane(x, n) && flat.surface_in_plane(x, n),
            "instance {i}"
        );
        let shifted = x + n * 0.01;
        assert_eq!(
            inst.surface_in_plane(shifted, n),
            flat.surface_in_plane(shifted, n),
            "instance {i}"
        );
    }
}
