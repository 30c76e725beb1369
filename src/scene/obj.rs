//! Wavefront OBJ + MTL loading (tobj): triangulated meshes with one shared index per vertex, shading
//! normals when present, one material per triangle. See [`crate::scene::material`] for the MTL table.

use crate::math::Rgb;
use crate::scene::material::Bsdf;
use crate::scene::material::{Material, conserve_energy};
use crate::scene::{LoadReport, Scene};
use anyhow::{Context, bail};
use glam::Vec3;
use std::path::Path;

/// Loads an OBJ file (and the MTL files it names) into a [`Scene`].
///
/// The file is first checked line by line ([`prescan`]): tobj reports malformed input without a
/// line number, so every `v`, `vt`, `vn` and `f` statement is validated here and the first bad one
/// is reported as `FILE:LINE`. Statements the loader does not use (free-form curves and surfaces,
/// points, lines, ...) are warned about once per keyword. Material libraries are read by this module
/// too ([`load_mtl`]), so that a missing or malformed one is a warning naming it (its materials
/// become grey diffuse), never a panic in the parser. A file without faces is an error.
pub fn load(path: &Path) -> anyhow::Result<Scene> {
    let file = path.display().to_string();
    if !path.is_file() {
        bail!("{file}: no such scene file");
    }
    let bytes = std::fs::read(path).with_context(|| format!("{file}: cannot read"))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{file}: not a text file (invalid UTF-8 at byte {})",
            e.utf8_error().valid_up_to()
        )
    })?;
    let scan = prescan(&file, &text)?;
    let mut report = LoadReport {
        warnings: scan.warnings,
        ..Default::default()
    };
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    let mtl_notes = std::cell::RefCell::new(Vec::new());
    // The checks above keep tobj away from the inputs it is known to panic on; should it still
    // panic, the file is reported as unreadable rather than the run aborting.
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut text.as_bytes(), &opts, |lib| {
            load_mtl(&file, dir, lib, &mtl_notes)
        })
    }));
    let (models, mtl) = match parsed {
        Ok(result) => result.map_err(|e| anyhow::anyhow!("{file}: {}", describe(&e)))?,
        Err(_) => bail!("{file}: the OBJ parser failed on this file (please report it)"),
    };
    let mtl_notes = mtl_notes.into_inner();
    let mut materials: Vec<Material> = match mtl {
        Ok(list) => {
            // One warning per kind of conversion note, not per material (a library may have
            // dozens): the count and the first material it concerns.
            let mut notes: Vec<(String, Vec<&str>)> = Vec::new();
            let mats = list
                .iter()
                .map(|m| {
                    let (mat, warn) = convert_material(m);
                    if let Some(w) = warn {
                        match notes.iter_mut().find(|(n, _)| *n == w) {
                            Some((_, names)) => names.push(&m.name),
                            None => notes.push((w, vec![&m.name])),
                        }
                    }
                    mat
                })
                .collect();
            for (w, names) in notes {
                report.warnings.push(match names[..] {
                    [one] => format!("{file}: material '{one}': {w}"),
                    _ => format!(
                        "{file}: {} materials: {w} (the first is '{}')",
                        names.len(),
                        names[0]
                    ),
                });
            }
            mats
        }
        Err(e) => {
            if mtl_notes.is_empty() {
                report.warnings.push(format!(
                    "{file}: material library not loaded ({}); using grey diffuse",
                    describe(&e)
                ));
            }
            Vec::new()
        }
    };
    report.warnings.extend(mtl_notes);
    // Index of the default material for faces without one.
    let default_id = materials.len() as u32;
    materials.push(Material::default_grey());

    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    let mut tri_material = Vec::new();
    let mut all_have_normals = true;
    for model in &models {
        let mesh = &model.mesh;
        let base = positions.len() as u64;
        let nverts = mesh.positions.len() / 3;
        if base + nverts as u64 >= u32::MAX as u64 {
            bail!("{file}: more than 2^32 vertices");
        }
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if mesh.normals.len() == mesh.positions.len() {
            normals.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        } else {
            all_have_normals = false;
            normals.extend(std::iter::repeat_n(Vec3::ZERO, nverts));
        }
        let mat = match mesh.material_id {
            Some(id) if id < default_id as usize => id as u32,
            Some(id) => {
                report.warnings.push(format!(
                    "{file}: object '{}' names material #{id}, which is not defined",
                    model.name
                ));
                default_id
            }
            None => default_id,
        };
        for f in mesh.indices.chunks_exact(3) {
            let tri = [f[0], f[1], f[2]];
            if tri.iter().any(|&i| i as usize >= nverts) {
                bail!(
                    "{file}: object '{}' has a face index outside its {} vertices",
                    model.name,
                    nverts
                );
            }
            triangles.push(tri.map(|i| i + base as u32));
            tri_material.push(mat);
        }
    }
    if triangles.is_empty() {
        bail!(
            "{file}: no geometry: the file has no faces ('f' statements){}",
            if scan.vertices == 0 {
                " and no vertices"
            } else {
                ""
            }
        );
    }
    if !all_have_normals {
        // A mix of meshes with and without normals: zero normals fall back to the geometric one.
        if normals.iter().all(|n| *n == Vec3::ZERO) {
            normals.clear();
        }
    }
    let scene = Scene::build(
        path,
        positions,
        normals,
        triangles,
        tri_material,
        materials,
        report,
    )
    .with_context(|| format!("{file}: building the scene"))?;
    if scene.triangles.is_empty() {
        bail!(
            "{file}: no geometry: all {} triangles are degenerate (zero area or non-finite coordinates)",
            scene.report.triangles_read
        );
    }
    Ok(scene)
}

/// What [`prescan`] learnt about an OBJ file.
#[derive(Debug, Default)]
pub struct Prescan {
    pub vertices: usize,
    pub faces: usize,
    pub warnings: Vec<String>,
}

/// The OBJ statements the loader uses (`#` starts a comment).
const OBJ_KEYWORDS: &[&str] = &["v", "vt", "vn", "f", "o", "g", "s", "mtllib", "usemtl"];

/// Checks an OBJ file line by line: `v x y z [w | r g b]`, `vt u v [w]` and `vn x y z` must hold
/// numbers, and every vertex of an `f` statement (`v`, `v/vt`, `v//vn` or `v/vt/vn`, at least
/// three) must be a whole number that names a position (texture coordinate, normal) defined before
/// it: positive from 1, or negative counting back from the last one. The first bad line is an error
/// `FILE:LINE: ...`. Other statements are ignored with one warning per keyword.
pub fn prescan(file: &str, text: &str) -> anyhow::Result<Prescan> {
    let mut scan = Prescan::default();
    let (mut nv, mut nvt, mut nvn) = (0usize, 0usize, 0usize);
    // Keyword → (first line, count), in order of first appearance.
    let mut ignored: Vec<(String, usize, usize)> = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line_no = k + 1;
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let Some(kw) = words.next() else { continue };
        if kw.starts_with('#') {
            continue;
        }
        let shown = || {
            let mut s: String = line.chars().take(60).collect();
            if line.chars().count() > 60 {
                s.push('…');
            }
            s
        };
        let numbers = |words: std::str::SplitWhitespace| -> Option<Vec<f32>> {
            words.map(|w| w.parse::<f32>().ok()).collect()
        };
        match kw {
            "v" => {
                let v = numbers(words);
                match v.as_deref() {
                    Some([_, _, _]) | Some([_, _, _, _, _, _]) => {}
                    Some([_, _, _, w]) if *w != 0.0 => {}
                    Some([_, _, _, _]) => bail!(
                        "{file}:{line_no}: vertex with w = 0 (a point at infinity): '{}'",
                        shown()
                    ),
                    _ => bail!(
                        "{file}:{line_no}: malformed vertex: expected 'v x y z' (optionally w, or r g b) with numbers, got '{}'",
                        shown()
                    ),
                }
                nv += 1;
            }
            "vt" => {
                match numbers(words) {
                    Some(v) if (2..=3).contains(&v.len()) => {}
                    _ => bail!(
                        "{file}:{line_no}: malformed texture coordinate: expected 'vt u v' (optionally w) with numbers, got '{}'",
                        shown()
                    ),
                }
                nvt += 1;
            }
            "vn" => {
                match numbers(words) {
                    Some(v) if v.len() == 3 => {}
                    _ => bail!(
                        "{file}:{line_no}: malformed normal: expected 'vn x y z' with numbers, got '{}'",
                        shown()
                    ),
                }
                nvn += 1;
            }
            "f" => {
                let refs: Vec<&str> = words.collect();
                if refs.len() < 3 {
                    bail!(
                        "{file}:{line_no}: a face needs at least 3 vertices, this one has {}: '{}'",
                        refs.len(),
                        shown()
                    );
                }
                for r in refs {
                    check_face_vertex(file, line_no, r, [nv, nvt, nvn])?;
                }
                scan.faces += 1;
            }
            "usemtl" | "mtllib" if words.next().is_none() => {
                bail!("{file}:{line_no}: '{kw}' needs a name: '{}'", shown())
            }
            kw if OBJ_KEYWORDS.contains(&kw) => {}
            other => match ignored.iter_mut().find(|(k, _, _)| k == other) {
                Some(entry) => entry.2 += 1,
                None => ignored.push((other.to_string(), line_no, 1)),
            },
        }
    }
    scan.vertices = nv;
    for (kw, first, count) in ignored {
        let what = match kw.as_str() {
            "p" => "points ('p') are not rendered".to_string(),
            "l" => "lines ('l') are not rendered".to_string(),
            _ => format!("'{kw}' statements are not supported"),
        };
        let times = if count == 1 {
            String::new()
        } else {
            format!(", {count} lines")
        };
        scan.warnings
            .push(format!("{file}:{first}: {what}; ignored{times}"));
    }
    Ok(scan)
}

/// Checks one vertex of a face (`v`, `v/vt`, `v//vn`, `v/vt/vn`) against the counts of positions,
/// texture coordinates and normals defined so far.
fn check_face_vertex(
    file: &str,
    line_no: usize,
    r: &str,
    counts: [usize; 3],
) -> anyhow::Result<()> {
    const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    const WHATS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    let parts: Vec<&str> = r.split('/').collect();
    let well_formed = match parts.as_slice() {
        [v] => !v.is_empty(),
        [v, _] => !v.is_empty(),
        [v, _, _] => !v.is_empty(),
        _ => false,
    };
    if !well_formed {
        bail!("{file}:{line_no}: malformed face vertex '{r}': expected v, v/vt, v//vn or v/vt/vn");
    }
    for (k, part) in parts.iter().enumerate() {
        if part.is_empty() {
            continue; // v//vn
        }
        let Ok(i) = part.parse::<i64>() else {
            bail!("{file}:{line_no}: malformed face vertex '{r}': '{part}' is not a whole number");
        };
        let n = counts[k] as i64;
        if i == 0 {
            bail!(
                "{file}:{line_no}: face {} index 0 in '{r}': OBJ indices start at 1 (or count back from -1)",
                WHAT[k]
            );
        }
        if i > n || -i > n {
            bail!(
                "{file}:{line_no}: face refers to {} {i} (in '{r}'), but only {n} {} are defined before this line",
                WHAT[k],
                WHATS[k]
            );
        }
    }
    Ok(())
}

/// Reads a material library named by an OBJ file for tobj: missing, unreadable or malformed
/// libraries leave a note (a warning naming the library) and load no materials. A colour given as
/// one number (`Kd 0.5`, grey) is expanded to three, which tobj requires.
fn load_mtl(
    obj_file: &str,
    dir: &Path,
    lib: &Path,
    notes: &std::cell::RefCell<Vec<String>>,
) -> tobj::MTLLoadResult {
    let path = dir.join(lib);
    let shown = path.display().to_string();
    let note = |s: String| notes.borrow_mut().push(format!("{obj_file}: {s}"));
    // Only regular files: a library named /dev/zero or a FIFO would never end.
    if path.exists() && !path.is_file() {
        note(format!(
            "material library {shown} is not a regular file; its materials are grey diffuse"
        ));
        return Err(tobj::LoadError::OpenFileFailed);
    }
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            note(format!(
                "material library {shown} cannot be read ({e}); its materials are grey diffuse"
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        }
    };
    let Ok(text) = String::from_utf8(bytes) else {
        note(format!(
            "material library {shown}: not a text file (invalid UTF-8); its materials are grey diffuse"
        ));
        return Err(tobj::LoadError::ReadError);
    };
    match prescan_mtl(&shown, &text) {
        Ok(clean) => tobj::load_mtl_buf(&mut clean.as_bytes()).inspect_err(|e| {
            note(format!(
                "material library {shown}: {}; its materials are grey diffuse",
                describe(e)
            ))
        }),
        Err(msg) => {
            note(format!(
                "material library {msg}; the library's materials are grey diffuse"
            ));
            Err(tobj::LoadError::MaterialParseError)
        }
    }
}

/// Checks an MTL file line by line (colours `Ka Kd Ks Ke` one or three numbers, `Ns Ni d` one
/// number, `illum` a whole number, `newmtl` a name); returns the text with one-number colours
/// expanded, or `FILE:LINE: ...` for the first bad line.
fn prescan_mtl(file: &str, text: &str) -> Result<String, String> {
    let mut out = String::with_capacity(text.len() + 64);
    for (k, raw) in text.lines().enumerate() {
        let line_no = k + 1;
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let kw = words.next().unwrap_or("");
        let rest: Vec<&str> = words.collect();
        let nums: Option<Vec<f32>> = rest.iter().map(|w| w.parse::<f32>().ok()).collect();
        let bad = |what: &str| Err(format!("{file}:{line_no}: {what}, got '{line}'"));
        match kw {
            "Ka" | "Kd" | "Ks" | "Ke" => match nums.as_deref() {
                Some([g]) => {
                    out.push_str(&format!("{kw} {g} {g} {g}\n"));
                    continue;
                }
                Some(v) if v.len() >= 3 => {}
                _ => return bad(&format!("'{kw}' needs a colour r g b (or one grey value)")),
            },
            "Ns" | "Ni" | "d" => match nums.as_deref() {
                Some([_, ..]) => {}
                _ => return bad(&format!("'{kw}' needs a number")),
            },
            "illum" if rest.first().is_none_or(|w| w.parse::<i32>().is_err()) => {
                return bad("'illum' needs a whole number");
            }
            "newmtl" if rest.is_empty() => return bad("'newmtl' needs a material name"),
            _ => {}
        }
        out.push_str(raw);
        out.push('\n');
    }
    Ok(out)
}

fn describe(e: &tobj::LoadError) -> String {
    use tobj::LoadError::*;
    match e {
        OpenFileFailed => "cannot open file".into(),
        ReadError => "read error".into(),
        UnrecognizedCharacter => "unrecognised character".into(),
        PositionParseError => "malformed vertex position (v)".into(),
        NormalParseError => "malformed normal (vn)".into(),
        TexcoordParseError => "malformed texture coordinate (vt)".into(),
        FaceParseError => "malformed face (f)".into(),
        MaterialParseError => "malformed material statement".into(),
        InvalidObjectName => "invalid object name".into(),
        InvalidPolygon => "invalid polygon (fewer than 3 vertices)".into(),
        FaceVertexOutOfBounds => "face refers to a vertex that does not exist".into(),
        FaceTexCoordOutOfBounds => "face refers to a texture coordinate that does not exist".into(),
        FaceNormalOutOfBounds => "face refers to a normal that does not exist".into(),
        FaceColorOutOfBounds => "face refers to a vertex colour that does not exist".into(),
        InvalidLoadOptionConfig => "invalid load options".into(),
        ScalingByZeroError => "texture scale of zero".into(),
        ColorParseError => "malformed vertex colour".into(),
        GenericFailure => "unreadable".into(),
    }
}

/// The f64 nearest the decimal written in the file (tobj parses to f32; `0.8f32 as f64` would be
/// 0.800000011920929).
fn decimal(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}

fn rgb(v: Option<[f32; 3]>) -> Option<Rgb> {
    v.map(|c| Rgb::new(decimal(c[0]), decimal(c[1]), decimal(c[2])).max(Rgb::ZERO))
}

fn parse_rgb(s: &str) -> Option<Rgb> {
    let v: Vec<f64> = s
        .split_whitespace()
        .filter_map(|t| t.parse().ok())
        .collect();
    match v.as_slice() {
        [g] => Some(Rgb::splat(*g)),
        [r, g, b, ..] => Some(Rgb::new(*r, *g, *b)),
        _ => None,
    }
}

/// Maps one MTL material onto the material model (the table in [`crate::scene::material`]).
pub fn convert_material(m: &tobj::Material) -> (Material, Option<String>) {
    let emission = rgb(m.emissive).unwrap_or(Rgb::ZERO);
    let emits = emission != Rgb::ZERO;
    let mut kd = rgb(m.diffuse).unwrap_or(if emits { Rgb::ZERO } else { Rgb::splat(0.5) });
    let ks_given = rgb(m.specular);
    let mut warn = None;
    let illum = m.illumination_model.unwrap_or(2);
    let bsdf = match illum {
        0 | 1 => Bsdf::Diffuse {
            kd: kd.min(Rgb::ONE),
        },
        3 | 5 | 8 => {
            let mut ks = ks_given.unwrap_or(Rgb::ONE);
            if conserve_energy(&mut kd, &mut ks) {
                warn = Some("Kd + Ks exceeds 1; scaled down".to_string());
            }
            Bsdf::Mirror { kd, ks }
        }
        4 | 6 | 7 | 9 => {
            let ior = m
                .optical_density
                .map(decimal)
                .filter(|n| *n > 0.0 && n.is_finite())
                .unwrap_or(1.5);
            let tint = m
                .unknown_param
                .get("Tf")
                .and_then(|s| parse_rgb(s))
                .unwrap_or(Rgb::ONE)
                .clamp(Rgb::ZERO, Rgb::ONE);
            Bsdf::Dielectric { ior, tint }
        }
        _ => {
            let mut ks = ks_given.unwrap_or(Rgb::ZERO);
            if ks == Rgb::ZERO {
                Bsdf::Diffuse {
                    kd: kd.min(Rgb::ONE),
                }
            } else {
                if conserve_energy(&mut kd, &mut ks) {
                    warn = Some("Kd + Ks exceeds 1; scaled down".to_string());
                }
                let exponent = m
                    .shininess
                    .map(decimal)
                    .filter(|n| n.is_finite() && *n >= 0.0)
                    .unwrap_or(1.0);
                Bsdf::Glossy { kd, ks, exponent }
            }
        }
    };
    let bsdf = match bsdf {
        Bsdf::Diffuse { kd } if kd == Rgb::ZERO => Bsdf::Black,
        b => b,
    };
    (
        Material {
            name: m.name.clone(),
            bsdf,
            emission,
        },
        warn,
    )
}
