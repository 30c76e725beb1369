//! `--explain`: the scene's contents and feature set, and the kernel and effects a run would use.

use crate::domain::slice::{SliceArg, resolve_plane};
use crate::math::Rgb;
use crate::run::{EstimatorArgs, prepare_flatland};
use crate::scene::Light;
use crate::scene::load::{LoadOptions, load_scene_with};
use std::io::Write;
use std::path::Path;

/// Writes the explanation of a run of `estimator` on the scene at `path` (with extra
/// `lights` from the command line) to `out`; `flatland` is the slice (with its window and resolution) of a
/// flatland run, whose cross-section it describes too; `options` say how the scene file is read.
/// Warnings of the loader go to stderr.
pub fn explain(
    out: &mut impl Write,
    path: &Path,
    lights: &[crate::scene::Light],
    estimator: &EstimatorArgs,
    flatland: Option<(&SliceArg, Option<[f64; 4]>, usize)>,
    options: &LoadOptions,
) -> anyhow::Result<()> {
    let mut scene = load_scene_with(path, lights, options)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    writeln!(out, "scene      {}", path.display())?;
    writeln!(
        out,
        "geometry   {} triangles ({} degenerate dropped), bounds {:?} .. {:?}, shading normals: {}",
        scene.triangles.len(),
        scene.report.degenerate_dropped,
        scene.bounds.min.to_array(),
        scene.bounds.max.to_array(),
        if !scene.has_shading_normals() {
            "no"
        } else {
            "yes"
        }
    )?;
    writeln!(out, "materials  {}", scene.materials.len())?;
    for m in &scene.materials {
        let emits = if m.emission == Rgb::ZERO {
            String::new()
        } else {
            format!(", emits {:?}", m.emission.to_array())
        };
        writeln!(out, "  {:<20} {:?}{emits}", m.name, m.bsdf)?;
    }
    let mut counts = [0usize; 5];
    for l in &scene.lights.lights {
        counts[match l {
            Light::Area { .. } => 0,
            Light::Point { .. } => 1,
            Light::Spot { .. } => 2,
            Light::Distant { .. } => 3,
            Light::Sky { .. } | Light::Env(_) => 4,
        }] += 1;
    }
    let mut kinds = format!(
        "{} emissive triangles, {} point lights",
        counts[0], counts[1]
    );
    for (n, what) in counts[2..]
        .iter()
        .zip(["spot lights", "suns", "skies and environment maps"])
    {
        if *n > 0 {
            kinds += &format!(", {n} {what}");
        }
    }
    writeln!(
        out,
        "lights     {kinds}, total power {:.4}",
        scene.lights.total_power()
    )?;
    writeln!(out, "cameras    {}", scene.cameras.len())?;
    if !scene.named_slices.is_empty() {
        let names: Vec<_> = scene
            .named_slices
            .iter()
            .map(|(n, p)| format!("{n} ({p})"))
            .collect();
        writeln!(out, "slices     {}", names.join(", "))?;
    }
    writeln!(out, "features   {}", scene.features)?;
    writeln!(out, "weighting  {}", estimator.weighting)?;
    let params = match flatland {
        Some((slice, window, res)) => {
            let plane = resolve_plane(slice, &scene, window, res);
            if let Ok(p) = &plane {
                writeln!(out, "flatland   in the slice {}", p.label)?;
            }
            plane
                .map_err(anyhow::Error::from)
                .and_then(|plane| prepare_flatland(&mut scene, &plane, estimator))
        }
        None => estimator.resolve(&scene).map_err(anyhow::Error::from),
    };
    if let Some(f) = &scene.flat {
        writeln!(
            out,
            "           {} light cross-sections, 2D power {:.4}",
            f.lights.lights.len(),
            f.lights.total_power()
        )?;
    }
    match params {
        Ok(params) => {
            writeln!(out, "kernel     {}", crate::ftpd::kernel_for(&params))?;
            let effects = crate::ftpd::effects::effects(&scene, &params);
            let on: Vec<&str> = effects
                .iter()
                .filter(|e| e.simulated)
                .map(|e| e.name)
                .collect();
            writeln!(out, "simulates  {}", on.join(" "))?;
            let mirrors = match &scene.flat {
                Some(f) if params.flat.is_some() => &f.mirrors,
                _ => &scene.mirrors,
            };
            if effects
                .iter()
                .any(|e| e.name == "mirror-images" && e.simulated)
            {
                writeln!(
                    out,
                    "           mirror images of the lights through {} planar mirror{} ({} triangles)",
                    mirrors.planes.len(),
                    if mirrors.planes.len() == 1 { "" } else { "s" },
                    mirrors.triangles
                )?;
            }
            for (i, e) in effects.iter().filter(|e| !e.simulated).enumerate() {
                let head = if i == 0 { "skips" } else { "" };
                writeln!(out, "{head:<10} {} ({})", e.name, e.why)?;
            }
        }
        Err(e) => writeln!(out, "kernel     (none: {})", super::errors::message(&e))?,
    }
    Ok(())
}
