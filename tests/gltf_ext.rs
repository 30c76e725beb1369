//! glTF extensions that change how geometry is stored or placed: KHR_mesh_quantization,
//! EXT_meshopt_compression, KHR_draco_mesh_compression, EXT_mesh_gpu_instancing, and
//! extensionsRequired. The compressed files are made here by the reference encoders (the
//! `meshopt` crate, which builds meshoptimizer's own C++ encoder, and `draco-core`'s encoder) from
//! the same mesh as an uncompressed file, and both must load to the same world-space triangles.

use crate::support::temp_dir;
use base64::Engine as _;
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::load_scene;
use glam::{DQuat, DVec3, Vec3};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The buffer of a test file, its views and accessors.
#[derive(Default)]
struct Buf {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buf {
    /// Appends `bytes` (4-aligned) and returns their offset.
    fn push(&mut self, bytes: &[u8]) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        self.data.extend_from_slice(bytes);
        self.data.len() - bytes.len()
    }

    /// A view of `bytes` (with `stride` when given).
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        let at = self.push(bytes);
        let mut v = json!({"buffer": 0, "byteOffset": at, "byteLength": bytes.len()});
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(
        &mut self,
        view: Option<usize>,
        ctype: u32,
        norm: bool,
        count: usize,
        ty: &str,
    ) -> usize {
        let mut a = json!({"componentType": ctype, "count": count, "type": ty});
        if let Some(v) = view {
            a["bufferView"] = json!(v);
        }
        if norm {
            a["normalized"] = json!(true);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// Sets a POSITION accessor's min and max (required by glTF).
    fn bounds(&mut self, acc: usize, p: &[[f32; 3]]) {
        let lo: Vec<f32> = (0..3)
            .map(|k| p.iter().map(|v| v[k]).fold(f32::MAX, f32::min))
            .collect();
        let hi: Vec<f32> = (0..3)
            .map(|k| p.iter().map(|v| v[k]).fold(f32::MIN, f32::max))
            .collect();
        self.accessors[acc]["min"] = json!(lo);
        self.accessors[acc]["max"] = json!(hi);
    }

    /// Writes `name` with the buffer as a data URI, the keys of `extra` added to the document.
    fn write(&self, dir: &Path, name: &str, extra: Value) -> PathBuf {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.data)
        );
        let mut doc = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": self.data.len(), "uri": uri}],
            "bufferViews": self.views,
            "accessors": self.accessors,
        });
        for (k, v) in extra.as_object().unwrap() {
            doc[k] = v.clone();
        }
        let path = dir.join(name);
        std::fs::write(&path, doc.to_string()).unwrap();
        path
    }
}

fn bytes<T: Copy, const N: usize>(v: &[[T; N]], f: impl Fn(T) -> Vec<u8>) -> Vec<u8> {
    v.iter().flatten().flat_map(|&x| f(x)).collect()
}

fn f32s<const N: usize>(v: &[[f32; N]]) -> Vec<u8> {
    bytes(v, |x: f32| x.to_le_bytes().to_vec())
}

/// A bumpy 6×6-vertex grid over [0, 2]² (z up to 0.3): positions, unit normals, uvs, and
/// triangles with one vertex list each (50 triangles).
struct Grid {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    indices: Vec<u32>,
}

fn grid() -> Grid {
    const N: usize = 6;
    let mut g = Grid {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        indices: Vec::new(),
    };
    for j in 0..N {
        for i in 0..N {
            let (u, v) = (i as f32 / (N - 1) as f32, j as f32 / (N - 1) as f32);
            let z = 0.3 * (3.0 * u).sin() * (2.0 * v).cos();
            g.positions.push([2.0 * u, 2.0 * v, z]);
            let n = Vec3::new(-0.45 * (3.0 * u).cos(), 0.3 * (3.0 * u).sin(), 1.0).normalize();
            g.normals.push(n.to_array());
            g.uvs.push([u, v]);
        }
    }
    for j in 0..N - 1 {
        for i in 0..N - 1 {
            let a = (j * N + i) as u32;
            let (b, c, d) = (a + 1, a + N as u32, a + N as u32 + 1);
            g.indices.extend([a, b, d, a, d, c]);
        }
    }
    g
}

/// The document keys of one mesh (its primitive `prim`) on one node, with the extensions named.
fn one_mesh(prim: Value, used: &[&str], required: &[&str]) -> Value {
    json!({
        "extensionsUsed": used,
        "extensionsRequired": required,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"name": "Grid", "primitives": [prim]}],
    })
}

/// The grid as plain f32 attributes and u32 indices.
fn write_plain(dir: &Path, g: &Grid) -> PathBuf {
    let mut b = Buf::default();
    let v = b.view(&f32s(&g.positions), None);
    let pos = b.accessor(Some(v), 5126, false, g.positions.len(), "VEC3");
    b.bounds(pos, &g.positions);
    let v = b.view(&f32s(&g.normals), None);
    let nrm = b.accessor(Some(v), 5126, false, g.normals.len(), "VEC3");
    let v = b.view(&f32s(&g.uvs), None);
    let uv = b.accessor(Some(v), 5126, false, g.uvs.len(), "VEC2");
    let idx: Vec<u8> = g.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let v = b.view(&idx, None);
    let ind = b.accessor(Some(v), 5125, false, g.indices.len(), "SCALAR");
    let prim =
        json!({"attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv}, "indices": ind});
    b.write(dir, "plain.gltf", one_mesh(prim, &[], &[]))
}

/// Each triangle's world-space vertices, starting at its smallest vertex (winding kept), sorted:
/// a description of the geometry that does not depend on vertex or triangle order.
fn triangle_set(scene: &Scene) -> Vec<[[f64; 3]; 3]> {
    let mut out: Vec<[[f64; 3]; 3]> = scene
        .triangles
        .iter()
        .map(|t| {
            let v = t.map(|i| scene.positions[i as usize].as_dvec3().to_array());
            let k = (0..3)
                .min_by(|&a, &b| v[a].partial_cmp(&v[b]).unwrap())
                .unwrap();
            [v[k], v[(k + 1) % 3], v[(k + 2) % 3]]
        })
        .collect();
    out.sort_by(|a, b| a.partial_cmp(b).unwrap());
    out
}

/// Asserts that `a` and `b` hold the same triangles to within `tol` per coordinate, and the same
/// shading normals and uvs at the centre of each triangle (within `ntol`, `uvtol`).
fn assert_same_scene(a: &Scene, b: &Scene, tol: f64, what: &str) {
    assert_eq!(
        a.triangles.len(),
        b.triangles.len(),
        "{what}: triangle count"
    );
    // Coordinates are compared after snapping to a grid coarser than the tolerance, so that the
    // sort orders agree.
    let snap = |s: &Scene| -> Vec<[[i64; 3]; 3]> {
        let mut t: Vec<_> = triangle_set(s)
            .into_iter()
            .map(|t| t.map(|v| v.map(|x| (x / 0.05).round() as i64)))
            .collect();
        t.sort();
        t
    };
    assert_eq!(snap(a), snap(b), "{what}: triangles differ");
    let (ta, tb) = (triangle_set(a), triangle_set(b));
    let worst = ta
        .iter()
        .flatten()
        .flatten()
        .zip(tb.iter().flatten().flatten())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= tol,
        "{what}: coordinates differ by {worst} > {tol}"
    );
}

/// Shoots a ray down at (x, y) and returns the hit's shading normal.
fn normal_at(scene: &Scene, x: f64, y: f64) -> DVec3 {
    let hit = scene
        .intersect(DVec3::new(x, y, 5.0), -DVec3::Z, f64::INFINITY)
        .unwrap_or_else(|| panic!("no hit at ({x}, {y})"));
    hit.ns
}

fn assert_same_normals(a: &Scene, b: &Scene, tol: f64, what: &str) {
    for (x, y) in [(0.3, 0.3), (1.1, 0.7), (1.7, 1.6), (0.5, 1.9)] {
        let (na, nb) = (normal_at(a, x, y), normal_at(b, x, y));
        assert!(
            (na - nb).length() < tol,
            "{what}: normal at ({x}, {y}) {na} vs {nb}"
        );
    }
}

#[test]
fn gltf_quantized_attributes_read_as_the_extension_says() {
    let dir = temp_dir("gltf_ext", "quantized");
    let g = grid();
    let plain = load_scene(&write_plain(&dir, &g)).unwrap();
    // As gltfpack writes them: positions as i16 in units of 1/10000 with the node scaling back,
    // normals as normalised i8 (padded to 4 bytes), uvs as normalised u16.
    let mut b = Buf::default();
    let q: Vec<[i16; 3]> = g
        .positions
        .iter()
        .map(|p| p.map(|x| (x * 10000.0).round() as i16))
        .collect();
    // Elements of a vertex attribute are 4-byte aligned: i16 VEC3 padded to a stride of 8.
    let padded: Vec<u8> = q
        .iter()
        .flat_map(|p| {
            p.iter()
                .flat_map(|x| x.to_le_bytes())
                .chain([0, 0])
                .collect::<Vec<_>>()
        })
        .collect();
    let v = b.view(&padded, Some(8));
    let pos = b.accessor(Some(v), 5122, false, q.len(), "VEC3");
    let qf: Vec<[f32; 3]> = q.iter().map(|p| p.map(f32::from)).collect();
    b.bounds(pos, &qf);
    let n8: Vec<[i8; 4]> = g
        .normals
        .iter()
        .map(|n| [n[0], n[1], n[2], 0.0].map(|x| (x * 127.0).round() as i8))
        .collect();
    let v = b.view(&bytes(&n8, |x: i8| vec![x as u8]), Some(4));
    let nrm = b.accessor(Some(v), 5120, true, n8.len(), "VEC3");
    let uv16: Vec<[u16; 2]> = g
        .uvs
        .iter()
        .map(|t| t.map(|x| (x * 65535.0).round() as u16))
        .collect();
    let v = b.view(&bytes(&uv16, |x: u16| x.to_le_bytes().to_vec()), None);
    let uv = b.accessor(Some(v), 5123, true, uv16.len(), "VEC2");
    let idx: Vec<u8> = g
        .indices
        .iter()
        .flat_map(|&i| (i as u16).to_le_bytes())
        .collect();
    let v = b.view(&idx, None);
    let ind = b.accessor(Some(v), 5123, false, g.indices.len(), "SCALAR");
    let prim =
        json!({"attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv}, "indices": ind});
    let mut doc = one_mesh(prim, &["KHR_mesh_quantization"], &["KHR_mesh_quantization"]);
    doc["nodes"][0]["scale"] = json!([1e-4, 1e-4, 1e-4]);
    let path = b.write(&dir, "quantized.gltf", doc.clone());
    let scene = load_scene(&path).unwrap();
    // Positions round to 1e-4 (half a unit: 5e-5), in f32 after the node's scale.
    assert_same_scene(&plain, &scene, 6e-5, "quantized");
    // An i8 normal is within 1/127 per component of the unit normal it rounds.
    assert_same_normals(&plain, &scene, 0.02, "quantized");
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    // The same file without the extension declared: an integer POSITION is an error naming it.
    let mut undeclared = doc;
    undeclared["extensionsUsed"] = json!([]);
    undeclared["extensionsRequired"] = json!([]);
    let path = b.write(&dir, "undeclared.gltf", undeclared);
    let e = format!("{:#}", anyhow_like(load_scene(&path).err().unwrap()));
    assert!(
        e.contains("POSITION accessor #0 is not VEC3 f32 (it is VEC3 i16)"),
        "{e}"
    );
}

/// The error with its sources, one line.
fn anyhow_like(e: impl std::error::Error) -> String {
    let mut s = e.to_string();
    let mut src = e.source();
    while let Some(x) = src {
        s += &format!(": {x}");
        src = x.source();
    }
    s
}

/// The grid compressed with EXT_meshopt_compression by meshoptimizer's own encoder (vertex codec
/// version 0, as the extension defines): positions as f32 (no filter), normals with the
/// octahedral filter in 8 bits, uvs with the exponential filter, indices in mode `index_mode`.
fn write_meshopt(dir: &Path, g: &Grid, index_mode: &str) -> PathBuf {
    // Buffer 0: the compressed streams; buffer 1: the fallback, marked and without data.
    let mut b = Buf::default();
    let mut views = Vec::new();
    let mut fallback_len = 0usize;
    let mut compressed =
        |b: &mut Buf, stream: &[u8], count: usize, stride: usize, mode: &str, filter: &str| {
            let at = b.push(stream);
            let length = count * stride;
            views.push(json!({
                "buffer": 1, "byteOffset": fallback_len, "byteLength": length, "byteStride": stride,
                "extensions": {"EXT_meshopt_compression": {
                    "buffer": 0, "byteOffset": at, "byteLength": stream.len(),
                    "byteStride": stride, "count": count, "mode": mode, "filter": filter
                }}
            }));
            fallback_len += length.next_multiple_of(4);
            views.len() - 1
        };
    let n = g.positions.len();
    let pos_stream = meshopt::encode_vertex_buffer_level(&g.positions, 2, Some(0)).unwrap();
    let pv = compressed(&mut b, &pos_stream, n, 12, "ATTRIBUTES", "NONE");
    let n4: Vec<[f32; 4]> = g.normals.iter().map(|v| [v[0], v[1], v[2], 0.0]).collect();
    let oct: Vec<[i8; 4]> = meshopt::encode_filter_oct::<i8>(&n4, 8);
    let nrm_stream = meshopt::encode_vertex_buffer_level(&oct, 2, Some(0)).unwrap();
    let nv = compressed(&mut b, &nrm_stream, n, 4, "ATTRIBUTES", "OCTAHEDRAL");
    let exp = meshopt::encode_filter_exp::<2>(&g.uvs, 15, meshopt::EncodeExpMode::Separate);
    let uv_stream = meshopt::encode_vertex_buffer_level(&exp, 2, Some(0)).unwrap();
    let uvv = compressed(&mut b, &uv_stream, n, 8, "ATTRIBUTES", "EXPONENTIAL");
    let idx_stream = match index_mode {
        "TRIANGLES" => meshopt::encode_index_buffer(&g.indices, n).unwrap(),
        _ => meshopt::encode_index_sequence(&g.indices, n).unwrap(),
    };
    let iv = compressed(&mut b, &idx_stream, g.indices.len(), 4, index_mode, "NONE");
    // Index views have no byteStride in glTF.
    views[iv].as_object_mut().unwrap().remove("byteStride");
    b.views = views;
    let pos = b.accessor(Some(pv), 5126, false, n, "VEC3");
    b.bounds(pos, &g.positions);
    let nrm = b.accessor(Some(nv), 5120, true, n, "VEC3");
    let uv = b.accessor(Some(uvv), 5126, false, n, "VEC2");
    let ind = b.accessor(Some(iv), 5125, false, g.indices.len(), "SCALAR");
    let prim =
        json!({"attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv}, "indices": ind});
    let ext = ["EXT_meshopt_compression", "KHR_mesh_quantization"];
    let mut doc = one_mesh(prim, &ext, &ext);
    let path = b.write(dir, &format!("meshopt-{index_mode}.gltf"), json!({}));
    // The fallback buffer after the data one.
    let mut root: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    root["buffers"].as_array_mut().unwrap().push(json!({
        "byteLength": fallback_len,
        "extensions": {"EXT_meshopt_compression": {"fallback": true}}
    }));
    for (k, v) in doc.as_object_mut().unwrap() {
        root[k] = v.take();
    }
    std::fs::write(&path, root.to_string()).unwrap();
    path
}

/// The .glb of the .gltf at `path`: its first buffer (a data URI) becomes the binary chunk.
fn to_glb(path: &Path) -> PathBuf {
    let mut root: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let uri = root["buffers"][0]["uri"].as_str().unwrap().to_string();
    let mut bin = base64::engine::general_purpose::STANDARD
        .decode(uri.split_once(',').unwrap().1)
        .unwrap();
    root["buffers"][0].as_object_mut().unwrap().remove("uri");
    let mut json = root.to_string().into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(0x4E4F534Au32.to_le_bytes());
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(0x004E4942u32.to_le_bytes());
    out.extend(bin);
    let glb = path.with_extension("glb");
    std::fs::write(&glb, out).unwrap();
    glb
}

#[test]
fn gltf_meshopt_compressed_grid_is_the_uncompressed_one() {
    let dir = temp_dir("gltf_ext", "meshopt");
    let g = grid();
    let plain = load_scene(&write_plain(&dir, &g)).unwrap();
    // As gltfpack writes them: .gltf with the streams in a buffer of their own, and .glb with the
    // streams in the binary chunk; the fallback buffer has no data either way.
    let files = ["TRIANGLES", "INDICES"].map(|mode| write_meshopt(&dir, &g, mode));
    let glb = to_glb(&files[0]);
    for (mode, path) in [
        ("TRIANGLES", &files[0]),
        ("INDICES", &files[1]),
        ("glb", &glb),
    ] {
        let scene = load_scene(path).unwrap();
        // Positions are stored losslessly.
        assert_same_scene(&plain, &scene, 0.0, mode);
        // 8-bit octahedral normals: within about 1/64 rad.
        assert_same_normals(&plain, &scene, 0.03, mode);
        assert!(
            scene.report.warnings.is_empty(),
            "{mode}: {:?}",
            scene.report.warnings
        );
    }
}

/// The ratified name, KHR_meshopt_compression, reads the EXT bitstream (attribute codec version 0,
/// the same filters): a file renamed to it, as the extension says existing files may be, loads as
/// the EXT one. Its attribute codec version 1 and COLOR filter, which this reader does not decode,
/// are refused naming the buffer view and what is missing.
#[test]
fn gltf_meshopt_under_the_khr_name_is_the_same_decoder() {
    let dir = temp_dir("gltf_ext", "meshopt_khr");
    let g = grid();
    let plain = load_scene(&write_plain(&dir, &g)).unwrap();
    let ext = write_meshopt(&dir, &g, "TRIANGLES");
    let text = std::fs::read_to_string(&ext)
        .unwrap()
        .replace("EXT_meshopt_compression", "KHR_meshopt_compression");
    assert!(
        text.contains("\"extensionsRequired\":[\"KHR_meshopt_compression\""),
        "{text}"
    );
    let khr = dir.join("khr.gltf");
    std::fs::write(&khr, &text).unwrap();
    let scene = load_scene(&khr).unwrap_or_else(|e| panic!("{e:#}"));
    assert_same_scene(&plain, &scene, 0.0, "KHR");
    assert_same_normals(&plain, &scene, 0.03, "KHR");
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );

    // Version 1 of the position stream, in place of version 0.
    let mut root: Value = serde_json::from_str(&text).unwrap();
    let v0 = meshopt::encode_vertex_buffer_level(&g.positions, 2, Some(0)).unwrap();
    let v1 = meshopt::encode_vertex_buffer_level(&g.positions, 2, Some(1)).unwrap();
    assert_eq!(v1[0], 0xa1);
    let uri = root["buffers"][0]["uri"].as_str().unwrap().to_string();
    let (head, data) = uri.split_once(',').unwrap();
    let mut bytes = base64::engine::general_purpose::STANDARD
        .decode(data)
        .unwrap();
    let at = root["bufferViews"][0]["extensions"]["KHR_meshopt_compression"]["byteOffset"]
        .as_u64()
        .unwrap() as usize;
    assert_eq!(&bytes[at..at + v0.len()], &v0[..]);
    bytes.splice(at..at + v0.len(), v1.iter().copied());
    let grown = v1.len() as i64 - v0.len() as i64;
    root["buffers"][0]["uri"] = json!(format!(
        "{head},{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    ));
    root["buffers"][0]["byteLength"] = json!(bytes.len());
    root["bufferViews"][0]["extensions"]["KHR_meshopt_compression"]["byteLength"] = json!(v1.len());
    for view in root["bufferViews"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .skip(1)
    {
        let e = &mut view["extensions"]["KHR_meshopt_compression"]["byteOffset"];
        *e = json!(e.as_i64().unwrap() + grown);
    }
    let v1_file = dir.join("khr_v1.gltf");
    std::fs::write(&v1_file, root.to_string()).unwrap();
    let e = format!("{:#}", load_scene(&v1_file).err().expect("v1 loaded"));
    assert!(
        e.contains("buffer view #0 (KHR_meshopt_compression)")
            && e.contains("attribute codec version 1"),
        "{e}"
    );
    // The COLOR filter.
    let mut root: Value = serde_json::from_str(&text).unwrap();
    root["bufferViews"][1]["extensions"]["KHR_meshopt_compression"]["filter"] = json!("COLOR");
    let color = dir.join("khr_color.gltf");
    std::fs::write(&color, root.to_string()).unwrap();
    let e = format!("{:#}", load_scene(&color).err().expect("COLOR loaded"));
    assert!(e.contains("buffer view #1") && e.contains("COLOR"), "{e}");
}

/// The grid as one Draco stream (positions quantized to `bits`, normals to 10 bits, uvs to 12)
/// at encoder speed `speed` (0: edgebreaker with valence coding; 10: the fastest coders).
fn write_draco(dir: &Path, g: &Grid, speed: i32, bits: i32) -> PathBuf {
    use draco_core::{
        DataType, EncoderBuffer, EncoderOptions, FaceIndex, GeometryAttributeType, Mesh,
        MeshEncoder, PointAttribute,
    };
    let n = g.positions.len();
    let attribute = |kind, values: Vec<f32>, k: u8| {
        let mut a = PointAttribute::new();
        a.init(kind, k, DataType::Float32, false, n);
        for (i, v) in values.iter().enumerate() {
            a.buffer_mut().write(i * 4, &v.to_le_bytes());
        }
        a
    };
    let mut mesh = Mesh::new();
    let flat = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<f32>>();
    let p = mesh.add_attribute(attribute(
        GeometryAttributeType::Position,
        flat(&g.positions),
        3,
    ));
    let nm = mesh.add_attribute(attribute(
        GeometryAttributeType::Normal,
        flat(&g.normals),
        3,
    ));
    let uv: Vec<f32> = g.uvs.iter().flatten().copied().collect();
    let t = mesh.add_attribute(attribute(GeometryAttributeType::TexCoord, uv, 2));
    mesh.set_num_faces(g.indices.len() / 3);
    for (f, tri) in g.indices.chunks_exact(3).enumerate() {
        mesh.set_face(
            FaceIndex(f as u32),
            [tri[0].into(), tri[1].into(), tri[2].into()],
        );
    }
    let ids = [p, nm, t].map(|a| mesh.attribute(a).unique_id());
    let mut options = EncoderOptions::new();
    options.set_global_int("encoding_speed", speed);
    options.set_global_int("decoding_speed", speed);
    options.set_attribute_int(p, "quantization_bits", bits);
    options.set_attribute_int(nm, "quantization_bits", 10);
    options.set_attribute_int(t, "quantization_bits", 12);
    let mut encoder = MeshEncoder::new();
    encoder.set_mesh(mesh);
    let mut out = EncoderBuffer::new();
    encoder.encode(&options, &mut out).unwrap();
    let mut b = Buf::default();
    let view = b.view(out.data(), None);
    // Accessors describe the decoded data and have no buffer view.
    let pos = b.accessor(None, 5126, false, n, "VEC3");
    b.bounds(pos, &g.positions);
    let nrm = b.accessor(None, 5126, false, n, "VEC3");
    let uvs = b.accessor(None, 5126, false, n, "VEC2");
    let ind = b.accessor(None, 5125, false, g.indices.len(), "SCALAR");
    let prim = json!({
        "attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uvs}, "indices": ind,
        "extensions": {"KHR_draco_mesh_compression": {
            "bufferView": view,
            "attributes": {"POSITION": ids[0], "NORMAL": ids[1], "TEXCOORD_0": ids[2]}
        }}
    });
    let ext = ["KHR_draco_mesh_compression"];
    b.write(
        dir,
        &format!("draco-{speed}.gltf"),
        one_mesh(prim, &ext, &ext),
    )
}

#[test]
fn gltf_draco_compressed_grid_is_the_uncompressed_one() {
    let dir = temp_dir("gltf_ext", "draco");
    let g = grid();
    let plain = load_scene(&write_plain(&dir, &g)).unwrap();
    for speed in [0, 5, 10] {
        let scene = load_scene(&write_draco(&dir, &g, speed, 16)).unwrap();
        // 16-bit quantization of a 2-unit range: steps of 3e-5, error half of that (plus f32).
        assert_same_scene(&plain, &scene, 2e-5, &format!("speed {speed}"));
        assert_same_normals(&plain, &scene, 0.01, &format!("speed {speed}"));
        assert!(
            scene.report.warnings.is_empty(),
            "{:?}",
            scene.report.warnings
        );
    }
}

#[test]
fn gltf_corrupt_draco_stream_is_an_error_naming_the_extension_and_mesh() {
    let dir = temp_dir("gltf_ext", "draco_bad");
    let path = write_draco(&dir, &grid(), 0, 14);
    let mut root: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    // Keep the stream's header, replace the rest with garbage.
    let uri = root["buffers"][0]["uri"].as_str().unwrap().to_string();
    let (head, data) = uri.split_once(',').unwrap();
    let mut bytes = base64::engine::general_purpose::STANDARD
        .decode(data)
        .unwrap();
    for (i, b) in bytes.iter_mut().enumerate().skip(12) {
        *b = (i * 37 % 251) as u8;
    }
    let enc = base64::engine::general_purpose::STANDARD.encode(&bytes);
    root["buffers"][0]["uri"] = json!(format!("{head},{enc}"));
    std::fs::write(&path, root.to_string()).unwrap();
    let e = anyhow_like(
        load_scene(&path)
            .err()
            .expect("a corrupt stream must not load"),
    );
    assert!(e.contains("KHR_draco_mesh_compression"), "{e}");
    assert!(e.contains("mesh 'Grid' primitive 0"), "{e}");
    assert!(e.contains("draco-0.gltf"), "{e}");
    assert!(e.len() < 400, "{e}");
}

#[test]
fn gltf_unknown_required_extension_is_refused_by_name_and_used_ones_warn() {
    let dir = temp_dir("gltf_ext", "required");
    let g = grid();
    let path = write_plain(&dir, &g);
    let mut root: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    root["extensionsUsed"] = json!(["EXT_made_up", "KHR_mesh_quantization"]);
    root["extensionsRequired"] = json!(["EXT_made_up", "KHR_mesh_quantization"]);
    std::fs::write(&path, root.to_string()).unwrap();
    let e = anyhow_like(load_scene(&path).err().expect("must be refused"));
    assert!(
        e.contains("requires the glTF extension EXT_made_up, which is not supported"),
        "{e}"
    );
    assert!(e.contains("plain.gltf"), "{e}");
    assert!(e.len() < 300, "{e}");
    // Used, not required: the file loads and one warning names the extension.
    root["extensionsRequired"] = json!([]);
    std::fs::write(&path, root.to_string()).unwrap();
    let scene = load_scene(&path).unwrap();
    let w = scene.report.warnings.join("\n");
    assert!(
        w.contains("extensions not supported, ignored: EXT_made_up"),
        "{w}"
    );
}

/// A quad [0,1]² at z = 0 in two primitives: the left half (x < 0.5) grey, the right half
/// emissive.
fn two_material_quad(b: &mut Buf) -> Value {
    let left = [
        [0.0, 0.0, 0.0],
        [0.5, 0.0, 0.0],
        [0.5, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let right = [
        [0.5, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.5, 1.0, 0.0],
    ];
    let mut prims = Vec::new();
    for (k, p) in [left, right].iter().enumerate() {
        let v = b.view(&f32s(p), None);
        let pos = b.accessor(Some(v), 5126, false, 4, "VEC3");
        b.bounds(pos, p);
        let idx: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let v = b.view(&idx, None);
        let ind = b.accessor(Some(v), 5123, false, 6, "SCALAR");
        prims.push(json!({"attributes": {"POSITION": pos}, "indices": ind, "material": k}));
    }
    json!({"name": "Tile", "primitives": prims})
}

#[test]
fn gltf_gpu_instances_are_hit_with_their_materials_and_emit() {
    let dir = temp_dir("gltf_ext", "instancing");
    let mut b = Buf::default();
    let mesh = two_material_quad(&mut b);
    let t: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 1.0]];
    // Instance 1 turned a quarter turn about z, instance 2 scaled by 2.
    let half = std::f32::consts::FRAC_1_SQRT_2;
    let r: [[f32; 4]; 3] = [
        [0.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, half, half],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let s: [[f32; 3]; 3] = [[1.0; 3], [1.0; 3], [2.0, 2.0, 1.0]];
    let tv = b.view(&f32s(&t), None);
    let ta = b.accessor(Some(tv), 5126, false, 3, "VEC3");
    let rv = b.view(&f32s(&r), None);
    let ra = b.accessor(Some(rv), 5126, false, 3, "VEC4");
    let sv = b.view(&f32s(&s), None);
    let sa = b.accessor(Some(sv), 5126, false, 3, "VEC3");
    let doc = json!({
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "materials": [
            {"name": "grey", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}},
            {"name": "glow", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
             "emissiveFactor": [1.0, 1.0, 1.0]}
        ],
        "scenes": [{"nodes": [0]}],
        // The node's own transform applies after each instance's.
        "nodes": [{"mesh": 0, "translation": [10.0, 0.0, 0.0], "extensions": {
            "EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": ta, "ROTATION": ra, "SCALE": sa}}
        }}],
        "meshes": [mesh],
    });
    let path = b.write(&dir, "forest.gltf", doc);
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 12);
    // Points of each instance's left (grey) and right (emissive) half, in world space.
    let place = |i: usize, x: f64, y: f64| {
        let q = DQuat::from_xyzw(
            r[i][0] as f64,
            r[i][1] as f64,
            r[i][2] as f64,
            r[i][3] as f64,
        );
        let local = DVec3::new(x * s[i][0] as f64, y * s[i][1] as f64, 0.0);
        q * local + DVec3::from(t[i].map(f64::from)) + DVec3::new(10.0, 0.0, 0.0)
    };
    for i in 0..3 {
        for (x, name) in [(0.25, "grey"), (0.75, "glow")] {
            let p = place(i, x, 0.5);
            let hit = scene
                .intersect(p + DVec3::Z, -DVec3::Z, f64::INFINITY)
                .unwrap_or_else(|| panic!("instance {i}: no hit at {p}"));
            assert!(
                (hit.p - p).length() < 1e-5,
                "instance {i}: hit {} for {p}",
                hit.p
            );
            assert_eq!(
                scene.materials[hit.material as usize].name, name,
                "instance {i}"
            );
        }
    }
    // Every instance's emissive half is a light: 2 triangles each, the third of area 4 × 1/2.
    let emitters = scene.lights.lights.len();
    assert_eq!(emitters, 6);
    let area: f64 = scene
        .lights
        .lights
        .iter()
        .map(|l| l.power(1.0))
        .sum::<f64>();
    let unit: f64 = scene.lights.lights[0].power(1.0) * 2.0;
    assert!(
        (area / unit - (1.0 + 1.0 + 4.0)).abs() < 1e-9,
        "power ratio {}",
        area / unit
    );
}

#[test]
fn gltf_gpu_instancing_with_mismatched_counts_is_an_error_naming_the_node() {
    let dir = temp_dir("gltf_ext", "instancing_bad");
    let mut b = Buf::default();
    let mesh = two_material_quad(&mut b);
    let tv = b.view(&f32s(&[[0.0f32; 3]; 3]), None);
    let ta = b.accessor(Some(tv), 5126, false, 3, "VEC3");
    let sv = b.view(&f32s(&[[1.0f32; 3]; 2]), None);
    let sa = b.accessor(Some(sv), 5126, false, 2, "VEC3");
    let doc = json!({
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "extensionsRequired": ["EXT_mesh_gpu_instancing"],
        "materials": [{"name": "a"}, {"name": "b"}],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "Trees", "mesh": 0, "extensions": {
            "EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": ta, "SCALE": sa}}
        }}],
        "meshes": [mesh],
    });
    let path = b.write(&dir, "bad.gltf", doc);
    let e = anyhow_like(load_scene(&path).err().unwrap());
    assert!(e.contains("node 'Trees'"), "{e}");
    assert!(e.contains("EXT_mesh_gpu_instancing"), "{e}");
}
