//! The texture maps and cut-outs of MTL materials: `map_Kd` (replaces `Kd`), `map_Ks` (replaces
//! `Ks`), `map_Ke` (times `Ke`, or alone where there is none), `map_d` and `d` (coverage), read
//! after the materials are converted ([`crate::scene::obj::mtl`]).
//!
//! - A map statement's file is its last word (the options before it, `-o`, `-s`, `-bm`, …, are
//!   skipped, except `-clamp on`, which clamps instead of repeating, and `-imfchan` for `map_d`);
//!   backslashes are read as path separators; the path is relative to the MTL file.
//! - `map_Kd` and `map_Ks` replace the constant colour, as the mainstream importers do (the MTL
//!   text says "multiplied"; exporters write a `Kd` beside the map that was never meant to darken
//!   it). Colour maps are sRGB-decoded; `map_d` is read as stored.
//! - Coverage α = `d` × the `map_d` texel: its alpha channel when the image has one (some texel
//!   below 1), else its red channel (a grey map), or the channel `-imfchan` names. Cut-outs are
//!   stochastic ([`AlphaMode::Stochastic`]): present with probability α, so binary leaf masks
//!   are exact and fractional `d` is unbiased. Dielectrics (`illum` 4, 6, 7, 9) ignore `d`:
//!   their transparency is the refraction itself. `Tr` is not read (its sense differs between
//!   exporters).
//! - A map whose file is missing or cannot be decoded leaves a warning (the count and the first
//!   file), and its material keeps its constant values. Bump, normal and other maps are not read:
//!   one warning with their count.
//! - An emitter with `map_Ke` is still chosen for light sampling, and its points drawn, by its
//!   constant `Ke`; the radiance at the drawn point and at every hit is the texel's
//!   (`transport::light::texture_light_sample`).

use crate::math::Rgb;
use crate::scene::material::{Alpha, AlphaMode, Bsdf, Material, TextureRef};
use crate::scene::model::LoadReport;
use crate::scene::texture::{Encoding, Texture, TextureSet, UvTransform, Wrap};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Which map a request fills.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Slot {
    Base,
    Specular,
    Emission,
    Alpha,
}

/// A map statement's value: its file (the last word, backslashes as separators), whether it
/// clamps, and the `-imfchan` channel if given.
struct MapSpec {
    file: PathBuf,
    clamp: bool,
    channel: Option<usize>,
}

fn parse_map(value: &str) -> Option<MapSpec> {
    let words: Vec<&str> = value.split_whitespace().collect();
    let file = words.last()?;
    if file.starts_with('-') {
        return None;
    }
    let option = |name: &str| {
        words[..words.len() - 1]
            .iter()
            .position(|w| *w == name)
            .and_then(|i| words.get(i + 1))
            .copied()
    };
    let channel = option("-imfchan").and_then(|c| match c {
        "r" | "l" | "m" | "z" => Some(0),
        "g" => Some(1),
        "b" => Some(2),
        _ => None,
    });
    Some(MapSpec {
        file: PathBuf::from(file.replace('\\', "/")),
        clamp: option("-clamp") == Some("on"),
        channel,
    })
}

/// Reads the maps of `list` (tobj's materials, converted to `materials` in the same order;
/// `dirs[k]` is the directory of material k's MTL file) and gives the materials their texture
/// references and cut-outs. Returns the decoded textures (each file once, in parallel).
pub(super) fn apply(
    file: &str,
    list: &[tobj::Material],
    dirs: &[PathBuf],
    materials: &mut [Material],
    report: &mut LoadReport,
) -> TextureSet {
    let Requests {
        files,
        uses,
        unread,
    } = Requests::of(list, dirs);
    if unread.0 > 0 {
        report.warnings.push(format!(
            "{file}: {} texture maps other than map_Kd, map_Ks, map_Ke and map_d are not read (the first: \
             {}); their materials use their constant values",
            unread.0, unread.1
        ));
    }
    let (set, id) = decode(file, &files, report);
    for (k, slot, r, spec) in uses {
        if let Some(texture) = id[r] {
            give_map(&mut materials[k], slot, texture, &spec, &set);
        }
    }
    apply_dissolve(list, materials);
    report.texture_bytes += set.bytes();
    set
}

/// The maps materials name: each distinct (file, encoding) once, each use of one by a material,
/// and the maps that are not read (their count and the first).
struct Requests {
    files: Vec<(PathBuf, Encoding)>,
    /// (material, slot, index into `files`, spec)
    uses: Vec<(usize, Slot, usize, MapSpec)>,
    unread: (usize, String),
}

impl Requests {
    fn of(list: &[tobj::Material], dirs: &[PathBuf]) -> Requests {
        let mut files: Vec<(PathBuf, Encoding)> = Vec::new();
        let mut index: HashMap<(PathBuf, Encoding), usize> = HashMap::new();
        let mut uses = Vec::new();
        let mut unread = (0usize, String::new());
        for (k, m) in list.iter().enumerate() {
            let dir = dirs.get(k).map_or(Path::new(""), |d| d.as_path());
            let maps = [
                (m.diffuse_texture.as_deref(), Slot::Base, Encoding::Colour),
                (
                    m.specular_texture.as_deref(),
                    Slot::Specular,
                    Encoding::Colour,
                ),
                (
                    m.unknown_param.get("map_Ke").map(String::as_str),
                    Slot::Emission,
                    Encoding::Colour,
                ),
                (m.dissolve_texture.as_deref(), Slot::Alpha, Encoding::Linear),
            ];
            for (value, slot, encoding) in maps {
                let Some(spec) = value.and_then(parse_map) else {
                    continue;
                };
                let key = (dir.join(&spec.file), encoding);
                let r = *index.entry(key.clone()).or_insert_with(|| {
                    files.push(key);
                    files.len() - 1
                });
                uses.push((k, slot, r, spec));
            }
            for key in m.unknown_param.keys() {
                let map = key.starts_with("map_") && key != "map_Ke";
                if map || key == "bump" || key == "disp" || key == "norm" {
                    if unread.0 == 0 {
                        unread.1 = format!("'{key}' of material '{}'", m.name);
                    }
                    unread.0 += 1;
                }
            }
            if m.normal_texture.is_some()
                || m.ambient_texture.is_some()
                || m.shininess_texture.is_some()
            {
                if unread.0 == 0 {
                    unread.1 = format!("a bump, ambient or shininess map of material '{}'", m.name);
                }
                unread.0 += 1;
            }
        }
        Requests {
            files,
            uses,
            unread,
        }
    }
}

/// Decodes `files` in parallel: the textures that could be read, and for each file its index
/// among them (`None`: it failed, one warning for all with the first failure).
fn decode(
    file: &str,
    files: &[(PathBuf, Encoding)],
    report: &mut LoadReport,
) -> (TextureSet, Vec<Option<u32>>) {
    let decoded: Vec<Result<Texture, String>> = files
        .par_iter()
        .map(|(p, e)| Texture::load(p, *e).map_err(|err| format!("{err:#}")))
        .collect();
    let failed: Vec<&String> = decoded.iter().filter_map(|d| d.as_ref().err()).collect();
    if let Some(first) = failed.first() {
        report.warnings.push(format!(
            "{file}: {} texture file(s) could not be read (the first: {first}); their materials use \
             their constant values",
            failed.len()
        ));
    }
    // Keep the decoded textures only, renumbered.
    let mut set = TextureSet::default();
    let mut id: Vec<Option<u32>> = Vec::with_capacity(decoded.len());
    for d in decoded {
        id.push(d.ok().map(|t| {
            set.textures.push(Arc::new(t));
            set.textures.len() as u32 - 1
        }));
    }
    (set, id)
}

/// Gives material `m` texture `texture` of `set` in `slot`, as `spec` says.
fn give_map(m: &mut Material, slot: Slot, texture: u32, spec: &MapSpec, set: &TextureSet) {
    let wrap = if spec.clamp {
        Wrap::ClampToEdge
    } else {
        Wrap::Repeat
    };
    let tref = TextureRef {
        texture,
        factor: Rgb::ONE,
        wrap: (wrap, wrap),
        transform: UvTransform::default(),
    };
    match slot {
        Slot::Base => {
            // A black Kd beside the map would have made the material black at load.
            if m.bsdf == Bsdf::Black && m.emission == Rgb::ZERO {
                m.bsdf = Bsdf::Diffuse { kd: Rgb::ONE };
            }
            m.maps.base_color = Some(tref);
        }
        Slot::Specular => m.maps.specular = Some(tref),
        Slot::Emission => {
            // The texel times `Ke` (1 where the map comes without one).
            if m.emission == Rgb::ZERO {
                m.emission = Rgb::ONE;
            }
            m.maps.emission = Some(tref);
        }
        Slot::Alpha => {
            let t = &set.textures[texture as usize];
            let channel = spec
                .channel
                .unwrap_or(if t.has_partial_alpha() { 3 } else { 0 });
            m.maps.alpha = Some(Alpha {
                factor: 1.0,
                map: Some(tref),
                channel,
                mode: AlphaMode::Stochastic,
            });
        }
    }
}

/// `d`: the constant coverage (times the map's); dielectrics are transparent by refraction.
fn apply_dissolve(list: &[tobj::Material], materials: &mut [Material]) {
    for (k, m) in list.iter().enumerate() {
        let mat = &mut materials[k];
        if matches!(mat.bsdf, Bsdf::Dielectric { .. }) {
            mat.maps.alpha = None;
            continue;
        }
        let Some(d) = m.dissolve.map(|d| d as f64).filter(|d| d.is_finite()) else {
            continue;
        };
        let d = d.clamp(0.0, 1.0);
        match mat.maps.alpha.as_mut() {
            Some(a) => a.factor = d,
            None if d < 1.0 => {
                mat.maps.alpha = Some(Alpha {
                    factor: d,
                    map: None,
                    channel: 3,
                    mode: AlphaMode::Stochastic,
                })
            }
            None => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_statements_name_their_file_last_and_keep_clamp_and_channel() {
        let m = parse_map("-s 1 1 1 -clamp on -imfchan m textures\\leaf.png").unwrap();
        assert_eq!(m.file, PathBuf::from("textures/leaf.png"));
        assert!(m.clamp);
        assert_eq!(m.channel, Some(0));
        let m = parse_map("wood.jpg").unwrap();
        assert!(!m.clamp && m.channel.is_none());
        assert!(parse_map("").is_none());
        assert!(parse_map("-clamp").is_none());
    }
}
