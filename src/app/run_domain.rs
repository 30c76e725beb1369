//! One domain of a job run to its field: the library's entry point for a resolved domain, which the
//! command line's job runner and any other caller share, so that they compute the same field bit
//! for bit. Nothing here prints, writes a file or names a flag.

use super::progress::mark_progress;
use super::resolve::JobDomain;
use crate::field::Field;
use crate::ftpd::Params;
use crate::render::{
    Hooks, Progress, RenderOptions, RunStats, check_flatland, run_domain_progressive,
};
use crate::run_info::RunInfo;
use crate::scene::Scene;

/// Where a domain's run starts.
#[derive(Clone, Debug)]
pub enum Start {
    /// A new field.
    Fresh,
    /// A field read back with where its run stood ([`super::read_progress`]), already checked to
    /// belong to this run ([`super::check_resume`]).
    Resumed(Field, Progress),
}

/// What a domain's passes came to.
#[derive(Clone, Debug)]
pub struct DomainRun {
    /// The field, described by [`DomainRun::info`].
    pub field: Field,
    pub progress: Progress,
    pub stats: RunStats,
    /// The run's description with where it stands (partial, passes, samples, why it stopped).
    pub info: RunInfo,
}

impl DomainRun {
    /// Whether the run stopped before its budget (interrupted, or at a pass limit): the field is
    /// partial and can be resumed.
    pub fn partial(&self) -> bool {
        !self.stats.stop.is_complete()
    }

    /// Pairs carried weight, yet none was deflected: Δ is exactly 0 only for two straight walks,
    /// so every walk ran its whole run length without reaching any geometry.
    pub fn none_deflected(&self) -> bool {
        let cells = &self.field.cells;
        cells.iter().any(|c| c.s0 > 0.0) && cells.iter().all(|c| c.s1 == 0.0 && c.s2 == 0.0)
    }
}

/// Runs passes of `params` over `domain` of `scene` from `start` until a budget of `opts` is
/// reached or `hooks.stop` is set, on `opts.threads` threads; the field comes back described by
/// `info` ([`super::describe_domain`]) and marked with where the run stands.
pub fn run_domain(
    scene: &Scene,
    domain: &JobDomain,
    params: &Params,
    opts: &RenderOptions,
    mut info: RunInfo,
    start: Start,
    hooks: Hooks,
) -> anyhow::Result<DomainRun> {
    if let JobDomain::Plane(p) = domain {
        check_flatland(scene, p, params)?;
    }
    let (mut field, mut progress) = match start {
        Start::Fresh => {
            let (w, h, d) = domain.dims();
            let field = Field::new(w, h, d);
            let field = match opts.gradient_domain {
                Some(alpha) => field.with_shift(alpha),
                None => field,
            };
            (field, Progress::default())
        }
        Start::Resumed(field, progress) => (field, progress),
    };
    field.set_info(&info);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let stats = domain.sampled(scene, |dom| {
        run_domain_progressive(
            &pool,
            scene,
            dom,
            params,
            opts,
            &mut field,
            &mut progress,
            hooks,
        )
    })?;
    let partial = !stats.stop.is_complete();
    mark_progress(
        &mut field,
        &mut info,
        &progress,
        opts,
        partial,
        Some(stats.stop),
    );
    Ok(DomainRun {
        field,
        progress,
        stats,
        info,
    })
}
