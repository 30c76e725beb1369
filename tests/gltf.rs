//! glTF loading: files are assembled here (JSON with a base64 data-URI buffer, a .bin next to the
//! .gltf, or a .glb built byte by byte) and checked for world-space geometry, materials, lights,
//! cameras, and errors that name the file.

use crate::support::{scene_path, temp_dir};
use base64::Engine as _;
use ftpd3d::math::Rgb;
use ftpd3d::scene::load::load_scene;
use ftpd3d::scene::{Light, Scene};
use ftpd3d::transport::bsdf::Bsdf;
use glam::DVec3;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// One binary buffer with its buffer views and accessors, assembled as a test goes.
#[derive(Default)]
pub(crate) struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    pub(crate) fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()}));
        self.data.extend_from_slice(bytes);
        self.views.len() - 1
    }

    pub(crate) fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in v {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3",
            "min": lo, "max": hi
        }));
        self.accessors.len() - 1
    }

    /// Unsigned short indices.
    pub(crate) fn indices(&mut self, idx: &[u16]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5123, "count": idx.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    /// The glTF document: `extra`'s keys (scenes, nodes, meshes, …) plus the buffer, whose `uri` is
    /// `uri` (none for a GLB).
    fn document(&self, uri: Option<&str>, extra: Value) -> Value {
        let mut buffer = json!({"byteLength": self.data.len()});
        if let Some(u) = uri {
            buffer["uri"] = json!(u);
        }
        let mut doc = json!({
            "asset": {"version": "2.0"},
            "buffers": [buffer],
            "bufferViews": self.views,
            "accessors": self.accessors,
        });
        for (k, v) in extra.as_object().unwrap() {
            doc[k] = v.clone();
        }
        doc
    }

    /// Writes `name` (.gltf) with the buffer embedded as a base64 data URI.
    pub(crate) fn write_embedded(&self, dir: &Path, name: &str, extra: Value) -> PathBuf {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.data)
        );
        let path = dir.join(name);
        std::fs::write(&path, self.document(Some(&uri), extra).to_string()).unwrap();
        path
    }

    /// Writes `name` (.gltf) and the buffer as `bin` next to it.
    fn write_external(&self, dir: &Path, name: &str, bin: &str, extra: Value) -> PathBuf {
        std::fs::write(dir.join(bin), &self.data).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, self.document(Some(bin), extra).to_string()).unwrap();
        path
    }

    /// The GLB bytes: 12-byte header, JSON chunk (space-padded), BIN chunk (zero-padded).
    fn glb(&self, extra: Value) -> Vec<u8> {
        let mut json = self.document(None, extra).to_string().into_bytes();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.data.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((json.len() as u32).to_le_bytes());
        out.extend(0x4E4F534Au32.to_le_bytes()); // "JSON"
        out.extend(json);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(0x004E4942u32.to_le_bytes()); // "BIN\0"
        out.extend(bin);
        out
    }
}

/// The unit quad in z = 0 (x, y in [0, 1]), front side +z, with +z normals: (bin, mesh JSON).
fn quad(bin: &mut Bin, name: &str, material: Option<usize>) -> Value {
    let pos = bin.vec3(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
    let nrm = bin.vec3(&[[0., 0., 1.]; 4]);
    let idx = bin.indices(&[0, 1, 2, 0, 2, 3]);
    let mut prim = json!({"attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx});
    if let Some(m) = material {
        prim["material"] = json!(m);
    }
    json!({"name": name, "primitives": [prim]})
}

/// A cube of half-size 0.5 around the origin, 4 vertices per face with the face's normal, wound
/// counter-clockwise seen from outside.
fn cube(bin: &mut Bin) -> Value {
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([1., 0., 0.], [0., 1., 0.], [0., 0., 1.]),
        ([-1., 0., 0.], [0., 0., 1.], [0., 1., 0.]),
        ([0., 1., 0.], [0., 0., 1.], [1., 0., 0.]),
        ([0., -1., 0.], [1., 0., 0.], [0., 0., 1.]),
        ([0., 0., 1.], [1., 0., 0.], [0., 1., 0.]),
        ([0., 0., -1.], [0., 1., 0.], [1., 0., 0.]),
    ];
    let (mut pos, mut nrm, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for (n, u, v) in faces {
        let base = pos.len() as u16;
        for (su, sv) in [(-1., -1.), (1., -1.), (1., 1.), (-1., 1.)] {
            pos.push([0, 1, 2].map(|k| 0.5 * (n[k] + su * u[k] + sv * v[k])));
            nrm.push(n);
        }
        idx.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
    let (p, n, i) = (bin.vec3(&pos), bin.vec3(&nrm), bin.indices(&idx));
    json!({"name": "Cube", "primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i}]})
}

fn world_positions(scene: &Scene) -> Vec<DVec3> {
    scene.positions.iter().map(|p| p.as_dvec3()).collect()
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

#[test]
fn gltf_node_hierarchy_places_the_quad() {
    let dir = temp_dir("gltf", "hierarchy");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", None);
    // Parent translation, child scale: world = T · S. A second tree gives the same with a matrix.
    let extra = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"translation": [1.0, 2.0, 3.0], "children": [1]},
            {"scale": [2.0, 3.0, 1.0], "mesh": 0},
            {"matrix": [2.0, 0, 0, 0,  0, 3.0, 0, 0,  0, 0, 1.0, 0,  1.0, 2.0, -3.0, 1.0], "mesh": 0}
        ],
        "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "quad.gltf", extra);
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 4);
    let p = world_positions(&scene);
    let expect = [
        DVec3::new(1., 2., 3.),
        DVec3::new(3., 2., 3.),
        DVec3::new(3., 5., 3.),
        DVec3::new(1., 5., 3.),
    ];
    for (k, e) in expect.iter().enumerate() {
        assert!(close(p[k], *e), "vertex {k}: {} vs {e}", p[k]);
        assert!(close(p[k + 4], *e - DVec3::new(0., 0., 6.)), "{}", p[k + 4]);
    }
    assert!(close(scene.bounds.min, DVec3::new(1., 2., -3.)));
    assert!(close(scene.bounds.max, DVec3::new(3., 5., 3.)));
    for n in scene.tri_normals() {
        assert!(close(n, DVec3::Z), "{n}");
    }
    assert_eq!(scene.normals.len(), scene.positions.len());
    assert_eq!(
        scene.materials[scene.tri_material[0] as usize].name,
        "default"
    );
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
}

#[test]
fn gltf_instanced_mesh_is_expanded() {
    let dir = temp_dir("gltf", "instanced");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", None);
    let extra = json!({
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"mesh": 0, "translation": [5.0, 0.0, 0.0]},
            {"mesh": 0, "translation": [0.0, 0.0, -4.0]}
        ],
        "meshes": [mesh],
    });
    let path = bin.write_external(&dir, "inst.gltf", "inst.bin", extra);
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 6);
    assert_eq!(scene.positions.len(), 12);
    assert!(close(scene.bounds.min, DVec3::new(0., 0., -4.)));
    assert!(close(scene.bounds.max, DVec3::new(6., 1., 0.)));
}

#[test]
fn gltf_negative_scale_keeps_outward_normals() {
    let dir = temp_dir("gltf", "mirror");
    let mut bin = Bin::default();
    let mesh = cube(&mut bin);
    // Mirroring, non-uniform parent scale over a rotated child: positions need the full transform,
    // normals its inverse transpose, and the winding a flip.
    let half = 15f32.to_radians(); // 30° about z
    let extra = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"scale": [-2.0, 0.5, 1.0], "translation": [3.0, 0.0, 0.0], "children": [1]},
            {"rotation": [0.0, 0.0, half.sin(), half.cos()], "mesh": 0}
        ],
        "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "cube.gltf", extra);
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 12);
    let centre = DVec3::new(3., 0., 0.);
    for (t, tri) in scene.triangles.iter().enumerate() {
        let ng = scene.tri_normal(t);
        let mid = tri
            .iter()
            .map(|&i| scene.positions[i as usize].as_dvec3())
            .sum::<DVec3>()
            / 3.0;
        assert!((mid - centre).dot(ng) > 0.0, "triangle {t} faces inward");
        for &i in tri {
            let ns = scene.normals[i as usize].as_dvec3();
            assert!((ns.length() - 1.0).abs() < 1e-5);
            // Flat faces: the transformed shading normal is the geometric normal.
            assert!(
                close(ns, ng),
                "triangle {t}: shading {ns} vs geometric {ng}"
            );
        }
    }
}

#[test]
fn gltf_point_spot_and_directional_lights_and_camera_come_through() {
    let dir = temp_dir("gltf", "lights");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Floor", None);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let extra = json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "bulb", "type": "point", "color": [1.0, 0.5, 0.25], "intensity": 8.0},
            {"type": "spot", "intensity": 2.0, "spot": {"outerConeAngle": 0.5}},
            {"type": "directional", "intensity": 3.0}
        ]}},
        "cameras": [
            {"name": "main", "type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.01}},
            {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.01, "zfar": 10}}
        ],
        "scenes": [{"nodes": [0, 1, 3, 4, 5, 6]}],
        "nodes": [
            {"mesh": 0},
            {"translation": [1.0, 0.0, 0.0], "children": [2]},
            {"translation": [0.0, 2.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            // +90° about y: the camera's −Z turns to −X.
            {"translation": [0.0, 1.0, 5.0], "rotation": [0.0, h, 0.0, h], "camera": 0},
            {"translation": [0.0, 3.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}},
            {"camera": 1}
        ],
        "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "lights.gltf", extra);
    let scene = load_scene(&path).unwrap();
    let points: Vec<_> = scene
        .lights
        .lights
        .iter()
        .filter_map(|l| match l {
            Light::Point {
                position,
                intensity,
            } => Some((*position, *intensity)),
            _ => None,
        })
        .collect();
    assert_eq!(points.len(), 1, "the point light");
    assert!(close(points[0].0, DVec3::new(1., 2., 0.)));
    assert!(close(points[0].1, Rgb::new(8., 4., 2.)));
    // The spot keeps its cone (glTF's defaults: inner 0, outer as given) and shines along the
    // node's −Z; the directional light is a sun without a disc, shining along −Z too, so its
    // direction (towards the light) is +Z.
    let spots: Vec<_> = scene
        .lights
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Spot { .. }))
        .collect();
    assert_eq!(spots.len(), 1);
    let Light::Spot {
        position,
        direction,
        intensity,
        cos_inner,
        cos_outer,
    } = spots[0]
    else {
        unreachable!()
    };
    assert!(close(*position, DVec3::new(0., 3., 0.)));
    assert!(close(*direction, DVec3::NEG_Z));
    assert!(close(*intensity, Rgb::splat(2.0)));
    assert!((cos_inner - 1.0).abs() < 1e-12 && (cos_outer - 0.5f64.cos()).abs() < 1e-7);
    let suns: Vec<_> = scene
        .lights
        .lights
        .iter()
        .filter_map(|l| match l {
            Light::Distant {
                direction,
                irradiance,
                half_angle,
                ..
            } => Some((*direction, *irradiance, *half_angle)),
            _ => None,
        })
        .collect();
    assert_eq!(suns.len(), 1);
    assert!(close(suns[0].0, DVec3::Z) && close(suns[0].1, Rgb::splat(3.0)));
    assert_eq!(suns[0].2, 0.0);
    assert!(scene.features.point_lights && scene.features.spot_lights && scene.features.sun);
    assert!(!scene.features.area_lights);
    assert_eq!(scene.cameras.len(), 1);
    let cam = &scene.cameras[0];
    assert_eq!(cam.name, "main");
    assert!(close(cam.eye, DVec3::new(0., 1., 5.)));
    assert!(close(cam.forward, DVec3::NEG_X), "{}", cam.forward);
    assert!(close(cam.up, DVec3::Y), "{}", cam.up);
    assert!((cam.fov_y - 0.8).abs() < 1e-6);
    assert!((cam.aspect.unwrap() - 1.5).abs() < 1e-6);
    let w = scene.report.warnings.join("\n");
    assert!(!w.contains("spot") && !w.contains("directional"), "{w}");
    assert!(w.contains("orthographic"), "{w}");
    assert!(w.contains("lights.gltf"), "{w}");
}

#[test]
fn gltf_emissive_material_is_an_area_light() {
    let dir = temp_dir("gltf", "emissive");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Lamp", Some(0));
    let extra = json!({
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "materials": [{
            "name": "glow",
            "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
            "emissiveFactor": [1.0, 0.5, 1.0],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}
        }],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "lamp.gltf", extra);
    let scene = load_scene(&path).unwrap();
    let m = &scene.materials[scene.tri_material[0] as usize];
    assert_eq!(m.name, "glow");
    assert_eq!(m.emission, Rgb::new(4., 2., 4.));
    assert_eq!(m.bsdf, Bsdf::Black);
    assert_eq!(scene.lights.lights.len(), 2);
    assert!(
        scene
            .lights
            .lights
            .iter()
            .all(|l| matches!(l, Light::Area { normal, .. } if close(*normal, DVec3::Z)))
    );
    assert!(scene.features.area_lights);
}

/// A negative (or, through an f32 overflow, infinite) light intensity or colour, emissiveFactor or
/// emissive strength is refused naming the light or material and the field, as the glTF validator
/// reports them: clamped to 0 it made a light that gives nothing yet counts as one.
#[test]
fn gltf_negative_light_intensity_and_emission_are_refused_naming_them() {
    let dir = temp_dir("gltf", "negative");
    let cases = [
        (
            json!({"extensionsUsed": ["KHR_lights_punctual"],
                   "extensions": {"KHR_lights_punctual": {"lights": [
                       {"name": "bulb", "type": "point", "intensity": -100.0}]}}}),
            vec!["KHR_lights_punctual light 'bulb'", "intensity -100"],
        ),
        (
            json!({"extensionsUsed": ["KHR_lights_punctual"],
                   "extensions": {"KHR_lights_punctual": {"lights": [
                       {"type": "spot", "intensity": 1.0, "color": [1.0, -0.5, 1.0], "spot": {}}]}}}),
            vec!["KHR_lights_punctual light #0", "color"],
        ),
        (
            json!({"extensionsUsed": ["KHR_lights_punctual"],
                   "extensions": {"KHR_lights_punctual": {"lights": [
                       {"type": "point", "intensity": 1e39}]}}}),
            vec!["KHR_lights_punctual light #0", "intensity inf"],
        ),
        (
            json!({"materials": [{"name": "glow", "emissiveFactor": [1.0, -2.0, 0.0]}]}),
            vec!["material 'glow'", "emissiveFactor"],
        ),
        (
            json!({"extensionsUsed": ["KHR_materials_emissive_strength"],
                   "materials": [{"emissiveFactor": [1.0, 1.0, 1.0], "extensions":
                       {"KHR_materials_emissive_strength": {"emissiveStrength": -3.0}}}]}),
            vec!["material #0", "KHR_materials_emissive_strength -3"],
        ),
    ];
    for (k, (mut extra, words)) in cases.into_iter().enumerate() {
        let mut bin = Bin::default();
        let material = extra.get("materials").map(|_| 0);
        let mesh = quad(&mut bin, "Floor", material);
        extra["scenes"] = json!([{"nodes": [0]}]);
        extra["nodes"] = json!([{"mesh": 0}]);
        extra["meshes"] = json!([mesh]);
        let path = bin.write_embedded(&dir, &format!("n{k}.gltf"), extra);
        let e = match load_scene(&path) {
            Ok(_) => panic!("case {k} loaded"),
            Err(e) => format!("{e:#}"),
        };
        assert!(e.starts_with(&path.display().to_string()), "{e}");
        for w in words {
            assert!(e.contains(w), "case {k}: no '{w}' in: {e}");
        }
    }
}

#[test]
fn gltf_transmission_is_a_dielectric_with_its_ior() {
    let dir = temp_dir("gltf", "glass");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Pane", Some(1));
    let extra = json!({
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"],
        "materials": [
            {"name": "rough", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
            {
                "name": "glass",
                "pbrMetallicRoughness": {"baseColorFactor": [0.9, 1.0, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
                "extensions": {
                    "KHR_materials_transmission": {"transmissionFactor": 1.0},
                    "KHR_materials_ior": {"ior": 1.33}
                }
            }
        ],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "glass.gltf", extra);
    let scene = load_scene(&path).unwrap();
    let Bsdf::Dielectric { ior, tint } = scene.materials[scene.tri_material[0] as usize].bsdf
    else {
        panic!("{:?}", scene.materials);
    };
    assert!((ior - 1.33).abs() < 1e-6, "{ior}");
    assert!(close(tint, Rgb::new(0.9, 1.0, 0.8)));
    assert!(scene.features.dielectric);
    assert_eq!(
        scene.materials[0].bsdf,
        Bsdf::Diffuse {
            kd: Rgb::splat(0.5)
        }
    );
}

#[test]
fn gltf_glb_loads_and_a_truncated_one_is_an_error_naming_it() {
    let dir = temp_dir("gltf", "glb");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", None);
    let extra = json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "translation": [0, 0, 1]}], "meshes": [mesh]});
    let glb = bin.glb(extra);
    let full = dir.join("quad.glb");
    std::fs::write(&full, &glb).unwrap();
    let scene = load_scene(&full).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert!(close(scene.bounds.max, DVec3::new(1., 1., 1.)));

    for cut in [glb.len() - 10, glb.len() / 2, 7] {
        let short = dir.join("short.glb");
        std::fs::write(&short, &glb[..cut]).unwrap();
        let e = format!("{:#}", load_scene(&short).err().unwrap());
        assert!(e.contains("short.glb"), "{e}");
        assert!(e.contains("truncated"), "{e}");
    }
}

#[test]
fn gltf_missing_bin_is_an_error_naming_both_files() {
    let dir = temp_dir("gltf", "missing");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", None);
    let extra = json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}], "meshes": [mesh]});
    let path = dir.join("lonely.gltf");
    std::fs::write(&path, bin.document(Some("gone.bin"), extra).to_string()).unwrap();
    let e = format!("{:#}", load_scene(&path).err().unwrap());
    assert!(e.contains("lonely.gltf") && e.contains("gone.bin"), "{e}");

    let e = format!("{:#}", load_scene(&dir.join("nothere.gltf")).err().unwrap());
    assert!(e.contains("nothere.gltf"), "{e}");
}

#[test]
fn gltf_bad_position_accessor_is_an_error_naming_the_mesh() {
    let dir = temp_dir("gltf", "badacc");
    let mut bin = Bin::default();
    let pos = bin.vec3(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.]]);
    // Quantised positions without KHR_mesh_quantization: not allowed by the core spec.
    bin.accessors[pos]["componentType"] = json!(5123);
    let extra = json!({
        "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"name": "Box", "primitives": [{"attributes": {"POSITION": pos}}]}],
    });
    let path = bin.write_embedded(&dir, "scene.gltf", extra);
    let e = format!("{:#}", load_scene(&path).err().unwrap());
    assert!(e.contains("scene.gltf"), "{e}");
    assert!(
        e.contains("mesh 'Box' primitive 0: POSITION accessor #0 is not VEC3 f32 (it is VEC3 u16)"),
        "{e}"
    );

    // An index past the vertices, and an accessor running past its buffer view.
    let mut bin = Bin::default();
    let pos = bin.vec3(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.]]);
    let idx = bin.indices(&[0, 1, 7]);
    let long = bin.vec3(&[[0., 0., 0.]; 3]);
    bin.accessors[long]["count"] = json!(300);
    let extra = json!({
        "scenes": [{"nodes": [0, 1]}], "nodes": [{"mesh": 0}, {"mesh": 1}],
        "meshes": [
            {"name": "A", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]},
            {"name": "B", "primitives": [{"attributes": {"POSITION": long}}]}
        ],
    });
    let path = bin.write_embedded(&dir, "bad.gltf", extra.clone());
    let e = format!("{:#}", load_scene(&path).err().unwrap());
    assert!(e.contains("bad.gltf: mesh 'A' primitive 0: index 7"), "{e}");
    let mut extra = extra;
    extra["scenes"] = json!([{"nodes": [1]}]);
    let path = bin.write_embedded(&dir, "bad.gltf", extra);
    let e = format!("{:#}", load_scene(&path).err().unwrap());
    assert!(
        e.contains("bad.gltf: mesh 'B' primitive 0") && e.contains("past the end"),
        "{e}"
    );
}

#[test]
fn gltf_corrupt_files_give_errors_not_panics() {
    let dir = temp_dir("gltf", "corrupt");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", Some(0));
    let extra = json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 1.0}]}},
        "materials": [{"pbrMetallicRoughness": {"metallicFactor": 0.5}}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"mesh": 0, "children": [1, 2]},
            {"camera": 0, "translation": [0, 0, 2]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "meshes": [mesh],
    });
    let glb = bin.glb(extra);
    let path = dir.join("c.glb");
    // Every truncation, and every byte turned into '9' (digits become large counts, offsets and
    // indices; the binary chunk gets out-of-range indices): an error or a scene, never a panic.
    for cut in 0..glb.len() {
        std::fs::write(&path, &glb[..cut]).unwrap();
        let e = format!("{:#}", load_scene(&path).err().unwrap());
        assert!(e.contains("c.glb"), "{e}");
    }
    let mut errors = 0;
    for k in 0..glb.len() {
        let mut bad = glb.clone();
        bad[k] = b'9';
        std::fs::write(&path, &bad).unwrap();
        if let Err(e) = load_scene(&path) {
            let e = format!("{e:#}");
            assert!(e.contains("c.glb"), "{e}");
            errors += 1;
        }
    }
    assert!(errors > 0);
    // A camera whose type names the block it does not have.
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", None);
    let extra = json!({
        "cameras": [{"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 9}}],
        "scenes": [{"nodes": [0, 1]}], "nodes": [{"mesh": 0}, {"camera": 0}], "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "cam.gltf", extra);
    let e = format!("{:#}", load_scene(&path).err().unwrap());
    assert!(e.contains("cam.gltf: camera #0"), "{e}");
}

#[test]
fn gltf_points_primitive_is_skipped_with_a_warning() {
    let dir = temp_dir("gltf", "points");
    let mut bin = Bin::default();
    let mut mesh = quad(&mut bin, "Cloud", None);
    let pts = bin.vec3(&[[5., 5., 5.], [6., 6., 6.]]);
    mesh["primitives"]
        .as_array_mut()
        .unwrap()
        .push(json!({"attributes": {"POSITION": pts}, "mode": 0}));
    let extra = json!({"scenes": [{"nodes": [0, 1]}], "nodes": [{"mesh": 0}, {"mesh": 0}], "meshes": [mesh]});
    let path = bin.write_embedded(&dir, "cloud.gltf", extra);
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 4);
    assert!(close(scene.bounds.max, DVec3::new(1., 1., 0.)));
    let w = &scene.report.warnings;
    assert_eq!(
        w.len(),
        1,
        "one warning per primitive, not per instance: {w:?}"
    );
    assert!(
        w[0].contains("cloud.gltf")
            && w[0].contains("mesh 'Cloud' primitive 1")
            && w[0].contains("POINTS"),
        "{w:?}"
    );
}

#[test]
fn gltf_strips_and_fans_are_triangulated() {
    let dir = temp_dir("gltf", "strip");
    let mut bin = Bin::default();
    // Strip order 0 1 3 2 and fan order 0 1 2 3 of the unit quad, non-indexed: both face +z.
    let strip = bin.vec3(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]]);
    let fan = bin.vec3(&[[0., 0., 2.], [1., 0., 2.], [1., 1., 2.], [0., 1., 2.]]);
    let extra = json!({
        "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": strip}, "mode": 5},
            {"attributes": {"POSITION": fan}, "mode": 6}
        ]}],
    });
    let path = bin.write_embedded(&dir, "strip.gltf", extra);
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 4);
    assert_eq!(scene.report.degenerate_dropped, 0);
    for n in scene.tri_normals() {
        assert!(close(n, DVec3::Z), "{n}");
    }
    assert!(scene.normals.is_empty(), "no NORMAL attribute anywhere");
}

#[test]
fn gltf_shipped_cornell_point_scene_loads() {
    let scene = load_scene(&scene_path("cornell_point.gltf")).unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    assert!(close(scene.bounds.min, DVec3::new(-1., 0., -1.)));
    assert!(close(scene.bounds.max, DVec3::new(1., 2., 1.)));
    let [
        Light::Point {
            position,
            intensity,
        },
    ] = scene.lights.lights.as_slice()
    else {
        panic!("{:?}", scene.lights.lights);
    };
    assert!(close(*position, DVec3::new(0., 1.5, 0.)));
    assert!(close(*intensity, Rgb::splat(5.)));
    assert!(scene.features.diffuse && scene.features.point_lights);
    assert!(!(scene.features.glossy || scene.features.mirror || scene.features.area_lights));
    // Closed room, walls facing inward.
    let centre = DVec3::new(0., 1., 0.);
    for (t, tri) in scene.triangles.iter().enumerate() {
        let p = scene.positions[tri[0] as usize].as_dvec3();
        assert!((centre - p).dot(scene.tri_normal(t)) > 0.0, "triangle {t}");
    }
    let cam = &scene.cameras[0];
    assert!(close(cam.eye, DVec3::new(0., 1., 0.95)));
    assert!(close(cam.forward, DVec3::NEG_Z));
    assert!(close(cam.up, DVec3::Y));
    assert!((cam.fov_y - 0.9).abs() < 1e-6);
}

/// A glTF 1.0 document (its meshes and materials are maps keyed by id, as 1.0 has them) is
/// refused for its version, through the binary, as the `.glb` path refuses binary glTF 1.
#[test]
fn gltf_version_1_is_named_as_such() {
    let dir = temp_dir("gltf", "version1");
    let path = dir.join("old.gltf");
    let doc = json!({
        "asset": {"version": "1.0"},
        "scene": "defaultScene",
        "scenes": {"defaultScene": {"nodes": ["node_1"]}},
        "nodes": {"node_1": {"meshes": ["mesh_1"]}},
        "meshes": {"mesh_1": {"primitives": []}},
        "materials": {"mat_1": {"values": {"diffuse": [1, 0, 0, 1]}}}
    });
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let Err(e) = load_scene(&path) else {
        panic!("a glTF 1.0 document was loaded");
    };
    let want = format!(
        "{}: glTF version 1.0; only version 2 is supported",
        path.display()
    );
    assert_eq!(format!("{e:#}"), want);
    let r = crate::support::ftpd3d(&["--scene", path.to_str().unwrap(), "--explain"]);
    assert!(!r.ok);
    assert_eq!(r.err.trim(), format!("error: {want}"));
}

/// A glTF scene without triangles (here: only a point light) is refused as empty, naming the
/// file, through the binary, even with `--window` (which used to fail for lack of bounds).
#[test]
fn gltf_without_triangles_is_an_empty_scene() {
    let dir = temp_dir("gltf", "no_triangles");
    let path = dir.join("lamp_only.gltf");
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 10.0}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"translation": [0.0, 1.0, 0.0],
                   "extensions": {"KHR_lights_punctual": {"light": 0}}}]
    });
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let want = format!(
        "error: {}: no geometry: the scene's nodes reference no triangles (primitives of mode \
         TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN)",
        path.display()
    );
    for extra in [&[][..], &["--window=-1,0,1,2"][..]] {
        let mut args = vec!["--scene", path.to_str().unwrap(), "--slice", "z=0"];
        args.extend_from_slice(extra);
        let r = crate::support::ftpd3d(&args);
        assert!(!r.ok, "{extra:?}");
        assert_eq!(r.err.trim(), want, "{extra:?}");
    }
}

/// A scene without lights: radiance weighting is refused with the ways to add one, in the glTF's
/// own terms (not the MTL's Ke); a camera run goes on but warns that its beauty image is black.
#[test]
fn gltf_without_lights_names_the_ways_to_add_one() {
    let dir = temp_dir("gltf", "no_lights");
    let mut bin = Bin::default();
    let mesh = quad(&mut bin, "Quad", None);
    let extra = json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [mesh],
    });
    let path = bin.write_embedded(&dir, "dark.gltf", extra);
    let p = path.to_str().unwrap();
    let r = crate::support::ftpd3d_in(&dir, &["--scene", p, "--slice", "z=0", "--quiet"]);
    assert!(!r.ok);
    assert_eq!(
        r.err.trim(),
        format!(
            "error: --weight radiance: {p} has no lights (no emissive material (emissiveFactor) \
             and no KHR_lights_punctual light); add one with --point-light X,Y,Z:R,G,B \
             (position and radiant intensity), --sun X,Y,Z:R,G,B (direction and irradiance), \
             --sky R,G,B or --env FILE, or use --weight unweighted"
        )
    );
    let r = crate::support::ftpd3d_in(
        &dir,
        &[
            "--scene",
            p,
            "--eye",
            "0.5,0.5,2",
            "--target",
            "0.5,0.5,0",
            "--size",
            "4,4",
            "--spp",
            "1",
            "--quiet",
            "--no-png",
            "-o",
            "cam.exr",
        ],
    );
    assert!(r.ok, "{}", r.err);
    assert!(
        r.err.contains(&format!(
            "warning: {p} has no lights (no emissive material (emissiveFactor) and no \
             KHR_lights_punctual light): the beauty image (radiance.R/G/B) will be black; add \
             one with --point-light X,Y,Z:R,G,B, --sun X,Y,Z:R,G,B, --sky R,G,B or --env FILE"
        )),
        "{}",
        r.err
    );
}

/// A PNG of `w` × `h` grey-or-colour RGB bytes as a base64 data URI.
fn png_uri(w: u32, h: u32, rgb: Vec<u8>) -> String {
    let mut png = Vec::new();
    image::RgbImage::from_raw(w, h, rgb)
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&png)
    )
}

/// The unit quad in z = 0 with TEXCOORD_0 running over the texture (u along x; glTF's v points
/// down, so the top edge y = 1 is v = 0): (positions, uvs, indices) accessors.
pub(crate) fn textured_quad(bin: &mut Bin) -> (usize, usize, usize) {
    let pos = bin.vec3(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
    let uv_bytes: Vec<u8> = [[0f32, 1.], [1., 1.], [1., 0.], [0., 0.]]
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let uv_view = bin.view(&uv_bytes);
    bin.accessors
        .push(json!({"bufferView": uv_view, "componentType": 5126, "count": 4, "type": "VEC2"}));
    let uv = bin.accessors.len() - 1;
    let idx = bin.indices(&[0, 1, 2, 0, 2, 3]);
    (pos, uv, idx)
}

/// A quad with a 2 × 1 base-colour texture (an embedded PNG: sRGB 255 and 128), factor 0.8, under
/// a delta sun overhead: at each texel's centre the quad reflects 0.8 × the texel (decoded to
/// linear by the sRGB formula written out here) / π × E, to rounding; half-way between, the
/// bilinear mean. A KHR_texture_transform offset of half the width moves the lookup by it.
#[test]
fn gltf_base_colour_texture_gives_each_texel_its_albedo() {
    use ftpd3d::kernel::Radiance3D;
    use ftpd3d::rng::Sampler;
    use ftpd3d::transport::walk::{RadianceStats, radiance};
    let srgb = |c: f64| {
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let png_uri = png_uri(2, 1, vec![255, 255, 255, 128, 128, 128]);
    for (k, offset) in [0.0, 0.5].into_iter().enumerate() {
        let dir = temp_dir("gltf", &format!("texture{k}"));
        let mut bin = Bin::default();
        let (pos, uv, idx) = textured_quad(&mut bin);
        let mut info = json!({"index": 0});
        if offset != 0.0 {
            info["extensions"] = json!({"KHR_texture_transform": {"offset": [offset, 0.0]}});
        }
        let extra = json!({
            "extensionsUsed": ["KHR_texture_transform"],
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{
                "attributes": {"POSITION": pos, "TEXCOORD_0": uv},
                "indices": idx, "material": 0}]}],
            "materials": [{"pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0,
                "roughnessFactor": 1.0, "baseColorTexture": info}}],
            "textures": [{"source": 0, "sampler": 0}],
            "samplers": [{"wrapS": 33071, "wrapT": 33071}],
            "images": [{"uri": png_uri}],
        });
        let path = bin.write_embedded(&dir, "textured.gltf", extra);
        let mut scene = load_scene(&path).unwrap();
        assert!(scene.features.textures);
        // An 8-bit image keeps its bytes: 4 B per texel.
        assert_eq!(scene.report.texture_bytes, 2 * 4);
        let e = 2.0;
        scene.add_light(Light::distant(DVec3::Z, Rgb::splat(e), 0.0));
        let (left, right) = (srgb(1.0), srgb(128.0 / 255.0));
        let kd = |x: f64| {
            // The offset moves u; then bilinear between the texel centres at u = 0.25 and 0.75,
            // clamped to the edge texels outside them (the sampler clamps).
            let t = ((x + offset - 0.25) / 0.5).clamp(0.0, 1.0);
            0.8 * (left * (1.0 - t) + right * t)
        };
        let mut s = Sampler::new(5, 0, 0);
        for x in [0.1, 0.25, 0.5, 0.75, 0.9] {
            let q = DVec3::new(x, 0.5, 0.0);
            let eye = DVec3::new(0.5, 0.5, 1.0);
            let mut st = RadianceStats::default();
            let l = radiance::<Radiance3D>(&scene, eye, (q - eye).normalize(), 4, &mut s, &mut st)
                .total();
            // The reflection reaches the eye off-normal, but Lambertian: the same radiance.
            let expected = kd(x) / std::f64::consts::PI * e;
            assert!(
                (l.x - expected).abs() <= 1e-6 * expected,
                "offset {offset}, x = {x}: {} vs {expected}",
                l.x
            );
        }
    }
}

/// An emissive quad whose emissiveTexture is 2 × 1 (sRGB 255 and 128), emissiveFactor 2: a hit at
/// each texel's centre sees 2 × the texel, decoded to linear.
#[test]
fn gltf_emissive_texture_scales_the_emission_per_texel() {
    let png_uri = png_uri(2, 1, vec![255, 255, 255, 128, 128, 128]);
    let dir = temp_dir("gltf", "emissive_texture");
    let mut bin = Bin::default();
    let (pos, uv, idx) = textured_quad(&mut bin);
    let extra = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": 0}]}],
        "materials": [{"emissiveFactor": [2.0, 2.0, 2.0], "emissiveTexture": {"index": 0},
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 33071, "wrapT": 33071}],
        "images": [{"uri": png_uri}],
    });
    let path = bin.write_embedded(&dir, "emissive.gltf", extra);
    let scene = load_scene(&path).unwrap();
    assert!(scene.features.emission_textures);
    let srgb_128 = ((128.0 / 255.0 + 0.055) / 1.055f64).powf(2.4);
    for (x, texel) in [(0.25, 1.0), (0.75, srgb_128)] {
        let o = DVec3::new(x, 0.5, 1.0);
        let hit = scene.intersect(o, -DVec3::Z, f64::INFINITY).unwrap();
        let l = scene.emitted(&hit, DVec3::Z);
        assert!(
            (l.x - 2.0 * texel).abs() < 1e-5,
            "x = {x}: {} vs {}",
            l.x,
            2.0 * texel
        );
    }
}

/// KHR_texture_transform's rotation on a texture whose orientation matters (4 × 4 texels, each
/// its own grey): at quad points whose transformed UV lands on a texel's centre, the emission is
/// that texel's. The expected texel comes from the extension's `T · R · S` written out here (glTF's
/// UV space, v down, `u' = cos u + sin v`, `v' = −sin u + cos v`: the turn the extension's worked
/// example, its sample model TextureTransformTest (whose 22.5° this uses) and the common
/// implementations agree on); the mirrored turn would land on other texels at most of the points
/// checked.
#[test]
fn gltf_texture_transform_rotation_lands_on_the_texel_the_extension_defines() {
    let levels: Vec<u8> = (0..16u8).map(|k| 15 + 15 * k).collect();
    let rgb: Vec<u8> = levels.iter().flat_map(|&g| [g, g, g]).collect();
    let png_uri = png_uri(4, 4, rgb);
    let (rotation, offset, scale) = (std::f64::consts::FRAC_PI_8, [0.1f64, -0.05], [0.9f64, 1.1]);
    let dir = temp_dir("gltf", "texture_rotation");
    let mut bin = Bin::default();
    let (pos, uv, idx) = textured_quad(&mut bin);
    let extra = json!({
        "extensionsUsed": ["KHR_texture_transform"],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": 0}]}],
        "materials": [{"emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": {"index": 0,
            "extensions": {"KHR_texture_transform": {
                "rotation": rotation, "offset": offset, "scale": scale}}},
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 33071, "wrapT": 33071}],
        "images": [{"uri": png_uri}],
    });
    let path = bin.write_embedded(&dir, "rotated.gltf", extra);
    let scene = load_scene(&path).unwrap();
    let srgb = |c: f64| ((c + 0.055) / 1.055f64).powf(2.4);
    // The file's f32 values, as the loader reads them.
    let (rotation, offset, scale) = (
        rotation as f32 as f64,
        offset.map(|x| x as f32 as f64),
        scale.map(|x| x as f32 as f64),
    );
    let (sn, cs) = rotation.sin_cos();
    // The UV (u, v) whose transform is (s, t): S⁻¹ R⁻¹ (s − offset, t − offset).
    let inverse = |s: f64, t: f64| {
        let (a, b) = (s - offset[0], t - offset[1]);
        ((cs * a - sn * b) / scale[0], (sn * a + cs * b) / scale[1])
    };
    let mirrored = |u: f64, v: f64| {
        let (a, b) = (u * scale[0], v * scale[1]);
        (cs * a - sn * b + offset[0], sn * a + cs * b + offset[1])
    };
    let (mut checked, mut discriminating) = (0, 0);
    for row in 0..4 {
        for col in 0..4 {
            let (u, v) = inverse((col as f64 + 0.5) / 4.0, (row as f64 + 0.5) / 4.0);
            if !(0.02..0.98).contains(&u) || !(0.02..0.98).contains(&v) {
                continue;
            }
            // The quad's point of that UV: x = u, y = 1 − v.
            let o = DVec3::new(u, 1.0 - v, 1.0);
            let hit = scene.intersect(o, -DVec3::Z, f64::INFINITY).unwrap();
            let l = scene.emitted(&hit, DVec3::Z).x;
            let want = srgb(levels[row * 4 + col] as f64 / 255.0);
            assert!(
                (l - want).abs() < 1e-5,
                "texel (col {col}, row {row}) at uv ({u:.3}, {v:.3}): {l} vs {want}"
            );
            checked += 1;
            let (ms, mt) = mirrored(u, v);
            let other = ((mt * 4.0).floor() as i64, (ms * 4.0).floor() as i64);
            discriminating += (other != (row as i64, col as i64)) as usize;
        }
    }
    assert!(checked >= 6, "{checked} texels checked");
    assert!(
        discriminating * 2 > checked,
        "{discriminating} of {checked}"
    );
}

/// Appends a quad in z = `z` over [x0, x1] × [0, 1] (front side +z) to `pos`/`uv`/`idx`, its
/// TEXCOORD_0 u running from `u0` to `u1` along x (v = 1 − y, glTF's v pointing down).
fn quad_at(
    pos: &mut Vec<[f32; 3]>,
    uv: &mut Vec<[f32; 2]>,
    idx: &mut Vec<u16>,
    [x0, x1]: [f32; 2],
    z: f32,
    [u0, u1]: [f32; 2],
) {
    let b = pos.len() as u16;
    for (x, y, u) in [(x0, 0., u0), (x1, 0., u1), (x1, 1., u1), (x0, 1., u0)] {
        pos.push([x, y, z]);
        uv.push([u, 1.0 - y]);
    }
    idx.extend([b, b + 1, b + 2, b, b + 2, b + 3]);
}

/// A primitive's accessors: (positions, uvs, indices).
fn primitive(bin: &mut Bin, pos: &[[f32; 3]], uv: &[[f32; 2]], idx: &[u16]) -> Value {
    let p = bin.vec3(pos);
    let uv_bytes: Vec<u8> = uv.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let view = bin.view(&uv_bytes);
    bin.accessors.push(
        json!({"bufferView": view, "componentType": 5126, "count": uv.len(), "type": "VEC2"}),
    );
    let t = bin.accessors.len() - 1;
    let i = bin.indices(idx);
    json!({"attributes": {"POSITION": p, "TEXCOORD_0": t}, "indices": i})
}

/// Roughness of the metal texel of [`mr_two_texel_scene`]: the 8-bit value 77, read as stored.
const METAL_G: u8 = 77;

/// A floor (z = 0, 0.5 grey, Lambertian) under a quad at z = 1 over x ∈ [0, 1], y ∈ [0, 1], base
/// colour 0.8. `textured`: one material with metallicFactor = roughnessFactor = 1 and a 2 × 1
/// metallic-roughness texture (clamped) whose left texel is a rough dielectric (G 255, B 0: r = 1,
/// m = 0) and right texel a glossy metal (G 77, B 255: r = 77/255, m = 1); the left half of the
/// quad has u ∈ [0, ¼] and the right half u ∈ [¾, 1], where the bilinear lookup gives exactly one
/// texel. Otherwise: the two halves with constant materials of those values (the mapping makes
/// them a Lambertian and a Phong lobe, through no texture).
fn mr_two_texel_scene(dir: &Path, textured: bool) -> Scene {
    let mut bin = Bin::default();
    // (x range, u range) of the two halves.
    let halves = [([0., 0.5], [0., 0.25]), ([0.5, 1.], [0.75, 1.])];
    // (material, the quads of one primitive as (x range, height, u range)).
    type Quad = ([f32; 2], f32, [f32; 2]);
    let parts: Vec<(usize, Vec<Quad>)> = if textured {
        vec![
            (0, vec![([-2., 3.], 0.0, [0., 0.])]),
            (1, halves.iter().map(|&(x, u)| (x, 1.0, u)).collect()),
        ]
    } else {
        vec![
            (0, vec![([-2., 3.], 0.0, [0., 0.])]),
            (1, vec![(halves[0].0, 1.0, halves[0].1)]),
            (2, vec![(halves[1].0, 1.0, halves[1].1)]),
        ]
    };
    let prims: Vec<Value> = parts
        .into_iter()
        .map(|(material, quads)| {
            let (mut pos, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new());
            for (x, z, u) in quads {
                quad_at(&mut pos, &mut uv, &mut idx, x, z, u);
            }
            let mut prim = primitive(&mut bin, &pos, &uv, &idx);
            prim["material"] = json!(material);
            prim
        })
        .collect();
    let pbr = |m: f64, r: f64| {
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
            "metallicFactor": m, "roughnessFactor": r}})
    };
    let floor_material = json!({"pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}});
    let mut extra = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": prims}],
    });
    if textured {
        let mut m = pbr(1.0, 1.0);
        m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = json!({"index": 0});
        extra["materials"] = json!([floor_material, m]);
        extra["textures"] = json!([{"source": 0, "sampler": 0}]);
        extra["samplers"] = json!([{"wrapS": 33071, "wrapT": 33071}]);
        extra["images"] = json!([{"uri": png_uri(2, 1, vec![0, 255, 0, 0, METAL_G, 255])}]);
    } else {
        let r = (METAL_G as f32 / 255.0) as f64;
        extra["materials"] = json!([floor_material, pbr(0.0, 1.0), pbr(1.0, r)]);
    }
    let name = if textured { "mr.gltf" } else { "constant.gltf" };
    let path = bin.write_embedded(dir, name, extra);
    let mut scene = load_scene(&path).unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    scene.add_point_light(DVec3::new(0.4, 0.5, 3.0), Rgb::splat(20.0));
    scene
}

/// σ (unweighted and radiance-weighted) and fluence at points over each texel, above and below
/// the quad, in the plane y = 0.5 (in flatland: the slice plane), for the textured quad and for
/// the two constant quads, with independent seeds: the difference of each pair over its combined
/// standard error.
fn mr_z_scores(flatland: bool) -> Vec<(String, f64)> {
    use ftpd3d::ftpd::Params;
    let dir = temp_dir("gltf", if flatland { "mr_flat" } else { "mr_3d" });
    let mut scenes = [
        mr_two_texel_scene(&dir, true),
        mr_two_texel_scene(&dir, false),
    ];
    assert!(scenes[0].features.textures && scenes[0].features.glossy);
    assert!(scenes[0].features.diffuse && !scenes[0].features.mirror);
    assert_eq!(scenes[0].report.texture_bytes, 2 * 4);
    let plane = ftpd3d::kernel::Flatland::new(DVec3::new(0.0, 0.5, 0.0), DVec3::X, DVec3::Z);
    if flatland {
        for s in &mut scenes {
            s.prepare_flatland(plane, "y=0.5").unwrap();
        }
    }
    let points: Vec<DVec3> = [0.1, 0.25, 0.4, 0.6, 0.75, 0.9]
        .into_iter()
        .flat_map(|x| [0.3, 0.7, 1.3, 1.8].map(|height| DVec3::new(x, 0.5, height)))
        .collect();
    let params = |weighting| Params {
        t0: 0.3,
        t1: 0.8,
        theta_max: 0.15,
        weighting,
        max_bounces: 8,
        radiance_bounces: None,
        flat: flatland.then_some(plane),
        design: ftpd3d::ftpd::Design::default_for(weighting),
        guide: false,
    };
    crate::support::z_scores_of_two_scenes([&scenes[0], &scenes[1]], &points, params, 21, 3000)
}

/// A quad whose metallic-roughness texture has two texels gives, over each texel, the σ and
/// fluence of a quad of constant material with that texel's values (3D).
#[test]
fn gltf_metallic_roughness_texels_match_constant_materials_3d() {
    crate::support::assert_consistent("3D", &mr_z_scores(false));
}

/// The same in flatland, where the Phong lobe's normalisation of each texel's exponent is
/// computed per hit (in closed form) and the constant material's once (by recurrence).
#[test]
fn gltf_metallic_roughness_texels_match_constant_materials_flatland() {
    crate::support::assert_consistent("flatland", &mr_z_scores(true));
}

/// The metallic-roughness texture through the loader: read as stored (G 128 is r = 128/255, not
/// its sRGB decoding), with the sampler's wrap modes and KHR_texture_transform, on TEXCOORD_0;
/// a base-colour texture multiplies baseColorFactor per hit; an image that is both base colour
/// and metallic-roughness is decoded once for each reading (both counted in the texture
/// memory). The metallic-roughness texture gives no warning, a normal texture still does, and so
/// does a metallic-roughness texture on a transmissive material.
#[test]
fn gltf_metallic_roughness_texture_is_read_linear_with_its_sampler_and_transform() {
    use ftpd3d::scene::gltf::phong_exponent;
    let srgb = |c: f64| ((c + 0.055) / 1.055f64).powf(2.4);
    // Left texel: G 128, B 0 (r = 128/255, m = 0); right: G 255, B 255 (r = 1, m = 1).
    let mr_png = png_uri(2, 1, vec![0, 128, 0, 0, 255, 255]);
    let grey_png = png_uri(1, 1, vec![128, 128, 128]);
    let r_left = (128f32 / 255.0) as f64;
    // (wrapS, offset, the texel read at x = 0.25 and x = 0.75: true for the left one).
    let cases = [
        (33071, 0.0, [true, false]),
        (10497, 0.5, [false, true]),
        (33071, 0.5, [false, false]),
    ];
    for (k, (wrap, offset, left)) in cases.into_iter().enumerate() {
        let dir = temp_dir("gltf", &format!("mr_sampler{k}"));
        let mut bin = Bin::default();
        let (pos, uv, idx) = textured_quad(&mut bin);
        let mut info = json!({"index": 0});
        if offset != 0.0 {
            info["extensions"] = json!({"KHR_texture_transform": {"offset": [offset, 0.0]}});
        }
        let extra = json!({
            "extensionsUsed": ["KHR_texture_transform", "KHR_materials_transmission"],
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{
                "attributes": {"POSITION": pos, "TEXCOORD_0": uv},
                "indices": idx, "material": 0}]}],
            "materials": [
                {"pbrMetallicRoughness": {
                    "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 1.0,
                    "roughnessFactor": 1.0, "metallicRoughnessTexture": info,
                    "baseColorTexture": {"index": 1}}},
                {"pbrMetallicRoughness": {"baseColorTexture": {"index": 2}},
                    "normalTexture": {"index": 0}},
                {"pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 0}},
                    "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}},
            ],
            "textures": [{"source": 0, "sampler": 0}, {"source": 1}, {"source": 0}],
            "samplers": [{"wrapS": wrap, "wrapT": 33071}],
            "images": [{"uri": mr_png.clone()}, {"uri": grey_png.clone()}],
        });
        let path = bin.write_embedded(&dir, "mr.gltf", extra);
        let scene = load_scene(&path).unwrap();
        let w = &scene.report.warnings;
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(
            w.iter().any(|w| w.contains(
                "normal, occlusion and transmission textures are ignored (1 material(s)"
            )),
            "{w:?}"
        );
        assert!(
            w.iter()
                .any(|w| w.contains("metallic-roughness texture ignored on a transmissive")),
            "{w:?}"
        );
        assert!(!w.iter().any(|w| w.contains("material #0")), "{w:?}");
        // Image 0 as metallic-roughness (linear) and as base colour (sRGB), image 1 once.
        assert_eq!(scene.report.texture_bytes, 2 * 2 * 4 + 4);
        let base = 0.8 * srgb(128.0 / 255.0);
        for (x, left) in [0.25, 0.75].into_iter().zip(left) {
            let o = DVec3::new(x, 0.5, 1.0);
            let hit = scene.intersect(o, -DVec3::Z, f64::INFINITY).unwrap();
            let Some(Bsdf::Glossy { kd, ks, exponent }) = scene.textured_bsdf(&hit) else {
                panic!("case {k}, x = {x}: not glossy");
            };
            // Left: m = 0, kd = base, ks = 0.04; right: m = 1, kd = 0, ks = base.
            let (kd_e, ks_e, r) = if left {
                (base, 0.04, r_left)
            } else {
                (0.0, base, 1.0)
            };
            let msg = format!("case {k}, x = {x}: {kd:?} {ks:?} {exponent}");
            assert!(
                (kd.x - kd_e).abs() < 1e-6 && (ks.x - ks_e).abs() < 1e-6,
                "{msg}"
            );
            // To the f32 rounding of the interpolated texture coordinate, which moves the
            // bilinear weights by ~1e-7 (an sRGB decoding would give r = 0.216, n = 919).
            assert!((exponent / phong_exponent(r) - 1.0).abs() < 1e-5, "{msg}");
        }
    }
}
