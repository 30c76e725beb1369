//! The attributes as files store them: [`RunInfo::to_attributes`] and the number formats it uses.

use super::RunInfo;
use super::values::{fmt_parts, join};
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

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

impl RunInfo {
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
        put("light_scale", text(&self.light_scale));
        put("flatland", Some(self.flatland.to_string()));
        if let Some(g) = &self.gradient {
            put("gradient.alpha", Some(g.alpha.to_string()));
            put("gradient.replicates", Some(g.replicates.to_string()));
        }
        put("kernel", text(&self.kernel));
        put("pairs", text(&self.pairs));
        put("guide", text(&self.guide));
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
}
