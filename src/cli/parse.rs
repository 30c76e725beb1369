//! Parsers of command-line values (clap `value_parser`s): each error says what was expected.

use crate::math::parse_floats;
use glam::DVec3;
use std::time::Duration;

/// Parses `--point-light x,y,z:r,g,b` (position, then radiant intensity per steradian).
pub fn parse_point_light(s: &str) -> Result<(DVec3, DVec3), String> {
    let (p, i) = s
        .split_once(':')
        .ok_or_else(|| format!("'{s}': expected x,y,z:r,g,b"))?;
    let three = |t: &str, what: &str, names: &str| {
        parse_floats::<3>(t, names)
            .map(DVec3::from)
            .map_err(|e| format!("'{s}': {what}: {e}"))
    };
    let (pos, int) = (
        three(p, "position", "x,y,z")?,
        three(i, "intensity", "r,g,b")?,
    );
    crate::app::point_light(pos, int).map_err(|e| format!("'{s}': {e}"))?;
    Ok((pos, int))
}

/// Parses `--light-scale NAME=FACTOR` (split at the last `=`: a material name may hold one):
/// a light's name, or `*`, and a finite factor ≥ 0.
pub fn parse_light_scale(s: &str) -> Result<(String, f64), String> {
    let (name, k) = s
        .rsplit_once('=')
        .ok_or_else(|| format!("'{s}': expected NAME=FACTOR (e.g. light=0.5, or *=2)"))?;
    if name.is_empty() {
        return Err(format!("'{s}': no light name before '='"));
    }
    match k.trim().parse::<f64>() {
        Ok(k) if k.is_finite() && k >= 0.0 => Ok((name.to_string(), k)),
        _ => Err(format!(
            "'{s}': the factor must be a finite number ≥ 0 (0 switches the light off)"
        )),
    }
}

/// Parses `--sun x,y,z:r,g,b[:diameter]`: the direction towards the sun (any length), the
/// irradiance it gives a surface facing it, and its angular diameter in degrees (default
/// [`crate::scene::DEFAULT_SUN_DIAMETER_DEG`]; 0 for a Dirac delta in direction).
pub fn parse_sun(s: &str) -> Result<crate::scene::Light, String> {
    let parts: Vec<&str> = s.split(':').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(format!("'{s}': expected x,y,z:r,g,b[:diameter in degrees]"));
    }
    let three = |t: &str, what: &str, names: &str| {
        parse_floats::<3>(t, names)
            .map(DVec3::from)
            .map_err(|e| format!("'{s}': {what}: {e}"))
    };
    let dir = three(parts[0], "direction", "x,y,z")?;
    let e = three(parts[1], "irradiance", "r,g,b")?;
    let diameter = match parts.get(2) {
        None => None,
        Some(t) => Some(
            t.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{s}': {}", crate::app::LightError::Diameter))?,
        ),
    };
    crate::app::sun(dir, e, diameter).map_err(|e| format!("'{s}': {e}"))
}

/// Parses `--sky r,g,b`: constant radiance from every direction that leaves the scene.
pub fn parse_sky(s: &str) -> Result<crate::scene::Light, String> {
    let radiance = DVec3::from(parse_floats::<3>(s, "r,g,b")?);
    crate::app::sky(radiance).map_err(|e| format!("'{s}': {e}"))
}

/// Parses `--env FILE[:SCALE[:ROT_DEG]]` and reads the map: a lat-long `.exr` or `.hdr` (Mitsuba
/// 3's convention), its radiance scaled by SCALE (default 1) and turned about +y by ROT_DEG
/// degrees (default 0).
pub fn parse_env(s: &str) -> Result<crate::scene::Light, String> {
    // The file name may itself hold ':' only before the last two fields that parse as numbers.
    let mut parts: Vec<&str> = s.split(':').collect();
    let mut nums = Vec::new();
    while parts.len() > 1 && nums.len() < 2 {
        match parts.last().unwrap().trim().parse::<f64>() {
            Ok(v) => {
                nums.push(v);
                parts.pop();
            }
            Err(_) => break,
        }
    }
    nums.reverse();
    let file = parts.join(":");
    let (scale, rot) = (
        nums.first().copied().unwrap_or(1.0),
        nums.get(1).copied().unwrap_or(0.0),
    );
    crate::app::environment(std::path::Path::new(&file), scale, rot).map_err(|e| format!("{e:#}"))
}

/// Parses `X,Y,Z` (`--eye`, `--target`, `--up`).
pub fn parse_vec3(s: &str) -> Result<DVec3, String> {
    parse_floats(s, "x,y,z").map(DVec3::from)
}

/// Parses `--window u0,v0,u1,v1`.
pub fn parse_window(s: &str) -> Result<[f64; 4], String> {
    parse_floats(s, "u0,v0,u1,v1")
}

/// Parses `--size W,H` (whole numbers).
pub fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s
        .split_once(',')
        .ok_or_else(|| format!("'{s}': expected W,H such as 640,480"))?;
    let p = |t: &str| {
        t.trim()
            .parse::<usize>()
            .map_err(|_| format!("'{t}' is not a whole number"))
    };
    Ok((p(w)?, p(h)?))
}

/// Worker threads above this many per core are refused ([`parse_threads`]): the work is CPU
/// bound, so more threads than a few per core only cost memory and start-up time, and a count a
/// thousand times the cores (a typo, a variable holding something else) would start threads for
/// minutes before any sample.
pub const MAX_THREADS_PER_CORE: usize = 64;

/// The largest `--threads` this machine takes: [`MAX_THREADS_PER_CORE`] × its available
/// parallelism (cores, or the CPU quota of the container).
pub fn max_threads() -> usize {
    MAX_THREADS_PER_CORE * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Parses `--threads N`: 0 for every core, else at most [`max_threads`].
pub fn parse_threads(s: &str) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let n: usize = s.trim().parse().map_err(|_| {
        format!("'{s}' is not a whole number ≥ 0 (0: all {cores} cores of this machine)")
    })?;
    let max = max_threads();
    if n > max {
        return Err(format!(
            "{n} threads is more than {MAX_THREADS_PER_CORE} per core of this machine's {cores} \
             cores: give at most {max}, or 0 for one per core"
        ));
    }
    Ok(n)
}

/// Parses a count of cells (`--res`): a whole number, 1 or more (0 is refused with the domain).
pub fn parse_cells(s: &str) -> Result<usize, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number of cells (1 or more)"))
}

/// Parses a whole number from 0 to `u64::MAX` (`--seed`).
pub fn parse_u64(s: &str) -> Result<u64, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number from 0 to {}", u64::MAX))
}

/// Parses a duration such as `90s`, `10m`, `1h30m`, `2.5h`, `1d`, `500ms`; a bare number is
/// seconds.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let t = s.trim();
    if t.is_empty() {
        return Err("empty duration; expected e.g. 90s, 10m or 1h30m".into());
    }
    if t.starts_with('-') {
        return Err(format!(
            "'{s}': a duration must be ≥ 0 (e.g. 90s, 10m or 1h30m)"
        ));
    }
    if let Ok(x) = t.parse::<f64>() {
        return Duration::try_from_secs_f64(x)
            .map_err(|_| format!("'{s}': a duration must be finite and ≥ 0"));
    }
    let mut total = 0.0f64;
    let mut rest = t;
    while !rest.is_empty() {
        let num_len = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(rest.len());
        if num_len == 0 {
            return Err(format!(
                "'{s}': expected a number before '{rest}' (e.g. 90s, 10m, 1h30m)"
            ));
        }
        let x: f64 = rest[..num_len]
            .parse()
            .map_err(|_| format!("'{s}': '{}' is not a number", &rest[..num_len]))?;
        rest = rest[num_len..].trim_start();
        let unit_len = rest
            .find(|c: char| !c.is_ascii_alphabetic())
            .unwrap_or(rest.len());
        let unit = match &rest[..unit_len] {
            "ms" => 1e-3,
            "s" | "sec" | "secs" => 1.0,
            "m" | "min" | "mins" => 60.0,
            "h" | "hr" | "hrs" => 3600.0,
            "d" => 86400.0,
            "" => {
                return Err(format!(
                    "'{s}': a unit must follow '{x}' (ms, s, m, h or d)"
                ));
            }
            u => return Err(format!("'{s}': unknown unit '{u}' (ms, s, m, h or d)")),
        };
        total += x * unit;
        rest = rest[unit_len..].trim_start();
    }
    Duration::try_from_secs_f64(total).map_err(|_| format!("'{s}': duration out of range"))
}

/// Parses `--volume N` or `--volume NX,NY,NZ`.
pub fn parse_volume(s: &str) -> Result<crate::domain::VolumeRes, String> {
    s.parse()
}
