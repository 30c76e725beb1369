//! Where a scene file may make the tool read: only inside its own folder and the folders below it
//! (a scene file may come from anywhere). glTF buffer and image URIs, OBJ `mtllib` and MTL maps,
//! a sidecar's mesh and environment map that leave the folder (`..`, absolute paths, `file:` URIs,
//! drive and backslash paths, percent-encoded `..%2F`, symbolic links) are refused naming the
//! reference and the scene file, unless the load opts in (`allow_outside_uris`,
//! `--allow-outside-uris`). Also: a scene path that is a loop of symbolic links says so.

use crate::support::{ftpd3d, temp_dir};
use ftpd3d::scene::LoadError;
use ftpd3d::scene::load::{LoadOptions, load_scene, load_scene_with};
use serde_json::json;
use std::path::{Path, PathBuf};

/// One triangle: 3 f32 positions then 3 f32×2 texture coordinates (60 bytes).
fn triangle_bin() -> Vec<u8> {
    let pos = [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]];
    let uv = [[0f32, 0.], [1., 0.], [0., 1.]];
    pos.iter()
        .flatten()
        .chain(uv.iter().flatten())
        .flat_map(|x| x.to_le_bytes())
        .collect()
}

/// A glTF file `name` in `dir` whose buffer's URI is `buffer` and, with `image`, a material whose
/// base-colour texture is the image at that URI (the buffer must hold [`triangle_bin`]).
fn gltf(dir: &Path, name: &str, buffer: &str, image: Option<&str>) -> PathBuf {
    let mut prim = json!({"attributes": {"POSITION": 0, "TEXCOORD_0": 1}});
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": 60, "uri": buffer}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}
        ],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    if let Some(uri) = image {
        prim["material"] = json!(0);
        doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
        doc["textures"] = json!([{"source": 0}]);
        doc["images"] = json!([{"uri": uri}]);
    }
    doc["meshes"] = json!([{"primitives": [prim]}]);
    let path = dir.join(name);
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

/// A 1 × 1 white PNG.
fn png(path: &Path) {
    image::RgbImage::from_raw(1, 1, vec![255, 255, 255])
        .unwrap()
        .save(path)
        .unwrap();
}

/// The error of loading `path` by default, with its causes; panics when it loads.
fn refused(path: &Path) -> (LoadError, String) {
    match load_scene(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => {
            let text = format!("{e:#}");
            (e, text)
        }
    }
}

/// Asserts that `path` is refused as reading outside its folder, with a message that names the
/// scene file and `name`, and that it loads when the load opts in.
fn refused_unless_allowed(path: &Path, name: &str) {
    let (e, text) = refused(path);
    assert!(matches!(e, LoadError::Outside { .. }), "{text}");
    assert!(text.starts_with(&path.display().to_string()), "{text}");
    assert!(text.contains(&format!("'{name}'")), "{text}");
    assert!(
        text.contains("outside") && text.contains("allow_outside_uris"),
        "{text}"
    );
    let allowed = LoadOptions {
        allow_outside_uris: true,
        ..Default::default()
    };
    if let Err(e) = load_scene_with(path, &[], &allowed) {
        panic!("{name} with allow_outside_uris: {e:#}");
    }
}

#[test]
fn reach_gltf_buffer_uris_outside_the_folder_are_refused() {
    let root = temp_dir("reach", "buffers");
    let dir = root.join("model");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(root.join("outside.bin"), triangle_bin()).unwrap();
    std::fs::write(dir.join("sub/in.bin"), triangle_bin()).unwrap();
    let outside = root.join("outside.bin");
    let absolute = outside.to_str().unwrap().to_string();
    let file_uri = format!("file://{absolute}");
    for (k, uri) in [
        "../outside.bin",
        "..%2Foutside.bin",
        "sub/..%2F..%2Foutside.bin",
        absolute.as_str(),
        file_uri.as_str(),
    ]
    .iter()
    .enumerate()
    {
        let path = gltf(&dir, &format!("b{k}.gltf"), uri, None);
        refused_unless_allowed(&path, uri);
    }
    // Refused without being read, whether they exist or not.
    for (k, uri) in ["/proc/self/environ", "C:\\outside.bin", "..\\outside.bin"]
        .iter()
        .enumerate()
    {
        let path = gltf(&dir, &format!("w{k}.gltf"), uri, None);
        let (e, text) = refused(&path);
        assert!(matches!(e, LoadError::Outside { .. }), "{text}");
        assert!(text.contains(&format!("'{uri}'")), "{text}");
    }
    // A symbolic link in the folder that leads outside it.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&outside, dir.join("link.bin")).unwrap();
        let path = gltf(&dir, "link.gltf", "link.bin", None);
        let (_, text) = refused(&path);
        assert!(text.contains("symbolic link"), "{text}");
        refused_unless_allowed(&path, "link.bin");
    }
    // Subfolders are the scene's own.
    for (k, uri) in ["sub/in.bin", "sub%2Fin.bin", "./sub/../sub/in.bin"]
        .iter()
        .enumerate()
    {
        let path = gltf(&dir, &format!("ok{k}.gltf"), uri, None);
        if let Err(e) = load_scene(&path) {
            panic!("{uri}: {e:#}");
        }
    }
}

#[test]
fn reach_gltf_image_uri_outside_the_folder_is_refused_not_a_warning() {
    let root = temp_dir("reach", "images");
    let dir = root.join("model");
    std::fs::create_dir_all(dir.join("tex")).unwrap();
    std::fs::write(dir.join("t.bin"), triangle_bin()).unwrap();
    png(&root.join("outside.png"));
    png(&dir.join("tex/in.png"));
    let path = gltf(&dir, "img.gltf", "t.bin", Some("../outside.png"));
    refused_unless_allowed(&path, "../outside.png");
    let inside = gltf(&dir, "in.gltf", "t.bin", Some("tex/in.png"));
    let scene = load_scene(&inside).unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
}

#[test]
fn reach_obj_material_libraries_and_maps_stay_in_the_folder() {
    let root = temp_dir("reach", "obj");
    let dir = root.join("model");
    std::fs::create_dir_all(dir.join("mat")).unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\n";
    std::fs::write(root.join("outside.mtl"), "newmtl m\nKd 0.5 0.5 0.5\n").unwrap();
    let lib = dir.join("lib.obj");
    std::fs::write(&lib, format!("mtllib ../outside.mtl\n{obj}")).unwrap();
    refused_unless_allowed(&lib, "../outside.mtl");
    let abs = dir.join("abs.obj");
    std::fs::write(&abs, format!("mtllib /etc/passwd\n{obj}")).unwrap();
    assert!(matches!(refused(&abs).0, LoadError::Outside { .. }));
    // A map is relative to its library, which may be in a subfolder: `..` back to the OBJ's
    // folder is fine, above it is not.
    png(&root.join("outside.png"));
    png(&dir.join("in.png"));
    std::fs::write(
        dir.join("mat/in.mtl"),
        "newmtl m\nKd 1 1 1\nmap_Kd ../in.png\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("mat/out.mtl"),
        "newmtl m\nKd 1 1 1\nmap_Kd ../../outside.png\n",
    )
    .unwrap();
    let good = dir.join("good.obj");
    std::fs::write(&good, format!("mtllib mat/in.mtl\n{obj}")).unwrap();
    let scene = load_scene(&good).unwrap();
    assert!(
        scene.report.warnings.is_empty(),
        "{:?}",
        scene.report.warnings
    );
    let map = dir.join("map.obj");
    std::fs::write(&map, format!("mtllib mat/out.mtl\n{obj}")).unwrap();
    refused_unless_allowed(&map, "../../outside.png");
    assert!(refused(&map).1.contains("map_Kd"), "{}", refused(&map).1);
}

#[test]
fn reach_sidecar_mesh_outside_its_folder_is_refused() {
    let root = temp_dir("reach", "sidecar");
    let dir = root.join("scene");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let toml = dir.join("s.toml");
    std::fs::write(&toml, "mesh = \"../m.obj\"\n").unwrap();
    refused_unless_allowed(&toml, "../m.obj");
}

#[test]
fn reach_the_command_line_names_its_flag() {
    let root = temp_dir("reach", "cli");
    let dir = root.join("model");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("outside.bin"), triangle_bin()).unwrap();
    let path = gltf(&dir, "up.gltf", "../outside.bin", None);
    let scene = path.to_str().unwrap();
    let run = ftpd3d(&["--scene", scene, "--slice", "z=0", "--explain"]);
    assert!(!run.ok, "{}", run.out);
    assert!(
        run.err.contains("'../outside.bin'") && run.err.contains("--allow-outside-uris"),
        "{}",
        run.err
    );
    let run = ftpd3d(&[
        "--scene",
        scene,
        "--slice",
        "z=0",
        "--explain",
        "--allow-outside-uris",
    ]);
    assert!(run.ok, "{}", run.err);
    // `converge` loads scenes too.
    let out = root.join("conv");
    let conv = |extra: &[&str]| {
        let mut a = vec![
            "converge",
            "--scene",
            scene,
            "--slice",
            "x=0.25",
            "--res",
            "2",
            "--start-spp",
            "1",
            "--max-spp",
            "8",
            "--weight",
            "unweighted",
            "--quiet",
            "--out-dir",
            out.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        ftpd3d(&a)
    };
    let run = conv(&[]);
    assert!(
        !run.ok && run.err.contains("--allow-outside-uris"),
        "{}",
        run.err
    );
    let run = conv(&["--allow-outside-uris"]);
    assert!(run.ok, "{}", run.err);
}

/// A scene path that is a loop of symbolic links says so (the system's cause), not "no such
/// scene file".
#[cfg(unix)]
#[test]
fn reach_a_loop_of_symbolic_links_is_named_as_such() {
    let dir = temp_dir("reach", "loop");
    for (a, b) in [("a", "b"), ("b", "a")] {
        for ext in ["obj", "gltf"] {
            std::os::unix::fs::symlink(
                dir.join(format!("{b}.{ext}")),
                dir.join(format!("{a}.{ext}")),
            )
            .unwrap();
        }
    }
    for ext in ["obj", "gltf"] {
        let path = dir.join(format!("a.{ext}"));
        let text = refused(&path).1;
        assert!(text.starts_with(&path.display().to_string()), "{text}");
        assert!(
            text.to_lowercase()
                .contains("too many levels of symbolic links"),
            "{text}"
        );
    }
}
