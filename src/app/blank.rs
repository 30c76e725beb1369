//! A finished run whose output shows nothing says so, in one line on stderr with the likely cause
//! and the flag that changes it: no valid cell (no sample carried weight: a slice inside a closed
//! object, or no light reaching the domain), or no deflected pair (run lengths too short to reach
//! any geometry).

use super::job::Job;
use super::resolve::JobDomain;
use super::run_domain::DomainRun;
use crate::ftpd::{Params, Weighting};
use crate::scene::Scene;
use glam::DVec3;

/// Probe directions of [`enclosed`]: the six axes and the eight diagonals.
fn probe_directions() -> impl Iterator<Item = DVec3> {
    let axes = [DVec3::X, DVec3::Y, DVec3::Z]
        .into_iter()
        .flat_map(|a| [a, -a]);
    let diagonals = (0..8).map(|k| {
        let s = |bit: usize| if k & bit == 0 { 1.0 } else { -1.0 };
        DVec3::new(s(1), s(2), s(4)).normalize()
    });
    axes.chain(diagonals)
}

/// Whether `p` lies inside a closed object: every probe ray from it meets a surface, and meets it
/// from behind (the side its winding does not face), as rays from inside a closed mesh with
/// outward faces do. (The inside of a room, whose walls face inwards, is not enclosed.)
pub fn enclosed(scene: &Scene, p: DVec3) -> bool {
    probe_directions().all(|d| {
        scene
            .intersect(p, d, f64::INFINITY)
            .is_some_and(|hit| hit.ng.dot(d) > 0.0)
    })
}

/// Points spread over the domain (a 5 × 5 grid over a plane, 3 × 3 × 3 over a volume's box, a
/// camera's eye) for [`enclosed`].
fn probe_points(domain: &JobDomain) -> Vec<DVec3> {
    let f = [0.1, 0.3, 0.5, 0.7, 0.9];
    match domain {
        JobDomain::Plane(p) => f
            .iter()
            .flat_map(|&a| {
                f.iter()
                    .map(move |&b| p.origin + p.u_axis * (a * p.size.0) + p.v_axis * (b * p.size.1))
            })
            .collect(),
        JobDomain::Volume(v) => {
            let (lo, hi) = (v.origin, v.max_corner());
            let g = [0.25, 0.5, 0.75];
            let mut out = Vec::new();
            for x in g {
                for y in g {
                    for z in g {
                        out.push(lo + (hi - lo) * DVec3::new(x, y, z));
                    }
                }
            }
            out
        }
        JobDomain::Camera(c) => vec![c.camera.eye],
    }
}

/// The one-line warning for a run whose output is blank, if it is: no valid cell among those it
/// sampled, or valid cells and no deflected pair.
pub fn blank_warning(
    job: &Job,
    scene: &Scene,
    domain: &JobDomain,
    params: &Params,
    run: &DomainRun,
) -> Option<String> {
    let (w, h, d) = domain.dims();
    let active = job.render.active_cells(w, h, d);
    let cells = run.field.cells.get(active)?;
    if cells.is_empty() || run.field.total_samples() == 0 {
        return None;
    }
    let name = domain.name();
    let move_flags = match domain {
        JobDomain::Plane(_) => "--slice, --plane or --window",
        JobDomain::Volume(_) => "--box",
        JobDomain::Camera(_) => "--eye or --camera",
    };
    if cells.iter().all(|c| c.s0 == 0.0) {
        let points = probe_points(domain);
        let inside = points.iter().filter(|&&p| enclosed(scene, p)).count();
        let cause = if 2 * inside > points.len() {
            format!(
                "{name} lies inside a closed object (rays from it meet the backs of surfaces on \
                 every side), where no light or walk gets out; move it with {move_flags}"
            )
        } else if params.weighting == Weighting::Radiance {
            format!(
                "no light reached any point of {name}; move it with {move_flags}, add a light \
                 that reaches it (--point-light, --sun, --sky, --env) or use --weight unweighted"
            )
        } else {
            format!(
                "every pair of {name} carried zero weight (absorbed by black surfaces); move it \
                 with {move_flags}"
            )
        };
        return Some(format!(
            "warning: no valid cell: σ is undefined everywhere (the 'valid' channel is 0): {cause}"
        ));
    }
    if run.none_deflected() {
        return Some(format!(
            "warning: no pair was deflected: every walk ran straight for its whole run length \
             (T in [{:.4}, {:.4}]) without reaching any geometry, so σ is 0 everywhere; give \
             longer run lengths with --t0/--t1 (the scene's diagonal is {:.4})",
            params.t0,
            params.t1,
            scene.extent()
        ));
    }
    None
}
