//! The texture maps and cut-outs of MTL materials: `map_Kd` (replaces `Kd`), `map_Ks` (replaces
//! `Ks`), `map_Ke` (times `Ke`, or alone where there is none), `map_d` and `d` (coverage), read
//! after the materials are converted ([`crate::scene::obj::mtl`]).
//!
//! - A map statement's file is what follows its options, spaces and all (`map_Kd -s 2 2 my
//!   texture.png`); the options (`-o`, `-s`, `-t` with up to three numbers, `-bm`, `-mm`, ...) are
//!   skipped, except `-clamp on`, which clamps instead of repeating, and `-imfchan` for `map_d`;
//!   backslashes are read as path separators; the path is relative to the MTL file.
//! - `map_Kd` and `map_Ks` replace the constant colour, as the mainstream importers do (the MTL
//!   text says "multiplied"; exporters write a `Kd` beside the map that was never meant to darken
//!   it). Colour maps are sRGB-decoded; `map_d` is read as stored.
//! - Coverage α = `d` × the `map_d` texel: its alpha channel when the image has one (even if every
//!   texel is opaque), else its grey level (a grey map, or an RGB image whose channels are equal)
//!   or, with a warning, the red channel of a coloured RGB image; or the channel `-imfchan` names. Cut-outs are
//!   stochastic ([`AlphaMode::Stochastic`]): present with probability α, so binary leaf masks
//!   are exact and fractional `d` is unbiased. Dielectrics (`illum` 4, 6, 7, 9) ignore `d`:
//!   their transparency is the refraction itself. `Tr` is not read (its sense differs between
//!   exporters).
//! - A map may lie only inside the OBJ file's folder (or below), as the load's reach says
//!   ([`crate::scene::files::Reach`]): one that leaves it refuses the file, naming the map.
//! - A map whose file is missing or cannot be decoded leaves a warning naming it and its
//!   materials, which keep their constant values; one that is not a regular file (a FIFO, a
//!   device, a directory) is refused at once, naming it and its material, like a scene file of
//!   that kind (opening a FIFO would block the load). Texels that
//!   are negative or not finite (a float EXR) are set to 0, with a warning that counts them. Bump, normal and other maps are not read:
//!   one warning with their count.
//! - An emitter with `map_Ke` is still chosen for light sampling, and its points drawn, by its
//!   constant `Ke`; the radiance at the drawn point and at every hit is the texel's
//!   (`transport::light::texture_light_sample`).

use crate::math::Rgb;
use crate::scene::error::LoadError;
use crate::scene::files::Reach;
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

impl Slot {
    /// The MTL statement that names a map of this slot.
    fn statement(self) -> &'static str {
        match self {
            Slot::Base => "map_Kd",
            Slot::Specular => "map_Ks",
            Slot::Emission => "map_Ke",
            Slot::Alpha => "map_d",
        }
    }
}

/// A map statement's value: its file (the last word, backslashes as separators), whether it
/// clamps, and the `-imfchan` channel if given.
struct MapSpec {
    file: PathBuf,
    clamp: bool,
    channel: Option<usize>,
}

fn parse_map(value: &str) -> Option<MapSpec> {
    // The options (MTL's `-name` followed by its arguments) and then the file name, which may
    // hold spaces: everything after the options, as written.
    let mut rest = value.trim();
    let (mut clamp, mut channel) = (false, None);
    while rest.starts_with('-') {
        let (name, after) = split_word(rest);
        // Options of up to three numbers (-o, -s, -t) take what parses as a number; the others
        // take a fixed count.
        let fixed = match name {
            "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-clamp" | "-imfchan"
            | "-texres" | "-type" => Some(1),
            "-mm" => Some(2),
            "-o" | "-s" | "-t" => None,
            // An option not known: its word alone.
            _ => Some(0),
        };
        rest = after;
        let mut args = Vec::new();
        for _ in 0..fixed.unwrap_or(3) {
            let (word, after) = split_word(rest);
            if word.is_empty() || (fixed.is_none() && word.parse::<f64>().is_err()) {
                break;
            }
            args.push(word);
            rest = after;
        }
        match (name, args.first()) {
            ("-clamp", Some(v)) => clamp = *v == "on",
            ("-imfchan", Some(c)) => {
                channel = match *c {
                    "r" | "l" | "m" | "z" => Some(0),
                    "g" => Some(1),
                    "b" => Some(2),
                    _ => None,
                }
            }
            _ => {}
        }
    }
    if rest.is_empty() {
        return None;
    }
    Some(MapSpec {
        file: PathBuf::from(rest.replace('\\', "/")),
        clamp,
        channel,
    })
}

/// The first whitespace-separated word of `s` and what follows it (trimmed at the start).
fn split_word(s: &str) -> (&str, &str) {
    let s = s.trim_start();
    let end = s.find(char::is_whitespace).unwrap_or(s.len());
    (&s[..end], s[end..].trim_start())
}

/// Reads the maps of `list` (tobj's materials, converted to `materials` in the same order;
/// `dirs[k]` is the directory of material k's MTL file) and gives the materials their texture
/// references and cut-outs. Returns the decoded textures (each file once, in parallel).
pub(super) fn apply(
    (path, reach): (&Path, &Reach),
    list: &[tobj::Material],
    dirs: &[PathBuf],
    materials: &mut [Material],
    report: &mut LoadReport,
) -> Result<TextureSet, LoadError> {
    let Requests {
        files,
        uses,
        unread,
    } = Requests::of(list, dirs, (path, reach))?;
    let file = &path.display().to_string();
    if unread.0 > 0 {
        report.warnings.push(format!(
            "{file}: {} texture maps other than map_Kd, map_Ks, map_Ke and map_d are not read (the first: \
             {}); their materials use their constant values",
            unread.0, unread.1
        ));
    }
    let users = |r: usize| {
        let names: Vec<&str> = uses
            .iter()
            .filter(|u| u.2 == r)
            .map(|u| list[u.0].name.as_str())
            .collect();
        match names.as_slice() {
            [] => "no material uses it".to_string(),
            [one] => format!("material '{one}' keeps its constant values"),
            [first, rest @ ..] => format!(
                "material '{first}' and {} other(s) keep their constant values",
                rest.len()
            ),
        }
    };
    for (r, (path, _)) in files.iter().enumerate() {
        if let Err(source) = crate::scene::texture::regular(path) {
            let material = uses.iter().find(|u| u.2 == r).map(|u| &list[u.0].name);
            return Err(LoadError::Image {
                file: PathBuf::from(file),
                image: format!(
                    "the texture of material '{}'",
                    material.map_or("", String::as_str)
                ),
                source,
            });
        }
    }
    let (set, id) = decode(file, &files, users, report);
    for (k, slot, r, spec) in uses {
        if let Some(texture) = id[r] {
            let t = &set.textures[texture as usize];
            // map_d without -imfchan on a coloured RGB image: which channel is the coverage is a
            // guess (a grey one has one value to read).
            if slot == Slot::Alpha && spec.channel.is_none() && t.channels == 3 && !t.is_grey() {
                report.warnings.push(format!(
                    "{file}: map_d {} of material '{}' has no alpha channel; its red channel is \
                     read as the coverage (-imfchan names another)",
                    t.source, list[k].name
                ));
            }
            give_map(&mut materials[k], slot, texture, &spec, &set);
        }
    }
    apply_dissolve(list, materials);
    report.texture_bytes += set.bytes();
    Ok(set)
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
    /// The maps of `list`, each file within `reach` (of the OBJ file at `path`).
    fn of(
        list: &[tobj::Material],
        dirs: &[PathBuf],
        (path, reach): (&Path, &Reach),
    ) -> Result<Requests, LoadError> {
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
                let at = reach
                    .resolve(dir, &spec.file.to_string_lossy())
                    .map_err(|o| LoadError::Outside {
                        file: path.to_path_buf(),
                        what: format!("the {} map of material '{}'", slot.statement(), m.name),
                        name: spec.file.display().to_string(),
                        folder: o.folder,
                        why: o.why,
                    })?;
                let key = (at, encoding);
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
        Ok(Requests {
            files,
            uses,
            unread,
        })
    }
}

/// Decodes `files` in parallel: the textures that could be read, and for each file its index
/// among them (`None`: it failed, a warning naming it and, through `users`, its materials).
fn decode(
    file: &str,
    files: &[(PathBuf, Encoding)],
    users: impl Fn(usize) -> String,
    report: &mut LoadReport,
) -> (TextureSet, Vec<Option<u32>>) {
    let decoded: Vec<Result<Texture, String>> = files
        .par_iter()
        .map(|(p, e)| Texture::load(p, *e).map_err(|err| format!("{err:#}")))
        .collect();
    for (k, d) in decoded.iter().enumerate() {
        match d {
            Err(e) => report
                .warnings
                .push(format!("{file}: {e}; {} in place of this map", users(k))),
            Ok(t) => report.warnings.extend(t.notes.iter().cloned()),
        }
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
            // The alpha channel where the image has one (even if every texel is opaque), else
            // the grey or red channel.
            let alpha = t.channels == 2 || t.channels == 4 || t.has_partial_alpha();
            let channel = spec.channel.unwrap_or(if alpha { 3 } else { 0 });
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
        let m = parse_map("-s 2 2 -bm 0.5 my wood  grain.jpg").unwrap();
        assert_eq!(m.file, PathBuf::from("my wood  grain.jpg"));
        let m = parse_map("-o 0.5 textures/a b.png").unwrap();
        assert_eq!(m.file, PathBuf::from("textures/a b.png"));
        assert!(parse_map("").is_none());
        assert!(parse_map("-clamp").is_none());
    }
}
