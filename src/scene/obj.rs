//! Wavefront OBJ + MTL loading: the OBJ text through [`crate::scene::obj_parse`] (parallel, by
//! chunks of lines), the MTL libraries through tobj; triangulated meshes, shading normals when
//! present, one material per triangle. See [`crate::scene::material`] for the MTL table.

use crate::math::Rgb;
use crate::scene::material::Bsdf;
use crate::scene::material::Material;
use crate::scene::model::{LoadReport, Scene, Shading, TexCoords};
use crate::scene::obj_parse::{self, Oddity, Statement, Tally};
use crate::scene::pbr::conserve_energy;
use anyhow::{Context, bail};
use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;

/// Loads an OBJ file (and the MTL files it names) into a [`Scene`].
///
/// The file is parsed by [`crate::scene::obj_parse`] (in parallel, by chunks of lines): every
/// `v`, `vt`, `vn` and `f` statement is validated and the first bad one is reported as
/// `FILE:LINE`. What mainstream loaders go on past is one warning per kind, with the count and
/// the first line (an error at that line with `strict`): faces of fewer than 3 vertices (skipped),
/// `usemtl` without a name (default material), `mtllib` without a name, statements the loader does
/// not use, and lines that are not UTF-8 (read as Latin-1). Material libraries are read by this
/// module too ([`load_mtl`]), so that a missing or malformed one is a warning naming it (its
/// materials become grey diffuse), never a panic in the parser. A file without faces is an error.
///
/// What the scene keeps matches what tobj (the parser this replaced) gave, triangle for
/// triangle: polygons fanned from their first vertex in file order; materials resolved by name at
/// the `usemtl` line against the libraries named before it (a later library's material of the
/// same name wins); shading normals from `vn` for every face of an object or material run whose
/// faces all give them, zero (the geometric normal) for the faces of a run where one does not, and
/// none at all when no face has a non-zero one.
///
/// Texture coordinates (`vt`, v up as in the file) are kept per face corner, as an index into the
/// `vt` table, when some material reads a texture ([`Material::maps`]); a corner whose face
/// gives no `vt` index reads (0, 0), and so do faces of files without `vt`.
pub fn load(path: &Path, strict: bool) -> anyhow::Result<Scene> {
    let file = path.display().to_string();
    if !path.is_file() {
        bail!("{file}: no such scene file");
    }
    let data = obj_parse::parse_file(path, strict).map_err(|(line, msg)| match line {
        0 => anyhow::anyhow!("{file}: {msg}"),
        _ => anyhow::anyhow!("{file}:{line}: {msg}"),
    })?;
    let mut report = LoadReport {
        warnings: oddity_warnings(&file, &data),
        ..Default::default()
    };
    if data.positions.len() >= u32::MAX as usize
        || data.normals.len() >= u32::MAX as usize
        || data.texcoords.len() >= u32::MAX as usize
    {
        bail!("{file}: more than 2^32 - 2 vertices, normals or texture coordinates");
    }
    if data.triangles.is_empty() {
        bail!(
            "{file}: no geometry: the file has no faces ('f' statements){}",
            if data.positions.is_empty() {
                " and no vertices"
            } else {
                ""
            }
        );
    }
    let dir = path.parent().unwrap_or(Path::new(""));

    // Materials, in file order: libraries as they are named, `usemtl` resolved against those
    // named before it; runs of faces end at `o`, `g` and a `usemtl` that changes the material.
    let mut mtl_notes = Vec::new();
    let mut list: Vec<tobj::Material> = Vec::new();
    let mut lib_dirs: Vec<std::path::PathBuf> = Vec::new();
    let mut by_name: HashMap<String, usize> = HashMap::new();
    let mut mtl_error = None;
    // (first triangle, material or None) of each run.
    let mut runs: Vec<(usize, Option<usize>)> = vec![(0, None)];
    for event in &data.events {
        match &event.what {
            Statement::Mtllib(lib) => {
                match load_mtl(&file, dir, Path::new(lib), &mut mtl_notes) {
                    Ok((mut mats, map)) => {
                        let offset = list.len();
                        // Texture paths are relative to the library's own directory.
                        let lib_dir = dir.join(lib).parent().map(Path::to_path_buf);
                        lib_dirs
                            .extend(std::iter::repeat_n(lib_dir.unwrap_or_default(), mats.len()));
                        list.append(&mut mats);
                        by_name.extend(map.into_iter().map(|(k, i)| (k, i + offset)));
                    }
                    Err(e) => mtl_error = Some(e),
                }
                continue;
            }
            Statement::Usemtl(name) => {
                let id = name.as_ref().and_then(|n| by_name.get(n).copied());
                let current = runs.last().and_then(|r| r.1);
                if id == current {
                    continue;
                }
                push_run(&mut runs, event.tri, id);
            }
            Statement::Group => {
                let current = runs.last().and_then(|r| r.1);
                push_run(&mut runs, event.tri, current);
            }
        }
    }
    let mut materials = convert_materials(&file, &list, &mut report);
    let textures =
        crate::scene::mtl_maps::apply(&file, &list, &lib_dirs, &mut materials, &mut report);
    if materials.is_empty()
        && let Some(e) = mtl_error
        && mtl_notes.is_empty()
    {
        report.warnings.push(format!(
            "{file}: material library not loaded ({}); using grey diffuse",
            describe(&e)
        ));
    }
    report.warnings.extend(mtl_notes);
    // Index of the default material for faces without one.
    let default_id = materials.len() as u32;
    materials.push(Material::default_grey());

    let n = data.triangles.len();
    let mut tri_material = Vec::with_capacity(n);
    for (k, &(start, id)) in runs.iter().enumerate() {
        let end = runs.get(k + 1).map_or(n, |r| r.0);
        let id = id.map_or(default_id, |i| i as u32);
        tri_material.extend(std::iter::repeat_n(id, end - start));
    }
    let shading = shading_normals(&data, &runs);
    // What the scene does not keep is freed here, before its own buffers are made and Embree
    // builds; texture coordinates are kept only for textured materials (`Scene::from_parts`
    // checks it too).
    let obj_parse::ObjData {
        positions,
        triangles,
        texcoords,
        tri_texcoords,
        normals,
        tri_normals,
        ..
    } = data;
    drop((normals, tri_normals));
    let texcoords = if materials.iter().any(|m| m.maps.reads_textures()) && !texcoords.is_empty() {
        TexCoords::PerCorner {
            table: texcoords,
            corners: tri_texcoords,
        }
    } else {
        drop((texcoords, tri_texcoords));
        TexCoords::None
    };
    let mut scene = Scene::from_parts(
        path,
        positions,
        triangles,
        tri_material,
        shading,
        texcoords,
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
    scene.attach_textures(textures);
    Ok(scene)
}

/// Starts a run of faces at triangle `tri` (replacing the previous run when it is still empty).
fn push_run(runs: &mut Vec<(usize, Option<usize>)>, tri: usize, id: Option<usize>) {
    match runs.last_mut() {
        Some(last) if last.0 == tri => last.1 = id,
        _ => runs.push((tri, id)),
    }
}

/// The shading normals of every triangle's corners (see [`load`]), on huge pages like the other
/// per-triangle records the hit code reads.
fn shading_normals(data: &obj_parse::ObjData, runs: &[(usize, Option<usize>)]) -> Shading {
    use rayon::prelude::*;
    if data.normals.is_empty() {
        return Shading::None;
    }
    let n = data.triangles.len();
    let end_of = |k: usize| runs.get(k + 1).map_or(n, |r| r.0);
    // A run whose faces all give normals keeps them; the others get zero normals.
    let complete: Vec<bool> = (0..runs.len())
        .into_par_iter()
        .map(|k| {
            data.tri_normals[runs[k].0..end_of(k)]
                .iter()
                .all(|t| !t.contains(&obj_parse::MISSING))
        })
        .collect();
    if !complete.iter().any(|&c| c) {
        return Shading::None;
    }
    let normals = &data.normals;
    let mut shading: Vec<[Vec3; 3]> = crate::accel::vec_with_huge_pages(n);
    shading.par_extend(rayon::iter::repeat_n([Vec3::ZERO; 3], n));
    const CHUNK: usize = 1 << 16;
    shading
        .par_chunks_mut(CHUNK)
        .zip(data.tri_normals.par_chunks(CHUNK))
        .enumerate()
        .for_each(|(j, (out, vns))| {
            let t0 = j * CHUNK;
            // The run of the chunk's first triangle: the last one starting at or before it.
            let mut k = runs.partition_point(|r| r.0 <= t0) - 1;
            for (i, (o, vn)) in out.iter_mut().zip(vns).enumerate() {
                while t0 + i >= end_of(k) {
                    k += 1;
                }
                if complete[k] {
                    *o = vn.map(|i| normals[i as usize]);
                }
            }
        });
    let non_zero = || {
        shading
            .par_iter()
            .any(|c| c.iter().any(|v| *v != Vec3::ZERO))
    };
    if complete.iter().all(|&c| c) || non_zero() {
        Shading::PerCorner(shading)
    } else {
        // Runs without normals and only zero ones elsewhere: no shading normals (tobj's result).
        Shading::None
    }
}

/// The warnings of a tolerant parse, one per kind, in the order of their first lines.
fn oddity_warnings(file: &str, data: &obj_parse::ObjData) -> Vec<String> {
    let times = |t: &Tally| {
        if t.count == 1 {
            String::new()
        } else {
            format!(", {} lines", t.count)
        }
    };
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut unused = Tally::default();
    for (_, t) in &data.unused {
        if unused.count == 0 || t.first < unused.first {
            unused.first = t.first;
        }
        unused.count += t.count;
    }
    if unused.count > 0 {
        let kinds: Vec<String> = data
            .unused
            .iter()
            .map(|(k, t)| match t.count {
                1 => format!("'{k}'"),
                c => format!("'{k}' ×{c}"),
            })
            .collect();
        out.push((
            unused.first,
            format!(
                "{file}:{}: statements the loader does not use ({}); ignored{}",
                unused.first,
                kinds.join(", "),
                times(&unused)
            ),
        ));
    }
    for kind in obj_parse::ODDITIES {
        let t = &data.oddities[kind as usize];
        if t.count == 0 {
            continue;
        }
        let what = match kind {
            Oddity::ShortFace => "faces with fewer than 3 vertices (points, lines); skipped",
            Oddity::BareUsemtl => {
                "'usemtl' without a name; the faces after it get the default material"
            }
            Oddity::BareMtllib => "'mtllib' without a file name; ignored",
            Oddity::NotUtf8 => "not UTF-8 text; read as Latin-1",
        };
        out.push((t.first, format!("{file}:{}: {what}{}", t.first, times(t))));
    }
    out.sort_by_key(|(line, _)| *line);
    out.into_iter().map(|(_, w)| w).collect()
}

/// Converts the materials of the libraries, with one warning per kind of conversion note, not
/// per material (a library may have hundreds): the count and the first material it concerns.
fn convert_materials(
    file: &str,
    list: &[tobj::Material],
    report: &mut LoadReport,
) -> Vec<Material> {
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

/// Reads a material library named by an OBJ file for tobj: missing, unreadable or malformed
/// libraries leave a note (a warning naming the library) and load no materials. Lines that are not
/// UTF-8 are read as Latin-1 (one note with their count and the first). A colour given as one
/// number (`Kd 0.5`, grey) is expanded to three, which tobj requires.
fn load_mtl(
    obj_file: &str,
    dir: &Path,
    lib: &Path,
    notes: &mut Vec<String>,
) -> tobj::MTLLoadResult {
    let path = dir.join(lib);
    let shown = path.display().to_string();
    let mut note = |s: String| notes.push(format!("{obj_file}: {s}"));
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
    let text = match String::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let (text, latin) = text_or_latin1(e.as_bytes());
            let times = match latin.count {
                1 => String::new(),
                c => format!(", {c} lines"),
            };
            note(format!(
                "material library {shown}:{}: not UTF-8 text; read as Latin-1{times}",
                latin.first
            ));
            text
        }
    };
    match prescan_mtl(&shown, &text) {
        Ok(clean) => {
            // The checks above keep tobj away from the inputs it is known to panic on; should it
            // still panic, the library is reported as unreadable rather than the run aborting.
            let parsed = std::panic::catch_unwind(|| tobj::load_mtl_buf(&mut clean.as_bytes()));
            match parsed {
                Ok(result) => result.inspect_err(|e| {
                    note(format!(
                        "material library {shown}: {}; its materials are grey diffuse",
                        describe(e)
                    ))
                }),
                Err(_) => {
                    note(format!(
                        "material library {shown}: the MTL parser failed on it (please report \
                         it); its materials are grey diffuse"
                    ));
                    Err(tobj::LoadError::GenericFailure)
                }
            }
        }
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
            // A map without a file names nothing to read (tobj would refuse the library).
            k if k.starts_with("map_") && rest.is_empty() => continue,
            _ => {}
        }
        out.push_str(raw);
        out.push('\n');
    }
    Ok(out)
}

/// The text of `bytes` line by line: UTF-8 lines as they are, the others read as Latin-1, and
/// how many of those there were (with the first line).
fn text_or_latin1(bytes: &[u8]) -> (String, Tally) {
    let mut text = String::with_capacity(bytes.len() + bytes.len() / 8);
    let mut latin = Tally::default();
    for (k, line) in bytes.split(|&b| b == b'\n').enumerate() {
        if k > 0 {
            text.push('\n');
        }
        match std::str::from_utf8(line) {
            Ok(s) => text.push_str(s),
            Err(_) => {
                if latin.count == 0 {
                    latin.first = k + 1;
                }
                latin.count += 1;
                text.extend(line.iter().map(|&b| b as char));
            }
        }
    }
    (text, latin)
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
            maps: Default::default(),
        },
        warn,
    )
}
