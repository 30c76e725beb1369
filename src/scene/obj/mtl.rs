//! MTL material libraries: read by the loader (a missing, unreadable or malformed library is a
//! warning naming it, and its materials become grey diffuse, never a panic in the parser), parsed
//! by tobj, and mapped onto the material model (the table in [`crate::scene::material`]).

use crate::math::Rgb;
use crate::scene::material::{Bsdf, Material};
use crate::scene::model::LoadReport;
use crate::scene::obj::tolerance::Tally;
use crate::scene::pbr::conserve_energy;
use std::path::Path;

/// Converts the materials of the libraries, with one warning per kind of conversion note, not
/// per material (a library may have hundreds): the count and the first material it concerns.
pub(super) fn convert_materials(
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
pub(super) fn load_mtl(
    obj_file: &str,
    path: &Path,
    notes: &mut Vec<String>,
) -> tobj::MTLLoadResult {
    let shown = path.display().to_string();
    let mut note = |s: String| notes.push(format!("{obj_file}: {s}"));
    // Only regular files: a library named /dev/zero or a FIFO would never end.
    if path.exists() && !path.is_file() {
        note(format!(
            "material library {shown} is not a regular file; its materials are grey diffuse"
        ));
        return Err(tobj::LoadError::OpenFileFailed);
    }
    let bytes = match std::fs::read(path) {
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
    // A line ending in a backslash goes on on the next, as in OBJ (line numbers are kept).
    let text = if text.contains('\\') {
        String::from_utf8_lossy(&super::lines::join_continued(text.as_bytes())).into_owned()
    } else {
        text
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

pub(super) fn describe(e: &tobj::LoadError) -> String {
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
fn convert_material(m: &tobj::Material) -> (Material, Option<String>) {
    let emission = rgb(m.emissive).unwrap_or(Rgb::ZERO);
    let emits = emission != Rgb::ZERO;
    let mut kd = rgb(m.diffuse).unwrap_or(if emits { Rgb::ZERO } else { Rgb::splat(0.5) });
    let ks_given = rgb(m.specular);
    let mut warn = None;
    let illum = m.illumination_model.unwrap_or(2);
    // An albedo above 1 would create light: clamped, and said.
    let over = |kd: Rgb| kd.max_element() > 1.0;
    // One text for all, so that the warning groups the materials it concerns.
    let clamp_note = |_: Rgb| "Kd exceeds 1; clamped to 1 per channel".to_string();
    let bsdf = match illum {
        0 | 1 => {
            if over(kd) {
                warn = Some(clamp_note(kd));
            }
            Bsdf::Diffuse {
                kd: kd.min(Rgb::ONE),
            }
        }
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
                if over(kd) {
                    warn = Some(clamp_note(kd));
                }
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
