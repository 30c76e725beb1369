//! The main run's arguments turned into a validated [`Job`] (ripgrep's habit: raw arguments, then
//! a job the library runs), and the main run itself.

use super::args::{RunArgs, WeightArg};
use super::report::shell_quote;
use crate::analysis::separatrix::SepParams;
use crate::app::{self, CameraArg, DomainArg, Job};
use crate::domain::slice::SliceArg;
use crate::render::{RenderOptions, StopReason};
use std::path::PathBuf;

/// The main run: the job of `args`, with the signal handler installed, to its outputs. Returns
/// why the last domain's run stopped.
pub fn run(args: &RunArgs) -> anyhow::Result<Option<StopReason>> {
    let job = args.job()?;
    super::signals::install_signal_handler();
    let outcomes = app::run_job(&job)?;
    if crate::render::INTERRUPT.load(std::sync::atomic::Ordering::SeqCst) {
        return Ok(Some(StopReason::Interrupted));
    }
    Ok(outcomes.last().map(|o| o.stats.stop))
}

impl RunArgs {
    /// The job these arguments ask for, checked as far as it can be without loading the scene.
    pub fn job(&self) -> anyhow::Result<Job> {
        self.check_box()?;
        let scene = self.scene()?;
        let stem = scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let (domain, default_out, default_weight) = self.domain(&stem)?;
        let weight = self.weight.unwrap_or(default_weight);
        check_weight(&domain, weight)?;
        self.check_adaptive_cap()?;
        self.check_gradient_alpha()?;
        Ok(Job {
            scene,
            domain,
            lights: self.estimator.lights(),
            estimator: self.estimator.args(weight.into()),
            render: self.render(),
            output: self
                .output
                .clone()
                .or_else(|| self.resume.clone())
                .unwrap_or_else(|| {
                    PathBuf::from("out").join(with_tile_suffix(default_out, self.tile))
                }),
            png: !self.no_png,
            quiet: self.quiet,
            flatland: self.flatland,
            checkpoint_every: self.checkpoint_every,
            resume: self.resume.clone(),
            command: Some(command_without_resume()),
            separatrices: self.separatrices()?,
            load: crate::scene::load::LoadOptions {
                strict: self.strict,
                allow_outside_uris: self.allow_outside_uris,
                light_scale: self.estimator.light_scale.clone(),
                ..Default::default()
            },
        })
    }

    pub fn scene(&self) -> anyhow::Result<PathBuf> {
        self.scene
            .clone()
            .ok_or_else(|| anyhow::anyhow!("--scene FILE is required (try --help)"))
    }

    /// --box bounds a volume; a slice takes --window.
    fn check_box(&self) -> anyhow::Result<()> {
        if let Some(b) = self.bbox
            && self.volume.is_none()
        {
            anyhow::bail!(
                "--box {}: a box bounds a volume; add --volume N (slices take --window)",
                b.map(|x| x.to_string()).join(",")
            );
        }
        Ok(())
    }

    /// The domain, its default output name (from the scene's `stem`) and its default weighting:
    /// a volume, a camera image, or the slices.
    fn domain(&self, stem: &str) -> anyhow::Result<(DomainArg, String, WeightArg)> {
        if let Some(res) = self.volume {
            let volume = DomainArg::Volume {
                res,
                bbox: self.bbox,
            };
            return Ok((volume, format!("{stem}_volume.vti"), WeightArg::Radiance));
        }
        if let Some(camera) = self.camera_arg() {
            let camera = DomainArg::Camera {
                camera,
                size: self.size.unwrap_or(app::DEFAULT_IMAGE_SIZE),
            };
            return Ok((camera, format!("{stem}_camera.exr"), WeightArg::Importance));
        }
        let slices = self.slice_args();
        let out = match slices.as_slice() {
            [] => anyhow::bail!(
                "--slice AXIS=VALUE (e.g. --slice z=0), --slices, --plane or --camera is required"
            ),
            [one] => format!("{stem}_{}.exr", one.file_label(0)),
            _ => format!("{stem}.exr"),
        };
        let slices = DomainArg::Slice {
            slices,
            window: self.window,
            res: self.res,
        };
        Ok((slices, out, WeightArg::Radiance))
    }

    /// The camera: --eye/--target, else a camera of the scene by --camera.
    fn camera_arg(&self) -> Option<CameraArg> {
        match (&self.camera, self.eye, self.target) {
            (_, Some(eye), Some(target)) => Some(CameraArg::Explicit {
                eye,
                target,
                up: self.up.unwrap_or(app::DEFAULT_UP),
                fov_deg: self.fov,
            }),
            (Some(name), _, _) => Some(CameraArg::Scene((!name.is_empty()).then(|| name.clone()))),
            _ => None,
        }
    }

    /// Every --slice, then every slice of each --slices, then every --plane.
    fn slice_args(&self) -> Vec<SliceArg> {
        let mut slices: Vec<SliceArg> = self.slice.iter().cloned().map(SliceArg::Axis).collect();
        slices.extend(
            self.slices
                .iter()
                .flat_map(|r| &r.0)
                .map(|s| SliceArg::Axis(s.to_string())),
        );
        slices.extend(self.plane.iter().copied().map(SliceArg::Plane));
        slices
    }

    /// --adaptive-cap on a run that is not adaptive is refused rather than ignored.
    fn check_adaptive_cap(&self) -> anyhow::Result<()> {
        if self.adaptive_cap.is_some() && !self.sampling().is_adaptive() {
            anyhow::bail!(
                "--adaptive-cap applies to adaptive runs: add --adaptive (runs of --spp or --time \
                 alone are uniform)"
            );
        }
        Ok(())
    }

    /// --gradient-alpha weighs each cell's own estimate in the reconstruction: a number > 0 (at
    /// 0 a grid's moments are known only up to a constant).
    fn check_gradient_alpha(&self) -> anyhow::Result<()> {
        match self.gradient_alpha {
            Some(a) if !(a.is_finite() && a > 0.0) => {
                anyhow::bail!("--gradient-alpha {a}: give a number > 0 (default 0.2)")
            }
            _ => Ok(()),
        }
    }

    fn separatrices(&self) -> anyhow::Result<Option<SepParams>> {
        if !self.separatrices {
            if self.sep.given() {
                anyhow::bail!("--sep-scale, --sep-threshold and --sep-tau need --separatrices");
            }
            return Ok(None);
        }
        self.sep.params().map(Some)
    }

    /// What the sampling flags ask for: --spp, --time and --target-error (none of them: the
    /// default budget, [`app::DEFAULT_BUDGET`]), --adaptive or --uniform (neither: adaptive when
    /// the run stops at a target error, [`app::Sampling::is_adaptive`]), and the rest as given.
    fn sampling(&self) -> app::Sampling {
        app::Sampling {
            spp: self.spp,
            batches: self.batches,
            pass_spp: self.pass_spp,
            time: self.time,
            target_error: self.target_error,
            adaptive: if self.adaptive {
                Some(true)
            } else if self.uniform {
                Some(false)
            } else {
                None
            },
            adaptive_cap: self.adaptive_cap,
            gradient_domain: self.gradient_domain.then(|| {
                self.gradient_alpha
                    .unwrap_or(crate::gradient_domain::DEFAULT_ALPHA)
            }),
            seed: self.seed,
            threads: self.threads,
            tile: self.tile,
            progress: !self.quiet,
        }
    }

    fn render(&self) -> RenderOptions {
        self.sampling().render_options()
    }
}

/// `name_tile3of16.ext` for a tile's run, else `name.ext`.
fn with_tile_suffix(name: String, tile: Option<crate::domain::Tile>) -> String {
    match (tile, name.rsplit_once('.')) {
        (Some(t), Some((stem, ext))) => format!("{stem}{}.{ext}", t.suffix()),
        _ => name,
    }
}

/// Camera images are importance-weighted, and only they.
fn check_weight(domain: &DomainArg, weight: WeightArg) -> anyhow::Result<()> {
    let camera_run = matches!(domain, DomainArg::Camera { .. });
    if camera_run == matches!(weight, WeightArg::Importance) {
        return Ok(());
    }
    anyhow::bail!(match domain {
        DomainArg::Camera { .. } => {
            "--weight: camera images are importance-weighted (pairs start along the pixel rays)"
        }
        DomainArg::Volume { .. } => {
            "--weight importance needs a camera; volumes take radiance or unweighted"
        }
        DomainArg::Slice { .. } => {
            "--weight importance needs a camera: give --camera [NAME] or --eye/--target"
        }
    })
}

/// This process's command line without `--resume FILE`, quoted for a shell.
fn command_without_resume() -> String {
    let mut out = Vec::new();
    let mut args = std::env::args();
    if let Some(a0) = args.next() {
        out.push(shell_quote(&a0));
    }
    while let Some(a) = args.next() {
        if a == "--resume" {
            args.next();
        } else if !a.starts_with("--resume=") {
            out.push(shell_quote(&a));
        }
    }
    out.join(" ")
}
