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
//! | `pairs` | deflection pairs per sample, kA,kB,J,M ([`crate::ftpd::Design`]; absent: written before designs, one pair per sample with another sample layout) | `2,2,1,2`; a merge of several: `1,1,1,1; 2,2,1,2` |
//! | `guide` | guided radiance paths ([`crate::transport::guide`]; absent: off) | `on` |
//! | `point_lights` | point lights added to the scene file's | `x,y,z:r,g,b;…` |
//! | `sun` | suns added to the scene file's | `x,y,z:r,g,b:diameter;…` |
//! | `sky` | sky or environment map added to the scene file's | `r,g,b` or `file:scale:rotation` |
//! | `light_scale` | the scene file's lights scaled or switched off (factor 0; absent: none) | `name=factor;…` |
//! | `flatland` | 2D transport | `true`/`false` (absent: false) |
//! | `gradient.alpha`, `gradient.replicates` | [`GradientInfo`]: a gradient-domain run ([`crate::gradient_domain`]; absent: an ordinary run) | a number > 0; `16` |
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

mod read;
mod values;
mod write;

pub use values::{
    CameraInfo, CellCount, DomainKind, GradientInfo, Part, PlaneInfo, Remaining, VolumeInfo,
    fmt_parts,
};
pub use write::{fmt_duration, fmt_vec};

use crate::domain::Tile;
use crate::ftpd::Weighting;
use glam::DVec3;
use std::collections::BTreeMap;

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
    /// The scene's feature set ([`crate::scene::Features`] as text).
    pub features: Option<String>,
    /// Point lights added to those of the scene file (by the caller): position, radiant
    /// intensity. Part of the scene: fields computed with other lights do not merge.
    pub point_lights: Vec<(DVec3, DVec3)>,
    /// Suns added to those of the scene file: direction, irradiance and angular diameter in
    /// degrees, `x,y,z:r,g,b:diameter`, `;`-separated.
    pub sun: Option<String>,
    /// A sky (`r,g,b`) or environment map (`file:scale:rotation in degrees`) added to the scene
    /// file's, `;`-separated.
    pub sky: Option<String>,
    /// The scene file's lights a run scaled (0: switched off), `name=factor` in the order the
    /// scene names them ([`crate::scene::dimmer`]), `;`-separated; `None` when it scaled none.
    pub light_scale: Option<String>,
    /// Directions confined to the slice plane.
    pub flatland: bool,
    /// A gradient-domain run: the field keeps its replayed neighbours' sums and is reconstructed
    /// from them (absent: an ordinary run).
    pub gradient: Option<GradientInfo>,
    pub kernel: Option<String>,
    /// The deflection pairs of a sample ([`crate::ftpd::Design`] as text); a merge of fields of
    /// different designs lists them.
    pub pairs: Option<String>,
    /// Guided radiance paths: `on` (absent: off); a merge of guided and unguided fields lists
    /// both.
    pub guide: Option<String>,
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
    "light_scale",
    "flatland",
    "gradient.alpha",
    "gradient.replicates",
    "kernel",
    "pairs",
    "guide",
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
    "light_scale",
    "volume.box",
    "flatland",
    "gradient.alpha",
    "gradient.replicates",
];

/// What a resumed run must share with its file beyond [`ESTIMATE_KEYS`]: which random streams,
/// pass sizes, kernel and tile produced the samples (a tile resumed as a whole grid would give
/// its other cells only the later passes). Budgets may change between invocations.
pub const RESUME_KEYS: &[&str] = &[
    "seed", "schedule", "adaptive", "kernel", "pairs", "guide", "tile",
];

impl RunInfo {
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
    /// and `other` differ, compared as typed values (absent on both counts as agreeing; an absent
    /// `pairs` agrees with any).
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
                "light_scale" => a.light_scale == b.light_scale,
                "flatland" => a.flatland == b.flatland,
                "gradient.alpha" => by(&a.gradient, &b.gradient, |g| g.alpha.to_bits()),
                "gradient.replicates" => by(&a.gradient, &b.gradient, |g| g.replicates),
                "seed" => a.seed == b.seed,
                "schedule" => a.schedule == b.schedule,
                "adaptive" => a.adaptive == b.adaptive,
                "kernel" => a.kernel == b.kernel,
                // Files written before designs have none; their samples are units of the same
                // expectations, so such a file resumes with any design (as it resumed with the
                // estimators that came after it).
                "pairs" => a.pairs.is_none() || b.pairs.is_none() || a.pairs == b.pairs,
                // A resumed guided run trains the same guide again (a function of the scene,
                // the parameters and the seed): it resumes only guided, and unguided only unguided.
                "guide" => {
                    a.guide.as_deref().unwrap_or("off") == b.guide.as_deref().unwrap_or("off")
                }
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
