//! `--explain`: the scene's contents and feature set, and the kernel and effects a run would use.

use super::args::RunArgs;
use crate::app::DomainArg;
use crate::domain::slice::{SliceArg, resolve_plane};
use crate::ftpd::Params;
use crate::math::Rgb;
use crate::params::{EstimatorArgs, prepare_flatland};
use crate::scene::load::{LoadOptions, load_scene_with};
use crate::scene::{Light, Scene};
use std::io::Write;
use std::path::Path;

/// `ftpd3d --explain`: the explanation of the run `args` describe (a slice z=0 when they give no
/// domain), on stdout, with the separatrix extraction's settings when it is asked for.
pub fn command(args: &RunArgs) -> anyhow::Result<()> {
    let mut a = args.clone();
    if a.camera.is_none() && a.eye.is_none() && a.slice.is_empty() && a.volume.is_none() {
        a.slice.push("z=0".into());
    }
    let job = a.job()?;
    let flatland = match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } if job.flatland => match slices.first() {
            Some(s) => Some((s, *window, *res)),
            None => anyhow::bail!("--flatland needs a slice"),
        },
        _ => None,
    };
    let mut out = std::io::stdout().lock();
    explain(
        &mut out,
        &job.scene,
        &job.lights,
        &job.estimator,
        flatland,
        &job.load,
    )?;
    if let Some(alpha) = job.render.gradient_domain {
        writeln!(
            out,
            "gradient   every sample traced again at the cell's upper neighbour along each axis \
             (the same random numbers, the start one cell over): {}× the paths per sample; the \
             field is reconstructed from cells and differences (screened Poisson, α {alpha})",
            if matches!(job.domain, DomainArg::Volume { .. }) {
                4
            } else {
                3
            }
        )?;
    }
    if let Some(sp) = &job.separatrices {
        let or_default =
            |v: Option<f64>, d: &str| v.map_or_else(|| d.to_string(), |x| x.to_string());
        writeln!(
            out,
            "separatrices  after the run: eq. 13 by derivative-of-Gaussian filters, scale {}, \
             τ {}, Z {} (Scheffé over directions); jump and ridge lines",
            sp.scale
                .map_or_else(|| "from the noise".to_string(), |s| format!("{s} cells")),
            or_default(sp.tau, "0.1 × median σ > 0"),
            sp.z
        )?;
    }
    Ok(())
}

/// Writes the explanation of a run of `estimator` on the scene at `path` (with extra
/// `lights` from the command line) to `out`; `flatland` is the slice (with its window and
/// resolution) of a flatland run, whose cross-section it describes too; `options` say how the scene
/// file is read. Warnings of the loader go to stderr.
pub fn explain(
    out: &mut impl Write,
    path: &Path,
    lights: &[Light],
    estimator: &EstimatorArgs,
    flatland: Option<(&SliceArg, Option<[f64; 4]>, usize)>,
    options: &LoadOptions,
) -> anyhow::Result<()> {
    let mut scene = load_scene_with(path, lights, options)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    write_contents(out, path, &scene)?;
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
            "           {} light cross-sections, 2D power {}",
            f.lights.lights.len(),
            crate::app::report::power(f.lights.total_power())
        )?;
    }
    match params {
        Ok(params) => write_kernel(out, &scene, &params),
        Err(e) => {
            writeln!(out, "kernel     (none: {})", super::errors::message(&e))?;
            Ok(())
        }
    }
}

/// What the scene holds: geometry, materials, lights, cameras, named slices, features.
fn write_contents(out: &mut impl Write, path: &Path, scene: &Scene) -> anyhow::Result<()> {
    writeln!(out, "scene      {}", path.display())?;
    writeln!(
        out,
        "geometry   {} triangles ({} degenerate dropped{}), bounds {:?} .. {:?}, shading normals: {}",
        scene.triangles.len(),
        scene.report.degenerate_dropped,
        crate::app::report::instancing_text(scene),
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
    writeln!(
        out,
        "lights     {}, total power {}",
        light_kinds(scene),
        crate::app::report::power(scene.lights.total_power())
    )?;
    if !scene.file_lights.is_empty() {
        let names: Vec<String> = scene
            .file_lights
            .iter()
            .map(|f| match f.scale {
                1.0 => format!("{} ({})", f.name, f.kind),
                0.0 => format!("{} ({}, off)", f.name, f.kind),
                k => format!("{} ({}, ×{k})", f.name, f.kind),
            })
            .collect();
        writeln!(
            out,
            "  by name  {} (--light-scale NAME=FACTOR)",
            names.join(", ")
        )?;
    }
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
    Ok(())
}

/// `3 emissive triangles, 1 point lights, 1 suns`: how many lights of each kind (the kinds after
/// point lights only when there are some).
fn light_kinds(scene: &Scene) -> String {
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
    kinds
}

/// The kernel of a run of `params`, the effects it simulates (with the mirror images of the
/// lights) and those it skips, with why.
fn write_kernel(out: &mut impl Write, scene: &Scene, params: &Params) -> anyhow::Result<()> {
    writeln!(out, "kernel     {}", crate::ftpd::kernel_for(params))?;
    let d = params.design;
    writeln!(
        out,
        "pairs      {d} per sample (--pairs): {} walks along the direction, {} cone directions \
         with {} walks each, {} run lengths: {} pairs from {} walks",
        d.along,
        d.cones,
        d.across,
        d.lengths,
        d.pairs(),
        d.walks()
    )?;
    let effects = crate::ftpd::effects::effects(scene, params);
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
    Ok(())
}
