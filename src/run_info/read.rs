//! Reading the attributes of a file back: [`RunInfo::from_attributes`], each attribute at most
//! once, its errors naming the attribute and the file.

use super::{
    CameraInfo, CellCount, DomainKind, GradientInfo, InfoError, KNOWN, Part, PlaneInfo, Remaining,
    RunInfo, VolumeInfo,
};
use crate::domain::Tile;
use crate::ftpd::Weighting;
use glam::DVec3;
use std::collections::BTreeMap;

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

/// What `gradient.replicates` must be: [`crate::gradient_domain::REPLICATES`].
const REPLICATES_TEXT: &str = "16 (the replicates of a gradient-domain run)";

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
    /// Reads the attributes of `file` (a name for messages). Where several are malformed, the
    /// error names the first in the order: domain placement, estimator, provenance, passes and
    /// budgets, progress.
    pub fn from_attributes(
        map: &BTreeMap<String, String>,
        file: &str,
    ) -> Result<RunInfo, InfoError> {
        let r = Reader { map, file };
        let plane = r.plane()?;
        let camera = r.camera()?;
        let volume = r.volume()?;
        let mut info = RunInfo {
            tool: r.text("tool"),
            embree: r.text("embree"),
            scene: r.text("scene"),
            domain: r.domain()?,
            plane,
            camera,
            volume,
            ..RunInfo::default()
        };
        r.estimator(&mut info)?;
        r.provenance(&mut info)?;
        r.passes(&mut info)?;
        r.progress(&mut info)?;
        info.extra = map
            .iter()
            .filter(|(k, _)| !KNOWN.contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        Ok(info)
    }
}

/// The groups of attributes [`RunInfo::from_attributes`] reads, in its order.
impl Reader<'_> {
    fn plane(&self) -> Result<Option<PlaneInfo>, InfoError> {
        let Some(label) = self.text("plane") else {
            return Ok(None);
        };
        Ok(Some(PlaneInfo {
            label,
            origin: self.need("plane.origin", "plane", "x,y,z", vec3)?,
            u: self.need("plane.u", "plane", "x,y,z", vec3)?,
            v: self.need("plane.v", "plane", "x,y,z", vec3)?,
            size: self.need("plane.size", "plane", "w,h", |s| {
                floats::<2>(s).map(|[w, h]| (w, h))
            })?,
        }))
    }

    fn camera(&self) -> Result<Option<CameraInfo>, InfoError> {
        let Some(name) = self.text("camera") else {
            return Ok(None);
        };
        Ok(Some(CameraInfo {
            name,
            eye: self.need("camera.eye", "camera", "x,y,z", vec3)?,
            forward: self.need("camera.forward", "camera", "x,y,z", vec3)?,
            up: self.need("camera.up", "camera", "x,y,z", vec3)?,
            fov_y_deg: self.need("camera.fov_y_deg", "camera", "a number", |s| s.parse().ok())?,
        }))
    }

    fn volume(&self) -> Result<Option<VolumeInfo>, InfoError> {
        let Some(b) = self.get("volume.box", "xmin,ymin,zmin,xmax,ymax,zmax", floats::<6>)? else {
            return Ok(None);
        };
        Ok(Some(VolumeInfo {
            min: DVec3::new(b[0], b[1], b[2]),
            max: DVec3::new(b[3], b[4], b[5]),
            dims: self.need("volume.dims", "volume.box", "nx,ny,nz", |s| {
                let v: Vec<usize> = s
                    .split(',')
                    .map(|t| t.trim().parse().ok())
                    .collect::<Option<_>>()?;
                v.try_into().ok()
            })?,
            spacing: self.need("volume.spacing", "volume.box", "x,y,z", vec3)?,
        }))
    }

    fn domain(&self) -> Result<Option<DomainKind>, InfoError> {
        self.get("domain", "slice, camera or volume", |s| match s {
            "slice" => Some(DomainKind::Slice),
            "camera" => Some(DomainKind::Camera),
            "volume" => Some(DomainKind::Volume),
            _ => None,
        })
    }

    /// What the samples estimate: weighting, run lengths, cone, bounce caps, the lights added to
    /// the scene, flatland, kernel.
    fn estimator(&self, info: &mut RunInfo) -> Result<(), InfoError> {
        let number = |s: &str| s.parse::<f64>().ok();
        info.weighting = self.get("weighting", "radiance, unweighted or importance", |s| {
            [
                Weighting::Radiance,
                Weighting::Unweighted,
                Weighting::Importance,
            ]
            .into_iter()
            .find(|w| w.to_string() == s)
        })?;
        info.t0 = self.get("t0", "a number", number)?;
        info.t1 = self.get("t1", "a number", number)?;
        info.angle_deg = self.get("angle_deg", "a number", number)?;
        info.max_bounces = self.get("max_bounces", "a whole number", |s| s.parse().ok())?;
        info.radiance_bounces =
            self.get("radiance_bounces", "a whole number", |s| s.parse().ok())?;
        info.features = self.text("features");
        info.point_lights = self
            .get("point_lights", "x,y,z:r,g,b;…", |s| {
                s.split(';')
                    .map(|l| {
                        let (p, i) = l.split_once(':')?;
                        Some((vec3(p)?, vec3(i)?))
                    })
                    .collect::<Option<Vec<_>>>()
            })?
            .unwrap_or_default();
        info.sun = self.text("sun");
        info.sky = self.text("sky");
        info.light_scale = self.text("light_scale");
        info.flatland = self
            .get("flatland", "true or false", boolean)?
            .unwrap_or(false);
        info.gradient = self.gradient()?;
        info.kernel = self.text("kernel");
        info.pairs = self.text("pairs");
        info.guide = self.text("guide");
        Ok(())
    }

    /// A gradient-domain run's α (finite, > 0) and replicates (those this version deals samples
    /// into: another count would give the replicates' sums another meaning).
    fn gradient(&self) -> Result<Option<GradientInfo>, InfoError> {
        let Some(alpha) = self.get("gradient.alpha", "a number > 0", |s| {
            s.parse::<f64>().ok().filter(|a| a.is_finite() && *a > 0.0)
        })?
        else {
            if self.map.contains_key("gradient.replicates") {
                return Err(InfoError::Missing {
                    file: self.file.to_string(),
                    key: "gradient.alpha",
                    with: "gradient.replicates",
                });
            }
            return Ok(None);
        };
        let replicates = self.need(
            "gradient.replicates",
            "gradient.alpha",
            REPLICATES_TEXT,
            |s| {
                s.parse()
                    .ok()
                    .filter(|&r| r == crate::gradient_domain::REPLICATES)
            },
        )?;
        Ok(Some(GradientInfo { alpha, replicates }))
    }

    /// Which streams and cells the samples come from: seed(s), tiles, a merge's parts and inputs.
    fn provenance(&self, info: &mut RunInfo) -> Result<(), InfoError> {
        info.seed = self.get("seed", "a whole number", |s| s.parse().ok())?;
        info.seeds = self
            .get("seeds", "whole numbers separated by commas", |s| {
                s.split(',').map(|t| t.trim().parse().ok()).collect()
            })?
            .unwrap_or_default();
        info.tiles = self
            .get("tile", "I/N (tiles separated by commas)", |s| {
                s.split(',')
                    .map(|t| t.trim().parse::<Tile>().ok())
                    .collect()
            })?
            .unwrap_or_default();
        info.parts = self.get("parts", "SEED@ROW0-ROW1 separated by ';'", |s| {
            s.split(';')
                .filter(|t| !t.trim().is_empty())
                .map(|t| t.parse::<Part>().ok())
                .collect()
        })?;
        info.merged = self
            .text("merged")
            .map(|s| s.split(';').map(String::from).collect())
            .unwrap_or_default();
        Ok(())
    }

    /// How the samples were cut into passes, and the budgets.
    fn passes(&self, info: &mut RunInfo) -> Result<(), InfoError> {
        info.spp = self.get("spp", "N, LO-HI or none", |s| s.parse::<CellCount>().ok())?;
        info.batches = self.get("batches", "N or LO-HI", |s| s.parse::<CellCount>().ok())?;
        info.schedule = self.text("schedule");
        info.adaptive = self.text("adaptive");
        info.budget_time = self.text("budget.time");
        info.budget_target_error = self.text("budget.target_error");
        Ok(())
    }

    /// Where the run stands. Merged files of earlier versions may join differing values with `;`:
    /// read as a merge now totals them (sums; any `true`).
    fn progress(&self, info: &mut RunInfo) -> Result<(), InfoError> {
        let any_true = |s: &str| joined(s).map(boolean).try_fold(false, |a, b| Some(a | b?));
        info.partial = self.get("partial", "true or false", any_true)?;
        info.passes = self
            .get("passes", "a whole number", |s| {
                let v: Vec<u32> = joined(s).map(|t| t.parse().ok()).collect::<Option<_>>()?;
                // Inputs of an earlier merge that differed: no one pass count describes it.
                Some(v.iter().all(|&p| p == v[0]).then_some(v[0]))
            })?
            .flatten();
        info.samples = self.get("samples", "a whole number", |s| {
            joined(s).map(|t| t.parse::<u64>().ok()).sum()
        })?;
        info.elapsed = self.get("elapsed", "a number of seconds", |s| {
            joined(s).map(|t| t.parse::<f64>().ok()).sum()
        })?;
        info.remaining_samples =
            self.get("remaining.samples", "a whole number or unbounded", |s| {
                joined(s).try_fold(Remaining::Samples(0), |acc, t| {
                    Some(match (acc, t) {
                        (_, "unbounded") | (Remaining::Unbounded, _) => Remaining::Unbounded,
                        (Remaining::Samples(a), t) => {
                            Remaining::Samples(a + t.parse::<u64>().ok()?)
                        }
                    })
                })
            })?;
        info.remaining_time = self.text("remaining.time");
        info.inflight = self.get("pass.inflight", "true or false", any_true)?;
        info.stop = self.text("stop");
        Ok(())
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
            ("gradient.alpha", "0.25"),
            ("gradient.replicates", "16"),
            ("future.key", "kept"),
        ] {
            m.insert(k.to_string(), v.to_string());
        }
        let info = RunInfo::from_attributes(&m, "a.exr").unwrap();
        assert_eq!(info.t0, Some(0.15));
        assert_eq!(info.spp, Some(CellCount::Range(8, 16)));
        assert_eq!(info.tiles.len(), 2);
        let g = info.gradient.unwrap();
        assert_eq!((g.alpha, g.replicates), (0.25, 16));
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
        // A gradient-domain run's α and replicates: another count is another layout of sums.
        for (key, value, expected) in [
            ("gradient.alpha", "0", "a number > 0"),
            ("gradient.alpha", "NaN", "a number > 0"),
            ("gradient.replicates", "8", REPLICATES_TEXT),
        ] {
            let mut bad = m.clone();
            bad.insert(key.into(), value.into());
            let e = RunInfo::from_attributes(&bad, "a.exr").unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("a.exr: attribute '{key}' = '{value}' is not {expected}")
            );
        }
        assert!(REPLICATES_TEXT.starts_with(&format!("{} ", crate::gradient_domain::REPLICATES)));
        let mut lone = m.clone();
        lone.remove("gradient.alpha");
        let e = RunInfo::from_attributes(&lone, "a.exr").unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.exr: attribute 'gradient.alpha' is missing, while 'gradient.replicates' is there"
        );
        m.remove("plane.u");
        let e = RunInfo::from_attributes(&m, "a.exr").unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.exr: attribute 'plane.u' is missing, while 'plane' is there"
        );
    }
}
