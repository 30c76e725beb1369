//! Bad input: broken scene files give errors (or warnings, where the input is recoverable) that
//! name the file, and the line where there is one, never a panic. `tests/corpus/` holds small
//! broken files: `err_*` must fail to load, `warn_*` load with a warning, `ok_*` load cleanly;
//! `part_*` are files the others refer to. Bad command-line values are in `tests/cli.rs`.

use ftpd3d::math::Rgb;
use ftpd3d::scene::load::load_scene;
use ftpd3d::transport::bsdf::Bsdf;
use std::path::{Path, PathBuf};

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("corpus")
        .join(name)
}

/// The error of loading a corpus file, with its context chain.
fn error_of(name: &str) -> String {
    let path = corpus(name);
    match load_scene(&path) {
        Ok(_) => panic!("{name} loaded"),
        Err(e) => format!("{e:#}"),
    }
}

/// Asserts that loading corpus file `name` fails with exactly `FILE` + `rest` as its message.
fn assert_error(name: &str, rest: &str) {
    let e = error_of(name);
    let expected = format!("{}{rest}", corpus(name).display());
    assert_eq!(e, expected);
}

#[test]
fn bad_input_every_corpus_file_errors_or_warns_naming_it_never_panics() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus(""))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let mut counts = [0; 3];
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("part_") || name == "README.md" {
            continue;
        }
        let shown = path.display().to_string();
        let result = std::panic::catch_unwind(|| load_scene(&path));
        let Ok(result) = result else {
            panic!("{name}: the loader panicked");
        };
        match (name.split('_').next().unwrap(), result) {
            ("err", Err(e)) => {
                let e = format!("{e:#}");
                assert!(e.starts_with(&shown), "{name}: {e}");
                counts[0] += 1;
            }
            ("warn", Ok(scene)) => {
                let w = &scene.report.warnings;
                assert!(!w.is_empty(), "{name}: no warning");
                assert!(w.iter().all(|w| w.starts_with(&shown)), "{name}: {w:?}");
                counts[1] += 1;
            }
            ("ok", Ok(scene)) => {
                assert!(
                    scene.report.warnings.is_empty(),
                    "{name}: {:?}",
                    scene.report.warnings
                );
                counts[2] += 1;
            }
            (_, Ok(scene)) => panic!("{name}: loaded, warnings {:?}", scene.report.warnings),
            (_, Err(e)) => panic!("{name}: {e:#}"),
        }
    }
    assert!(
        counts[0] >= 30 && counts[1] >= 5 && counts[2] >= 2,
        "{counts:?}"
    );
}

#[test]
fn bad_input_obj_missing_file() {
    let path = corpus("part_does_not_exist.obj");
    let e = format!("{:#}", load_scene(&path).err().unwrap());
    assert_eq!(e, format!("{}: no such scene file", path.display()));
}

#[test]
fn bad_input_obj_bad_face_indices_name_file_and_line() {
    assert_error(
        "err_face_index_out_of_range.obj",
        ":4: face refers to vertex 7 (in '7'), but only 3 vertices are defined before this line",
    );
    assert_error(
        "err_face_relative_out_of_range.obj",
        ":4: face refers to vertex -4 (in '-4'), but only 3 vertices are defined before this line",
    );
    assert_error(
        "err_face_normal_out_of_range.obj",
        ":5: face refers to normal 2 (in '2//2'), but only 1 normals are defined before this line",
    );
    assert_error(
        "err_face_index_zero.obj",
        ":4: face vertex index 0 in '0': OBJ indices start at 1 (or count back from -1)",
    );
    assert_error(
        "err_face_malformed.obj",
        ":4: malformed face vertex 'x': 'x' is not a whole number",
    );
    assert_error(
        "err_face_too_many_slashes.obj",
        ":4: malformed face vertex '1/1/1/1': expected v, v/vt, v//vn or v/vt/vn",
    );
}

#[test]
fn bad_input_obj_non_numeric_values_name_file_and_line() {
    assert_error(
        "err_v_not_a_number.obj",
        ":3: malformed vertex: expected 'v x y z' (optionally w, or r g b) with numbers, got 'v 1 0 abc'",
    );
    assert_error(
        "err_v_two_numbers.obj",
        ":2: malformed vertex: expected 'v x y z' (optionally w, or r g b) with numbers, got 'v 1 0'",
    );
    assert_error(
        "err_v_w_zero.obj",
        ":1: vertex with w = 0 (a point at infinity): 'v 0 0 0 0'",
    );
    assert_error(
        "err_vn_not_a_number.obj",
        ":4: malformed normal: expected 'vn x y z' with numbers, got 'vn 0 zero 1'",
    );
    assert_error(
        "err_vt_one_number.obj",
        ":4: malformed texture coordinate: expected 'vt u v' (optionally w) with numbers, got 'vt 0.5'",
    );
    // Bytes that are not UTF-8 are read as Latin-1: in a number they make a malformed line, named
    // by its number (not a byte offset).
    assert_error(
        "err_not_utf8.obj",
        ":1: malformed vertex: expected 'v x y z' (optionally w, or r g b) with numbers, got 'v 0 0 0ÿþ'",
    );
}

#[test]
fn bad_input_obj_unsupported_statements_give_one_summarised_warning() {
    let path = corpus("warn_unsupported_statements.obj");
    let scene = load_scene(&path).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    let f = path.display();
    assert_eq!(
        scene.report.warnings,
        vec![format!(
            "{f}:5: statements the loader does not use ('cstype', 'deg', 'curv' ×2, 'parm', \
             'end', 'p', 'l', 'vp'); ignored, 9 lines"
        )]
    );
}

/// What mainstream OBJ loaders go on past (faces of fewer than 3 vertices, a bare `usemtl`,
/// unknown statements, Latin-1 bytes) is one warning per kind with the count and the first line,
/// through the binary as a user sees it; `--strict` refuses each at its line.
#[test]
fn bad_input_obj_tolerant_loading_warns_once_per_kind_and_strict_refuses() {
    let run = |name: &str, strict: bool| {
        let path = corpus(name);
        let mut args = vec!["--scene", path.to_str().unwrap(), "--explain"];
        if strict {
            args.push("--strict");
        }
        crate::support::ftpd3d(&args)
    };
    let warnings = |err: &str| -> Vec<String> {
        err.lines()
            .filter_map(|l| l.strip_prefix("warning: "))
            .map(str::to_string)
            .collect()
    };
    let cases: &[(&str, &[&str], &str)] = &[
        (
            "warn_face_two_vertices.obj",
            &[":4: faces with fewer than 3 vertices (points, lines); skipped, 2 lines"],
            ":4: a face needs at least 3 vertices, this one has 2: 'f 1 2' (--strict)",
        ),
        (
            "warn_latin1_comment.obj",
            &[":1: not UTF-8 text; read as Latin-1"],
            ":1: not UTF-8 text (--strict)",
        ),
        (
            "warn_usemtl_without_name.obj",
            &[":4: 'usemtl' without a name; the faces after it get the default material"],
            ":4: 'usemtl' needs a name: 'usemtl' (--strict)",
        ),
        (
            "warn_unknown_statements.obj",
            &[":4: statements the loader does not use ('foo' ×2, 'bar'); ignored, 3 lines"],
            ":4: 'foo' statements are not supported: 'foo 1 2' (--strict)",
        ),
    ];
    for (name, warned, refused) in cases {
        let f = corpus(name).display().to_string();
        let r = run(name, false);
        assert!(r.ok, "{name}: {}", r.err);
        let expected: Vec<String> = warned.iter().map(|w| format!("{f}{w}")).collect();
        assert_eq!(warnings(&r.err), expected, "{name}");
        assert!(
            r.out.contains("geometry   1 triangles"),
            "{name}: {}",
            r.out
        );
        let r = run(name, true);
        assert!(!r.ok, "{name} loaded with --strict");
        assert_eq!(r.err.trim_end(), format!("error: {f}{refused}"), "{name}");
    }
}

/// A Latin-1 material name in the OBJ file and in its library is the same name: the material is
/// found, and each file's Latin-1 lines are one warning.
#[test]
fn bad_input_obj_latin1_material_name_matches_its_library() {
    let path = corpus("warn_latin1_material.obj");
    let scene = load_scene(&path).unwrap();
    let f = path.display();
    assert_eq!(
        scene.report.warnings,
        vec![
            format!("{f}:5: not UTF-8 text; read as Latin-1"),
            format!(
                "{f}: material library {}:1: not UTF-8 text; read as Latin-1, 2 lines",
                corpus("part_latin1.mtl").display()
            ),
        ]
    );
    let m = &scene.materials[scene.tri_material[0] as usize];
    assert_eq!(m.name, "café");
    assert_eq!(
        m.bsdf,
        Bsdf::Diffuse {
            kd: Rgb::splat(0.25)
        }
    );
    // The same through the binary with --strict: refused at the line.
    let r = crate::support::ftpd3d(&["--scene", path.to_str().unwrap(), "--explain", "--strict"]);
    assert!(!r.ok);
    assert_eq!(
        r.err.trim_end(),
        format!("error: {f}:5: not UTF-8 text (--strict)")
    );
}

#[test]
fn bad_input_obj_without_geometry_is_an_error() {
    assert_error(
        "err_empty.obj",
        ": no geometry: the file has no faces ('f' statements) and no vertices",
    );
    assert_error(
        "err_no_faces.obj",
        ": no geometry: the file has no faces ('f' statements)",
    );
    assert_error(
        "err_all_degenerate.obj",
        ": no geometry: all 2 triangles are degenerate (zero area or non-finite coordinates)",
    );
}

#[test]
fn bad_input_missing_or_malformed_mtl_warns_naming_it_then_grey_diffuse() {
    let grey = Bsdf::Diffuse {
        kd: Rgb::splat(0.5),
    };
    let path = corpus("warn_missing_mtl.obj");
    let scene = load_scene(&path).unwrap();
    let mtl = corpus("warn_missing_mtl_gone.mtl");
    let w = &scene.report.warnings;
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with(&format!(
            "{}: material library {} cannot be read (",
            path.display(),
            mtl.display()
        )) && w[0].ends_with("); its materials are grey diffuse"),
        "{w:?}"
    );
    assert_eq!(scene.materials[scene.tri_material[0] as usize].bsdf, grey);

    let path = corpus("warn_bad_mtl.obj");
    let scene = load_scene(&path).unwrap();
    assert_eq!(
        scene.report.warnings,
        vec![format!(
            "{}: material library {}:2: 'Kd' needs a colour r g b (or one grey value), got 'Kd 0.5 0.5'; \
             the library's materials are grey diffuse",
            path.display(),
            corpus("part_bad_mtl.mtl").display()
        )]
    );
    assert_eq!(scene.materials[scene.tri_material[0] as usize].bsdf, grey);

    // One number is a grey (tobj itself would panic on it).
    let scene = load_scene(&corpus("ok_grey_kd.obj")).unwrap();
    assert_eq!(
        scene.materials[scene.tri_material[0] as usize].bsdf,
        Bsdf::Diffuse {
            kd: Rgb::splat(0.25)
        }
    );
}

#[test]
fn bad_input_gltf_files_name_the_file_and_the_problem() {
    assert_error(
        "err_truncated.glb",
        ": truncated .glb: the header declares 624 bytes, the file has 312",
    );
    assert_error(
        "err_truncated_header.glb",
        ": truncated .glb: 7 bytes, shorter than the 12-byte header",
    );
    assert_error(
        "err_glb_version_1.glb",
        ": binary glTF version 1; only version 2 is supported",
    );
    let e = error_of("err_missing_buffer.gltf");
    let f = corpus("err_missing_buffer.gltf");
    assert!(
        e.starts_with(&format!(
            "{}: buffer #0: cannot read 'part_gone.bin' ({}): ",
            f.display(),
            corpus("part_gone.bin").display()
        )),
        "{e}"
    );
    assert_error(
        "err_bad_accessor_type.gltf",
        ": mesh 'Quad' primitive 0: POSITION accessor #0 is not VEC3 f32 (it is VEC2 f32)",
    );
    assert_error(
        "err_bad_accessor_component.gltf",
        ": mesh 'Quad' primitive 0: POSITION accessor #0 is not VEC3 f32 (it is VEC3 u16)",
    );
    assert_error(
        "err_accessor_past_buffer.gltf",
        ": mesh 'Quad' primitive 0: accessor #0: 400 elements of 12 bytes (stride 12) from offset 0 \
         run past the end of buffer view #0 (48 bytes)",
    );
    assert_error(
        "err_attribute_accessor_missing.gltf",
        ": not a valid glTF 2.0 file: meshes[0].primitives[0].attributes: accessor 9 does not exist \
         (2 accessors)",
    );
    assert_error(
        "err_not_json.gltf",
        ": not a valid glTF 2.0 file: expected ident at line 1 column 44",
    );
    for (name, mode) in [
        ("warn_points_primitive.gltf", "POINTS"),
        ("warn_lines_primitive.gltf", "LINES"),
    ] {
        let scene = load_scene(&corpus(name)).unwrap();
        assert_eq!(scene.triangles.len(), 2);
        assert_eq!(
            scene.report.warnings,
            vec![format!(
                "{}: mesh 'Quad' primitive 1: mode {mode} is not triangles; skipped",
                corpus(name).display()
            )]
        );
    }
}

#[test]
fn bad_input_sidecar_files_name_the_file_and_the_problem() {
    let e = error_of("err_sidecar_unknown_key.toml");
    assert!(
        e.starts_with(&format!(
            "{}: TOML parse error at line 2, column 1",
            corpus("err_sidecar_unknown_key.toml").display()
        )) && e.contains("unknown field `colour`"),
        "{e}"
    );
    assert_error(
        "err_sidecar_missing_mesh.toml",
        &format!(
            ": loading its mesh: {}: no such scene file",
            corpus("part_nothere.obj").display()
        ),
    );
    assert_error(
        "err_sidecar_negative_light.toml",
        ": point_light #1: position must be finite and intensity finite and ≥ 0",
    );
    assert_error(
        "err_sidecar_mesh_is_toml.toml",
        ": mesh = \"err_sidecar_unknown_key.toml\" must be a mesh file, not another .toml",
    );
    assert_error(
        "err_sidecar_bad_camera.toml",
        ": camera #1: target equals eye",
    );
    assert_error(
        "err_unsupported_format.ply",
        ": unsupported scene format '.ply' (supported: .obj, .gltf, .glb, .toml)",
    );
}

#[test]
fn bad_input_non_regular_files_are_not_read() {
    // /dev/zero never ends: a library or buffer named so must not be read. By default it lies
    // outside the scene's folder and is refused before anything looks at it; where the load
    // allows that, it is still never opened.
    use ftpd3d::scene::load::{LoadOptions, load_scene_with};
    let anywhere = LoadOptions {
        allow_outside_uris: true,
        ..Default::default()
    };
    let path = corpus("err_mtllib_dev_zero.obj");
    assert!(
        error_of("err_mtllib_dev_zero.obj").contains("mtllib '/dev/zero' lies outside"),
        "{}",
        error_of("err_mtllib_dev_zero.obj")
    );
    let scene = load_scene_with(&path, &[], &anywhere).unwrap();
    assert_eq!(
        scene.report.warnings,
        vec![format!(
            "{}: material library /dev/zero is not a regular file; its materials are grey diffuse",
            path.display()
        )]
    );
    let gltf = corpus("err_buffer_dev_zero.gltf");
    assert!(
        error_of("err_buffer_dev_zero.gltf").contains("buffer #0: URI '/dev/zero' lies outside")
    );
    let e = format!(
        "{:#}",
        load_scene_with(&gltf, &[], &anywhere).err().unwrap()
    );
    assert_eq!(
        e,
        format!(
            "{}: buffer #0: '/dev/zero' (/dev/zero) is not a regular file",
            gltf.display()
        )
    );
}

/// Hostile references: files the corpus's scene files name outside their folder are refused,
/// naming the reference, and never read.
#[test]
fn bad_input_references_outside_the_folder_are_refused() {
    for (name, uri) in [
        ("err_buffer_outside.gltf", "'../outside.bin'"),
        ("err_buffer_absolute.gltf", "'/etc/passwd'"),
        ("err_buffer_proc_environ.gltf", "'/proc/self/environ'"),
        ("err_buffer_percent_dotdot.gltf", "'..%2F..%2Fx.bin'"),
        ("err_buffer_file_uri.gltf", "'file:///etc/passwd'"),
        ("err_buffer_backslash.gltf", "'..\\..\\x.bin'"),
        ("err_buffer_drive.gltf", "'C:\\Windows\\x.bin'"),
        ("err_image_outside.gltf", "'../../x.png'"),
        ("err_mtllib_outside.obj", "'../../x.mtl'"),
        ("err_sidecar_mesh_outside.toml", "'../x.obj'"),
    ] {
        let e = error_of(name);
        assert!(e.contains(uri) && e.contains("lies outside"), "{name}: {e}");
    }
    assert_error(
        "err_light_negative_intensity.gltf",
        ": KHR_lights_punctual light 'bulb': intensity -100 must be finite and ≥ 0",
    );
    assert_error(
        "err_emissive_negative.gltf",
        ": material 'glow': emissiveFactor [1.0, -1.0, 0.5] must be finite and ≥ 0 in each component",
    );
}

/// A field of the earlier format (standard error from batch σ sums, no per-sample product sums)
/// cannot give the error this version computes: reading it says so and names the file.
#[test]
fn bad_input_field_of_the_earlier_format_is_refused_naming_it() {
    use exr::prelude::*;
    let dir = crate::support::temp_dir("bad", "old_exr");
    let path = dir.join("old.exr");
    let ch = |name: &str| AnyChannel::new(name, FlatSamples::U32(vec![0u32]));
    let channels = AnyChannels::sort(
        vec![
            ch("exact.batch.sigma.hi"),
            ch("exact.batch.sigma.lo"),
            ch("exact.sum.w.hi"),
            ch("exact.sum.w.lo"),
        ]
        .into(),
    );
    Image::from_channels((1, 1), channels)
        .write()
        .to_file(&path)
        .unwrap();
    let e = format!("{:#}", ftpd3d::output::exr::read_exr(&path).unwrap_err());
    assert!(
        e.contains("old.exr") && e.contains("earlier ftpd3d") && e.contains("run it again"),
        "{e}"
    );
}

/// Dozens of materials with Kd + Ks above 1 give one warning with the count and the first
/// material, not one warning each.
#[test]
fn bad_input_many_bright_materials_give_one_summarised_warning() {
    let dir = crate::support::temp_dir("bad_input", "bright_materials");
    let mut mtl = String::new();
    let mut obj = String::from("mtllib bright.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for i in 0..83 {
        mtl.push_str(&format!(
            "newmtl m{i}\nKd 0.8 0.8 0.8\nKs 0.5 0.5 0.5\nNs 20\n"
        ));
        obj.push_str(&format!("usemtl m{i}\nf 1 2 3\n"));
    }
    // One more with a different note's material kind (a mirror, illum 3) and one that is fine.
    mtl.push_str(
        "newmtl mirror\nillum 3\nKd 0.5 0.5 0.5\nKs 0.9 0.9 0.9\nnewmtl ok\nKd 0.5 0.5 0.5\n",
    );
    std::fs::write(dir.join("bright.mtl"), mtl).unwrap();
    let path = dir.join("bright.obj");
    std::fs::write(&path, obj).unwrap();
    let scene = load_scene(&path).unwrap();
    let f = path.display();
    assert_eq!(
        scene.report.warnings,
        vec![format!(
            "{f}: 84 materials: Kd + Ks exceeds 1; scaled down (the first is 'm0')"
        )]
    );
}
