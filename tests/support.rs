//! Scaffolding the test modules share: fresh temporary directories and runs of the binary.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test: `ftpd3d-<module>-<test>-<pid>` under the system's
/// temporary directory.
pub fn temp_dir(module: &str, test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ftpd3d-{module}-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// What a run of the binary gave: exit success, stdout, stderr.
pub struct Run {
    pub ok: bool,
    pub out: String,
    pub err: String,
}

/// Runs the ftpd3d binary with `args`, in `dir` when given.
pub fn ftpd3d(dir: Option<&Path>, args: &[&str]) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_ftpd3d"));
    if let Some(d) = dir {
        cmd.current_dir(d);
    }
    let out = cmd.args(args).output().expect("binary runs");
    Run {
        ok: out.status.success(),
        out: String::from_utf8_lossy(&out.stdout).into_owned(),
        err: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Every part of an EXR file with all its channels and attributes, read by the exr crate directly
/// (not by the project's reader).
pub fn exr_parts(
    path: &Path,
) -> Vec<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>> {
    use exr::prelude::*;
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap()
        .layer_data
        .into_vec()
}

/// A scene of `triangles` over `positions` (no shading normals, an empty load report), its
/// triangles of `materials[tri_material[i]]`, built with its Embree structure; `name` stands for
/// the file it would have come from.
pub fn scene_of(
    name: &str,
    positions: Vec<glam::Vec3>,
    triangles: Vec<[u32; 3]>,
    tri_material: Vec<u32>,
    materials: Vec<ftpd3d::scene::Material>,
) -> ftpd3d::scene::Scene {
    ftpd3d::scene::Scene::build(
        Path::new(name),
        positions,
        Vec::new(),
        triangles,
        tri_material,
        materials,
        Default::default(),
    )
    .unwrap()
}

/// Render options of `spp` samples per cell in 8 batches with `seed`, on every core, quietly.
pub fn render_opts(spp: u32, seed: u64) -> ftpd3d::render::RenderOptions {
    ftpd3d::render::RenderOptions {
        spp,
        batches: 8,
        seed,
        threads: 0,
        progress: false,
        ..Default::default()
    }
}

/// Checks a set of z-scores from independent estimates of equal expectations: none beyond 4.5,
/// and no more beyond 3 than a binomial tail allows (expected 0.27 %; at most 1 + 3 % of them).
pub fn assert_consistent(what: &str, zs: &[(String, f64)]) {
    let beyond3: Vec<_> = zs.iter().filter(|(_, z)| z.abs() > 3.0).collect();
    let mean_sq = zs.iter().map(|(_, z)| z * z).sum::<f64>() / zs.len() as f64;
    eprintln!(
        "{what}: {} comparisons, mean z² {mean_sq:.2}, beyond 3: {beyond3:?}",
        zs.len()
    );
    for (name, z) in zs {
        assert!(z.abs() <= 4.5, "{what}: {name}: z = {z:.2}");
    }
    assert!(
        beyond3.len() as f64 <= 1.0 + 0.03 * zs.len() as f64,
        "{what}: {} of {} beyond 3 standard errors",
        beyond3.len(),
        zs.len()
    );
}

/// σ, its standard error, the mean luminance of the weight (the fluence for radiance weighting)
/// and its standard error, from `n` samples at `at` drawn with `s`.
pub fn point_estimate(
    scene: &ftpd3d::scene::Scene,
    at: glam::DVec3,
    p: &ftpd3d::ftpd::Params,
    mut s: ftpd3d::rng::Sampler,
    n: usize,
) -> (f64, f64, f64, f64) {
    let mut m = ftpd3d::ftpd::moments::Moments::default();
    let (mut f, mut f2) = (0.0, 0.0);
    for _ in 0..n {
        let smp = ftpd3d::ftpd::sample_point(scene, at, p, &mut s);
        m.add_sample(smp.c, smp.delta, smp.weight);
        let w = ftpd3d::math::luminance(smp.weight);
        f += w;
        f2 += w * w;
    }
    let v = m.finalize();
    let mean = f / n as f64;
    let se = ((f2 / n as f64 - mean * mean).max(0.0) / (n as f64 - 1.0).max(1.0)).sqrt();
    (v.sigma, v.stderr, mean, se)
}

/// Appends the z-scores of two independent point estimates (`point_estimate`) of the same
/// quantities: σ always, the fluence too under radiance weighting.
pub fn push_z_scores(
    out: &mut Vec<(String, f64)>,
    name: &str,
    weighting: ftpd3d::ftpd::Weighting,
    a: (f64, f64, f64, f64),
    b: (f64, f64, f64, f64),
) {
    let z = |x: f64, sx: f64, y: f64, sy: f64| {
        let se = (sx * sx + sy * sy).sqrt();
        if se > 0.0 { (x - y) / se } else { 0.0 }
    };
    out.push((format!("σ {name}"), z(a.0, a.1, b.0, b.1)));
    if weighting == ftpd3d::ftpd::Weighting::Radiance {
        out.push((format!("fluence {name}"), z(a.2, a.3, b.2, b.3)));
    }
}
