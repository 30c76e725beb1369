//! Run metadata as one typed value: [`RunInfo`] says what a field's samples estimate (scene,
//! domain, estimator parameters), how they were drawn (seed, passes, tile), how far the run got
//! and, for a merged file, which parts it holds. Runs build it, writers store it, and merge and
//! resume read it back and compare it field by field.
//!
//! In files it is a flat list of text attributes (EXR header attributes `ftpd3d.<key>`, VTI
//! comments `<!-- ftpd3d key=value -->`); [`RunInfo::to_attributes`] and
//! [`RunInfo::from_attributes`] are the only code that knows their names and formats, which are
//! those of every earlier version, so old files still read. [`crate::field::Field::meta`] holds
//! the attributes as written (attributes of other versions survive a round trip in
//! [`RunInfo::extra`]).
//!
//! | attribute | field | format |
//! |---|---|---|
//! | `tool`, `embree` | versions | `ftpd3d 0.1.0`, `3.13.5` |
//! | `scene` | scene path | as given |
//! | `domain` | [`DomainKind`] | `slice`, `camera`, `volume` |
//! | `plane`, `plane.origin`, `plane.u`, `plane.v`, `plane.size` | [`PlaneInfo`] | label, `x,y,z` ×3, `w,h` |
//! | `camera`, `camera.eye`, `camera.forward`, `camera.up`, `camera.fov_y_deg` | [`CameraInfo`] | name, `x,y,z` ×3, degrees |
//! | `volume.box`, `volume.dims`, `volume.spacing` | [`VolumeInfo`] | 6 numbers, `nx,ny,nz`, `x,y,z` |
//! | `weighting` | [`Weighting`] | `radiance`, `unweighted`, `importance` |
//! | `t0`, `t1` | run lengths | `{:e}` (`1.5e0`) |
//! | `angle_deg`, `max_bounces` | cone half-angle, bounce cap | decimal |
//! | `radiance_bounces` | bounce cap of radiance paths (absent: `max_bounces`, as before it was written) | decimal |
//! | `features`, `kernel` | feature set, kernel | text |
//! | `point_lights` | command-line point lights | `x,y,z:r,g,b;…` |
//! | `sun` | command-line suns | `x,y,z:r,g,b:diameter;…` |
//! | `sky` | command-line sky or environment map | `r,g,b` or `file:scale:rotation` |
//! | `flatland` | 2D transport | `true`/`false` (absent: false) |
//! | `seed`, `seeds` | seed; a merge's distinct seeds | integer; `1,2,3` |
//! | `tile` | tiles ([`Tile`]) | `i/N`; a partial merge lists several, `0/4,1/4` |
//! | `parts`, `merged` | a merge's parts ([`Part`]) and inputs | `seed@r0-r1;…`; `a.exr;b.exr` |
//! | `spp`, `batches` | [`CellCount`] | `64`, `none`; a merge's `8-16` |
//! | `schedule`, `adaptive`, `budget.time`, `budget.target_error` | how passes were cut, budgets | text |
//! | `partial`, `pass.inflight` | progress flags | `true`/`false` |
//! | `passes`, `samples`, `elapsed` | progress | integers; seconds |
//! | `remaining.samples`, `remaining.time` | what is left of the budgets | [`Remaining`]; duration or `none` |
//! | `stop` | why the run stopped | text |
//!
//! Merged files of earlier versions may hold `a; b` lists where their inputs differed: the text
//! fields keep them as they are, and the progress totals read them as the merge now combines them
//! (sums; any `true`).

use crate::domain::Tile;
use crate::ftpd::Weighting;
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;
use std::time::Duration;

/// An attribute that does not read as what it should be, naming the attribute and the file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InfoError {
    #[error("{file}: attribute '{key}' = '{value}' is not {expected}")]
    Malformed {
        file: String,
        key: &'static str,
        value: String,
        expected: &'static str,
    },
    #[error("{file}: attribute '{key}' is missing, while '{with}' is there")]
    Missing {
        file: String,
        key: &'static str,
        with: &'static str,
    },
}

/// Which kind of domain a field covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DomainKind {
    Slice,
    Camera,
    Volume,
}

impl fmt::Display for DomainKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DomainKind::Slice => "slice",
            DomainKind::Camera => "camera",
            DomainKind::Volume => "volume",
        })
    }
}

/// A slice's rectangle: label, corner at u = v = 0, in-plane axes, size.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneInfo {
    pub label: String,
    pub origin: DVec3,
    pub u: DVec3,
    pub v: DVec3,
    pub size: (f64, f64),
}

/// A camera image's camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraInfo {
    pub name: String,
    pub eye: DVec3,
    pub forward: DVec3,
    pub up: DVec3,
    pub fov_y_deg: f64,
}

/// A volume's box and grid.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeInfo {
    pub min: DVec3,
    pub max: DVec3,
    pub dims: [usize; 3],
    pub spacing: DVec3,
}

/// Samples (or batches) per cell: a cap, no cap, or the range a merged field holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellCount {
    /// `none`: no sample cap (time or error budget only).
    Uncapped,
    Each(u64),
    /// `lo-hi`: cells differ (a merged field).
    Range(u64, u64),
}

impl CellCount {
    /// `lo` alone when `lo == hi`.
    pub fn range(lo: u64, hi: u64) -> CellCount {
        if lo == hi {
            CellCount::Each(lo)
        } else {
            CellCount::Range(lo, hi)
        }
    }
}

impl fmt::Display for CellCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CellCount::Uncapped => f.write_str("none"),
            CellCount::Each(n) => write!(f, "{n}"),
            CellCount::Range(lo, hi) => write!(f, "{lo}-{hi}"),
        }
    }
}

impl FromStr for CellCount {
    type Err = ();
    fn from_str(s: &str) -> Result<Self, ()> {
        if s == "none" {
            return Ok(CellCount::Uncapped);
        }
        match s.split_once('-') {
            Some((a, b)) => Ok(CellCount::Range(
                a.parse().map_err(|_| ())?,
                b.parse().map_err(|_| ())?,
            )),
            None => s.parse().map(CellCount::Each).map_err(|_| ()),
        }
    }
}

/// Samples still to take before the sample cap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Remaining {
    Samples(u64),
    /// No sample cap.
    Unbounded,
}

impl fmt::Display for Remaining {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Remaining::Samples(n) => write!(f, "{n}"),
            Remaining::Unbounded => f.write_str("unbounded"),
        }
    }
}

/// One seed over a range of grid rows (a 2D grid's rows from the bottom, a volume's z layers).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Part {
    pub seed: u64,
    pub rows: Range<usize>,
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}@{}-{}", self.seed, self.rows.start, self.rows.end)
    }
}

impl FromStr for Part {
    type Err = String;
    fn from_str(s: &str) -> Result<Part, String> {
        let bad = || format!("'{s}' is not SEED@ROW0-ROW1");
        let (seed, rows) = s.trim().split_once('@').ok_or_else(bad)?;
        let (r0, r1) = rows.split_once('-').ok_or_else(bad)?;
        let n = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
        Ok(Part {
            seed: seed.trim().parse().map_err(|_| bad())?,
            rows: n(r0)?..n(r1)?,
        })
    }
}

/// `seed@r0-r1;…`.
pub fn fmt_parts(parts: &[Part]) -> String {
    join(parts, ";")
}

/// The description of a run (or of a merge of runs) a field carries. `None` (empty, `false`) for
/// what the file does not say.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunInfo {
    /// `ftpd3d <version>` of the writer.
    pub tool: Option<String>,
    /// The Embree version the writer was built against.
    pub embree: Option<String>,
    /// The scene file, as given.
    pub scene: Option<String>,
    pub domain: Option<DomainKind>,
    pub plane: Option<PlaneInfo>,
    pub camera: Option<CameraInfo>,
    pub volume: Option<VolumeInfo>,
    pub weighting: Option<Weighting>,
    pub t0: Option<f64>,
    pub t1: Option<f64>,
    pub angle_deg: Option<f64>,
    pub max_bounces: Option<u32>,
    /// The radiance paths' cap ([`crate::ftpd::Params::radiance_cap`]); files written before it
    /// was recorded have none, and capped radiance paths at `max_bounces`
    /// ([`RunInfo::radiance_cap`]).
    pub radiance_bounces: Option<u32>,
    /// The scene's feature set, as `--explain` prints it.
    pub features: Option<String>,
    /// Command-line point lights: position, radiant intensity.
    pub point_lights: Vec<(DVec3, DVec3)>,
    /// Command-line suns, as `--sun` takes them (`;`-separated).
    pub sun: Option<String>,
    /// Command-line sky or environment map, as `--sky` and `--env` take them.
    pub sky: Option<String>,
    /// Directions confined to the slice plane.
    pub flatland: bool,
    pub kernel: Option<String>,
    pub seed: Option<u64>,
    /// The distinct seeds of a merged field.
    pub seeds: Vec<u64>,
    /// The tile of a tile's run; the tiles of a merge that does not cover the grid.
    pub tiles: Vec<Tile>,
    /// What a merged field holds (absent: its seed over its tile's rows).
    pub parts: Option<Vec<Part>>,
    /// The input names of a merge.
    pub merged: Vec<String>,
    pub spp: Option<CellCount>,
    pub batches: Option<CellCount>,
    pub schedule: Option<String>,
    /// `off` or `max Kx`.
    pub adaptive: Option<String>,
    pub budget_time: Option<String>,
    pub budget_target_error: Option<String>,
    pub partial: Option<bool>,
    pub passes: Option<u32>,
    pub samples: Option<u64>,
    /// Compute seconds so far.
    pub elapsed: Option<f64>,
    pub remaining_samples: Option<Remaining>,
    pub remaining_time: Option<String>,
    pub inflight: Option<bool>,
    pub stop: Option<String>,
    /// Attributes this version does not know, kept as they are.
    pub extra: BTreeMap<String, String>,
}

/// The attributes [`RunInfo`] reads; everything else goes to [`RunInfo::extra`].
const KNOWN: &[&str] = &[
    "tool",
    "embree",
    "scene",
    "domain",
    "plane",
    "plane.origin",
    "plane.u",
    "plane.v",
    "plane.size",
    "camera",
    "camera.eye",
    "camera.forward",
    "camera.up",
    "camera.fov_y_deg",
    "volume.box",
    "volume.dims",
    "volume.spacing",
    "weighting",
    "t0",
    "t1",
    "angle_deg",
    "max_bounces",
    "radiance_bounces",
    "features",
    "point_lights",
    "sun",
    "sky",
    "flatland",
    "kernel",
    "seed",
    "seeds",
    "tile",
    "parts",
    "merged",
    "spp",
    "batches",
    "schedule",
    "adaptive",
    "budget.time",
    "budget.target_error",
    "partial",
    "passes",
    "samples",
    "elapsed",
    "remaining.samples",
    "remaining.time",
    "pass.inflight",
    "stop",
];

/// What the samples estimate: merged fields must agree on every one of these attributes, and so
/// must a resumed run with its file (which checks [`RESUME_KEYS`] as well). In the order they are
/// checked; see [`RunInfo::first_difference`].
pub const ESTIMATE_KEYS: &[&str] = &[
    "scene",
    "domain",
    "plane",
    "plane.origin",
    "plane.u",
    "plane.v",
    "plane.size",
    "camera",
    "camera.eye",
    "camera.forward",
    "camera.up",
    "camera.fov_y_deg",
    "weighting",
    "t0",
    "t1",
    "angle_deg",
    "max_bounces",
    "radiance_bounces",
    "features",
    "point_lights",
    "sun",
    "sky",
    "volume.box",
    "flatland",
];

/// What a resumed run must share with its file beyond [`ESTIMATE_KEYS`]: which random streams,
/// pass sizes, kernel and tile produced the samples (a tile resumed as a whole grid would give
/// its other cells only the later passes). Budgets may change between invocations.
pub const RESUME_KEYS: &[&str] = &["seed", "schedule", "adaptive", "kernel", "tile"];

fn join<T: fmt::Display>(v: &[T], sep: &str) -> String {
    v.iter().map(T::to_string).collect::<Vec<_>>().join(sep)
}

/// `x,y,z`, each the shortest decimal that reads back as the same f64.
pub fn fmt_vec(v: DVec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

/// `1h02m03s`, `4m05s`, `12.3s`: a duration as run metadata (`budget.time`, `remaining.time`)
/// and reports write it, in the form the command line's duration parser reads back.
pub fn fmt_duration(d: Duration) -> String {
    let secs = d.as_secs_f64();
    if secs < 60.0 {
        return format!("{}s", (secs * 1000.0).round() / 1000.0);
    }
    let s = d.as_secs();
    let (h, m, sec) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 {
        format!("{h}h{m:02}m{sec:02}s")
    } else {
        format!("{m}m{sec:02}s")
    }
}

fn shown<T: fmt::Display>(v: &Option<T>) -> Option<String> {
    v.as_ref().map(T::to_string)
}

fn floats<const N: usize>(s: &str) -> Option<[f64; N]> {
    crate::math::parse_floats::<N>(s, "").ok()
}

fn vec3(s: &str) -> Option<DVec3> {
    floats::<3>(s).map(DVec3::from)
}

fn boolean(s: &str) -> Option<bool> {
    match s {
        "true" => Some(true),
        "false" => Some(false),
        _ => None,
    }
}

/// The values of an attribute that an earlier merge joined with `; ` where its inputs differed.
fn joined(s: &str) -> impl Iterator<Item = &str> {
    s.split(';').map(str::trim)
}

/// Reads attributes of one file, each at most once, with errors naming the attribute and file.
struct Reader<'a> {
    map: &'a BTreeMap<String, String>,
    file: &'a str,
}

impl Reader<'_> {
    fn text(&self, key: &str) -> Option<String> {
        self.map.get(key).cloned()
    }

    fn get<T>(
        &self,
        key: &'static str,
        expected: &'static str,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<Option<T>, InfoError> {
        match self.map.get(key) {
            None => Ok(None),
            Some(v) => parse(v).map(Some).ok_or_else(|| InfoError::Malformed {
                file: self.file.to_string(),
                key,
                value: v.clone(),
                expected,
            }),
        }
    }

    /// An attribute of a group that `with` (present) opened.
    fn need<T>(
        &self,
        key: &'static str,
        with: &'static str,
        expected: &'static str,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<T, InfoError> {
        self.get(key, expected, parse)?
            .ok_or_else(|| InfoError::Missing {
                file: self.file.to_string(),
                key,
                with,
            })
    }
}

impl RunInfo {
    /// Reads the attributes of `file` (a name for messages).
    pub fn from_attributes(
        map: &BTreeMap<String, String>,
        file: &str,
    ) -> Result<RunInfo, InfoError> {
        let r = Reader { map, file };
        let plane = match r.text("plane") {
            None => None,
            Some(label) => Some(PlaneInfo {
                label,
                origin: r.need("plane.origin", "plane", "x,y,z", vec3)?,
                u: r.need("plane.u", "plane", "x,y,z", vec3)?,
                v: r.need("plane.v", "plane", "x,y,z", vec3)?,
                size: r.need("plane.size", "plane", "w,h", |s| {
                    floats::<2>(s).map(|[w, h]| (w, h))
                })?,
            }),
        };
        let camera = match r.text("camera") {
            None => None,
            Some(name) => Some(CameraInfo {
                name,
                eye: r.need("camera.eye", "camera", "x,y,z", vec3)?,
                forward: r.need("camera.forward", "camera", "x,y,z", vec3)?,
                up: r.need("camera.up", "camera", "x,y,z", vec3)?,
                fov_y_deg: r.need("camera.fov_y_deg", "camera", "a number", |s| s.parse().ok())?,
            }),
        };
        let volume = match r.get("volume.box", "xmin,ymin,zmin,xmax,ymax,zmax", floats::<6>)? {
            None => None,
            Some(b) => Some(VolumeInfo {
                min: DVec3::new(b[0], b[1], b[2]),
                max: DVec3::new(b[3], b[4], b[5]),
                dims: r.need("volume.dims", "volume.box", "nx,ny,nz", |s| {
                    let v: Vec<usize> = s
                        .split(',')
                        .map(|t| t.trim().parse().ok())
                        .collect::<Option<_>>()?;
                    v.try_into().ok()
                })?,
                spacing: r.need("volume.spacing", "volume.box", "x,y,z", vec3)?,
            }),
        };
        let number = |s: &str| s.parse::<f64>().ok();
        Ok(RunInfo {
            tool: r.text("tool"),
            embree: r.text("embree"),
            scene: r.text("scene"),
            domain: r.get("domain", "slice, camera or volume", |s| match s {
                "slice" => Some(DomainKind::Slice),
                "camera" => Some(DomainKind::Camera),
                "volume" => Some(DomainKind::Volume),
                _ => None,
            })?,
            plane,
            camera,
            volume,
            weighting: r.get("weighting", "radiance, unweighted or importance", |s| {
                [
                    Weighting::Radiance,
                    Weighting::Unweighted,
                    Weighting::Importance,
                ]
                .into_iter()
                .find(|w| w.to_string() == s)
            })?,
            t0: r.get("t0", "a number", number)?,
            t1: r.get("t1", "a number", number)?,
            angle_deg: r.get("angle_deg", "a number", number)?,
            max_bounces: r.get("max_bounces", "a whole number", |s| s.parse().ok())?,
            radiance_bounces: r.get("radiance_bounces", "a whole number", |s| s.parse().ok())?,
            features: r.text("features"),
            point_lights: r
                .get("point_lights", "x,y,z:r,g,b;…", |s| {
                    s.split(';')
                        .map(|l| {
                            let (p, i) = l.split_once(':')?;
                            Some((vec3(p)?, vec3(i)?))
                        })
                        .collect::<Option<Vec<_>>>()
                })?
                .unwrap_or_default(),
            sun: r.text("sun"),
            sky: r.text("sky"),
            flatland: r
                .get("flatland", "true or false", boolean)?
                .unwrap_or(false),
            kernel: r.text("kernel"),
            seed: r.get("seed", "a whole number", |s| s.parse().ok())?,
            seeds: r
                .get("seeds", "whole numbers separated by commas", |s| {
                    s.split(',').map(|t| t.trim().parse().ok()).collect()
                })?
                .unwrap_or_default(),
            tiles: r
                .get("tile", "I/N (tiles separated by commas)", |s| {
                    s.split(',')
                        .map(|t| t.trim().parse::<Tile>().ok())
                        .collect()
                })?
                .unwrap_or_default(),
            parts: r.get("parts", "SEED@ROW0-ROW1 separated by ';'", |s| {
                s.split(';')
                    .filter(|t| !t.trim().is_empty())
                    .map(|t| t.parse::<Part>().ok())
                    .collect()
            })?,
            merged: r
                .text("merged")
                .map(|s| s.split(';').map(String::from).collect())
                .unwrap_or_default(),
            spp: r.get("spp", "N, LO-HI or none", |s| s.parse().ok())?,
            batches: r.get("batches", "N or LO-HI", |s| s.parse().ok())?,
            schedule: r.text("schedule"),
            adaptive: r.text("adaptive"),
            budget_time: r.text("budget.time"),
            budget_target_error: r.text("budget.target_error"),
            partial: r.get("partial", "true or false", |s| {
                joined(s).map(boolean).try_fold(false, |a, b| Some(a | b?))
            })?,
            passes: r
                .get("passes", "a whole number", |s| {
                    let v: Vec<u32> = joined(s).map(|t| t.parse().ok()).collect::<Option<_>>()?;
                    // Inputs of an earlier merge that differed: no one pass count describes it.
                    Some(v.iter().all(|&p| p == v[0]).then_some(v[0]))
                })?
                .flatten(),
            samples: r.get("samples", "a whole number", |s| {
                joined(s).map(|t| t.parse::<u64>().ok()).sum()
            })?,
            elapsed: r.get("elapsed", "a number of seconds", |s| {
                joined(s).map(|t| t.parse::<f64>().ok()).sum()
            })?,
            remaining_samples: r.get("remaining.samples", "a whole number or unbounded", |s| {
                joined(s).try_fold(Remaining::Samples(0), |acc, t| {
                    Some(match (acc, t) {
                        (_, "unbounded") | (Remaining::Unbounded, _) => Remaining::Unbounded,
                        (Remaining::Samples(a), t) => {
                            Remaining::Samples(a + t.parse::<u64>().ok()?)
                        }
                    })
                })
            })?,
            remaining_time: r.text("remaining.time"),
            inflight: r.get("pass.inflight", "true or false", |s| {
                joined(s).map(boolean).try_fold(false, |a, b| Some(a | b?))
            })?,
            stop: r.text("stop"),
            extra: map
                .iter()
                .filter(|(k, _)| !KNOWN.contains(&k.as_str()))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
        })
    }

    /// The attributes as files store them (see the module's table).
    pub fn to_attributes(&self) -> BTreeMap<String, String> {
        let mut m = self.extra.clone();
        let mut put = |k: &str, v: Option<String>| {
            if let Some(v) = v {
                m.insert(k.to_string(), v);
            }
        };
        let text = |v: &Option<String>| v.clone();
        put("tool", text(&self.tool));
        put("embree", text(&self.embree));
        put("scene", text(&self.scene));
        put("domain", self.domain.map(|d| d.to_string()));
        if let Some(p) = &self.plane {
            put("plane", Some(p.label.clone()));
            put("plane.origin", Some(fmt_vec(p.origin)));
            put("plane.u", Some(fmt_vec(p.u)));
            put("plane.v", Some(fmt_vec(p.v)));
            put("plane.size", Some(format!("{},{}", p.size.0, p.size.1)));
        }
        if let Some(c) = &self.camera {
            put("camera", Some(c.name.clone()));
            put("camera.eye", Some(fmt_vec(c.eye)));
            put("camera.forward", Some(fmt_vec(c.forward)));
            put("camera.up", Some(fmt_vec(c.up)));
            put("camera.fov_y_deg", Some(c.fov_y_deg.to_string()));
        }
        if let Some(v) = &self.volume {
            let (lo, hi) = (v.min, v.max);
            put(
                "volume.box",
                Some(format!(
                    "{},{},{},{},{},{}",
                    lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
                )),
            );
            put("volume.dims", Some(join(&v.dims, ",")));
            put("volume.spacing", Some(fmt_vec(v.spacing)));
        }
        put("weighting", self.weighting.map(|w| w.to_string()));
        put("t0", self.t0.map(|t| format!("{t:e}")));
        put("t1", self.t1.map(|t| format!("{t:e}")));
        put("angle_deg", shown(&self.angle_deg));
        put("max_bounces", shown(&self.max_bounces));
        put("radiance_bounces", shown(&self.radiance_bounces));
        put("features", text(&self.features));
        if !self.point_lights.is_empty() {
            let lights: Vec<String> = self
                .point_lights
                .iter()
                .map(|(p, i)| format!("{}:{}", fmt_vec(*p), fmt_vec(*i)))
                .collect();
            put("point_lights", Some(lights.join(";")));
        }
        put("sun", text(&self.sun));
        put("sky", text(&self.sky));
        put("flatland", Some(self.flatland.to_string()));
        put("kernel", text(&self.kernel));
        put("seed", shown(&self.seed));
        if !self.seeds.is_empty() {
            put("seeds", Some(join(&self.seeds, ",")));
        }
        if !self.tiles.is_empty() {
            put("tile", Some(join(&self.tiles, ",")));
        }
        put("parts", self.parts.as_deref().map(fmt_parts));
        if !self.merged.is_empty() {
            put("merged", Some(self.merged.join(";")));
        }
        put("spp", shown(&self.spp));
        put("batches", shown(&self.batches));
        put("schedule", text(&self.schedule));
        put("adaptive", text(&self.adaptive));
        put("budget.time", text(&self.budget_time));
        put("budget.target_error", text(&self.budget_target_error));
        put("partial", shown(&self.partial));
        put("passes", shown(&self.passes));
        put("samples", shown(&self.samples));
        put("elapsed", shown(&self.elapsed));
        put("remaining.samples", shown(&self.remaining_samples));
        put("remaining.time", text(&self.remaining_time));
        put("pass.inflight", shown(&self.inflight));
        put("stop", text(&self.stop));
        m
    }

    /// The radiance paths' cap: `radiance_bounces`, or for files written before it was recorded
    /// `max_bounces` (which then capped them).
    pub fn radiance_cap(&self) -> Option<u32> {
        self.radiance_bounces.or(self.max_bounces)
    }

    /// Whether passes from the third on were allocated adaptively (`adaptive` other than `off`).
    pub fn is_adaptive(&self) -> bool {
        self.adaptive.as_deref().is_some_and(|a| a != "off")
    }

    /// The first attribute of `keys` (from [`ESTIMATE_KEYS`] and [`RESUME_KEYS`]) on which `self`
    /// and `other` differ, compared as typed values (absent on both counts as agreeing).
    pub fn first_difference(&self, other: &RunInfo, keys: &[&str]) -> Option<&'static str> {
        let (a, b) = (self, other);
        fn by<T, U: PartialEq>(x: &Option<T>, y: &Option<T>, f: impl Fn(&T) -> U) -> bool {
            x.as_ref().map(&f) == y.as_ref().map(&f)
        }
        let same = |key: &str| -> bool {
            match key {
                "scene" => a.scene == b.scene,
                "domain" => a.domain == b.domain,
                "plane" => by(&a.plane, &b.plane, |p| p.label.clone()),
                "plane.origin" => by(&a.plane, &b.plane, |p| p.origin),
                "plane.u" => by(&a.plane, &b.plane, |p| p.u),
                "plane.v" => by(&a.plane, &b.plane, |p| p.v),
                "plane.size" => by(&a.plane, &b.plane, |p| p.size),
                "camera" => by(&a.camera, &b.camera, |c| c.name.clone()),
                "camera.eye" => by(&a.camera, &b.camera, |c| c.eye),
                "camera.forward" => by(&a.camera, &b.camera, |c| c.forward),
                "camera.up" => by(&a.camera, &b.camera, |c| c.up),
                "camera.fov_y_deg" => by(&a.camera, &b.camera, |c| c.fov_y_deg),
                "volume.box" => by(&a.volume, &b.volume, |v| (v.min, v.max)),
                "weighting" => a.weighting == b.weighting,
                "t0" => a.t0 == b.t0,
                "t1" => a.t1 == b.t1,
                "angle_deg" => a.angle_deg == b.angle_deg,
                "max_bounces" => a.max_bounces == b.max_bounces,
                "radiance_bounces" => a.radiance_cap() == b.radiance_cap(),
                "features" => a.features == b.features,
                "point_lights" => a.point_lights == b.point_lights,
                "sun" => a.sun == b.sun,
                "sky" => a.sky == b.sky,
                "flatland" => a.flatland == b.flatland,
                "seed" => a.seed == b.seed,
                "schedule" => a.schedule == b.schedule,
                "adaptive" => a.adaptive == b.adaptive,
                "kernel" => a.kernel == b.kernel,
                "tile" => a.tiles == b.tiles,
                other => panic!("RunInfo::first_difference: '{other}' is not a compared attribute"),
            }
        };
        keys.iter().find(|k| !same(k)).map(|k| {
            *KNOWN
                .iter()
                .find(|n| ***n == **k)
                .expect("compared keys are known")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attributes_round_trip_and_errors_name_the_attribute_and_file() {
        let mut m = BTreeMap::new();
        for (k, v) in [
            ("scene", "a.obj"),
            ("domain", "slice"),
            ("plane", "z=0"),
            ("plane.origin", "-1,-1,0"),
            ("plane.u", "1,0,0"),
            ("plane.v", "0,1,0"),
            ("plane.size", "2,2"),
            ("t0", "1.5e-1"),
            ("t1", "2e0"),
            ("weighting", "radiance"),
            ("point_lights", "-0.5,1.5,0:1,1,1"),
            ("tile", "0/4,1/4"),
            ("spp", "8-16"),
            ("parts", "1@0-4;2@0-2"),
            ("flatland", "false"),
            ("future.key", "kept"),
        ] {
            m.insert(k.to_string(), v.to_string());
        }
        let info = RunInfo::from_attributes(&m, "a.exr").unwrap();
        assert_eq!(info.t0, Some(0.15));
        assert_eq!(info.spp, Some(CellCount::Range(8, 16)));
        assert_eq!(info.tiles.len(), 2);
        assert_eq!(info.to_attributes(), m);
        // An earlier merge joined differing progress values: read as the merge now totals them.
        m.insert("elapsed".into(), "1.5; 2".into());
        m.insert("partial".into(), "false; true".into());
        m.insert("remaining.samples".into(), "0; 10".into());
        let info = RunInfo::from_attributes(&m, "a.exr").unwrap();
        assert_eq!(info.elapsed, Some(3.5));
        assert_eq!(info.partial, Some(true));
        assert_eq!(info.remaining_samples, Some(Remaining::Samples(10)));
        m.insert("t1".into(), "long".into());
        let e = RunInfo::from_attributes(&m, "a.exr").unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.exr: attribute 't1' = 'long' is not a number"
        );
        m.insert("t1".into(), "2e0".into());
        m.remove("plane.u");
        let e = RunInfo::from_attributes(&m, "a.exr").unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.exr: attribute 'plane.u' is missing, while 'plane' is there"
        );
    }
}
