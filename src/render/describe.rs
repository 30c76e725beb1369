//! The description of a run ([`RunInfo`]): what the driver ran, with which estimator settings,
//! budgets and kernel, over which domain; files store it as attributes (see [`crate::run_info`]).

use super::{RenderOptions, Schedule};
use crate::domain::volume::Volume;
use crate::domain::{CameraView, Plane};
use crate::ftpd::{self, Params};
use crate::run_info::{
    CameraInfo, CellCount, DomainKind, GradientInfo, PlaneInfo, RunInfo, VolumeInfo, fmt_duration,
};
use crate::scene::Scene;

/// The description of a run of `domain` (files store it as attributes, see [`crate::run_info`]);
/// the caller places it (plane, camera or volume) and adds what only it knows (command-line point
/// lights).
pub fn describe_run(
    scene: &Scene,
    params: &Params,
    opts: &RenderOptions,
    domain: DomainKind,
) -> RunInfo {
    RunInfo {
        tool: Some(format!("ftpd3d {}", env!("CARGO_PKG_VERSION"))),
        embree: Some(crate::embree_version().into()),
        scene: Some(scene.source.display().to_string()),
        domain: Some(domain),
        weighting: Some(params.weighting),
        t0: Some(params.t0),
        t1: Some(params.t1),
        angle_deg: Some(params.theta_max.to_degrees()),
        max_bounces: Some(params.max_bounces),
        radiance_bounces: Some(params.radiance_cap()),
        seed: Some(opts.seed),
        spp: Some(if opts.budget.cap_spp {
            CellCount::Each(opts.spp as u64)
        } else {
            CellCount::Uncapped
        }),
        batches: Some(CellCount::Each(opts.batches as u64)),
        schedule: Some(Schedule::of(opts).key()),
        adaptive: Some(match opts.adaptive {
            Some(a) => format!("max {}x", a.max_share),
            None => "off".into(),
        }),
        budget_time: Some(opts.budget.time.map_or_else(|| "none".into(), fmt_duration)),
        budget_target_error: Some(
            opts.budget
                .target_error
                .map_or_else(|| "none".into(), |t| t.to_string()),
        ),
        features: Some(scene.features.to_string()),
        flatland: params.flat.is_some(),
        gradient: opts.gradient_domain.map(|alpha| GradientInfo {
            alpha,
            replicates: crate::gradient_domain::REPLICATES,
        }),
        kernel: Some(ftpd::kernel_for(params).to_string()),
        pairs: Some(params.design.to_string()),
        guide: params.guide.then(|| "on".into()),
        tiles: opts.tile.into_iter().collect(),
        ..RunInfo::default()
    }
}

/// Where a slice lies, for its description.
pub fn plane_info(plane: &Plane) -> PlaneInfo {
    PlaneInfo {
        label: plane.label.clone(),
        origin: plane.origin,
        u: plane.u_axis,
        v: plane.v_axis,
        size: plane.size,
    }
}

/// Where a camera image is taken from, for its description.
pub fn camera_info(view: &CameraView) -> CameraInfo {
    let c = &view.camera;
    CameraInfo {
        name: c.name.clone(),
        eye: c.eye,
        forward: c.forward,
        up: c.up,
        fov_y_deg: c.fov_y.to_degrees(),
    }
}

/// Where a volume lies, for its description.
pub fn volume_info(volume: &Volume) -> VolumeInfo {
    VolumeInfo {
        min: volume.origin,
        max: volume.max_corner(),
        dims: volume.dims(),
        spacing: volume.spacing,
    }
}
