//! FTPD estimator against analytic facts: empty space, the planar mirror (an isometry), a diffuse
//! wall, determinism, and the EXR round trip.

use crate::support::scene_path;
use ftpd3d::domain::Plane;
use ftpd3d::field::Field;
use ftpd3d::ftpd::moments::Moments;
use ftpd3d::ftpd::{Params, Weighting, visit_point};
use ftpd3d::render::RenderOptions;
use ftpd3d::render::run_plane;
use ftpd3d::rng::Sampler;
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::load_scene;
use glam::DVec3;

fn unweighted(t0: f64, t1: f64, angle_deg: f64) -> Params {
    Params {
        t0,
        t1,
        theta_max: angle_deg.to_radians(),
        weighting: Weighting::Unweighted,
        max_bounces: 32,
        radiance_bounces: None,
        flat: None,
        design: ftpd3d::ftpd::Design::default_for(Weighting::Unweighted),
        guide: false,
    }
}

/// A vertical line of cells x = 0, z = 0, heights from `y0` to `y1` above a plane at y = 0.
fn column(y0: f64, y1: f64, cells: usize) -> Plane {
    Plane::new(
        DVec3::new(-0.005, y0, 0.0),
        DVec3::Y,
        DVec3::X,
        (y1 - y0, 0.01),
        cells,
        "column".into(),
    )
    .unwrap()
}

fn opts(spp: u32, seed: u64, threads: usize) -> RenderOptions {
    RenderOptions {
        spp,
        batches: 16,
        seed,
        threads,
        progress: false,
        ..Default::default()
    }
}

#[test]
fn empty_space_gives_exactly_zero() {
    // The only geometry is 10 km away: no walk of length ≤ 2 can reach it.
    let scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let far = crate::support::translated(&scene, glam::Vec3::new(0.0, -1e4, 0.0));
    let plane = Plane::new(
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::X,
        DVec3::Y,
        (2.0, 2.0),
        16,
        "empty".into(),
    )
    .unwrap();
    let (field, stats) =
        run_plane(&far, &plane, &unweighted(0.5, 2.0, 5.0), &opts(64, 3, 0)).unwrap();
    assert!(stats.rays > 0);
    for v in field.values() {
        assert!(v.valid);
        assert_eq!(v.sigma, 0.0);
        assert_eq!(v.stderr, 0.0);
    }
}

/// Δ and the bounce counts of every pair of `n` samples at height `h` above `scene`'s plane.
fn pair_deltas(scene: &Scene, h: f64, p: &Params, n: usize) -> Vec<(f64, (u32, u32))> {
    let mut s = Sampler::new(11, 0, 0);
    let mut out = Vec::new();
    for _ in 0..n {
        visit_point(scene, DVec3::new(0.0, h, 0.0), p, &mut s, &mut |pair| {
            out.push((pair.delta, pair.bounces))
        });
    }
    out
}

#[test]
fn mirror_is_an_isometry_for_pairs_that_both_reflect() {
    let scene = load_scene(&scene_path("mirror_plane.obj")).unwrap();
    let p = unweighted(1.0, 1.0, 5.0);
    let d = pair_deltas(&scene, 0.3, &p, 50_000);
    let both = d.iter().filter(|(_, b)| *b == (1, 1)).count();
    assert!(both > 10_000, "enough pairs reflect: {both}");
    // Rounding only: positions are O(1) in f64.
    let worst = d
        .iter()
        .filter(|(_, b)| b.0 == b.1)
        .map(|(x, _)| x.abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-9,
        "largest |Δ| over pairs with equal bounce counts: {worst}"
    );
}

/// Moments over the pairs accepted by `keep` (each sample's sums over them divided by its number
/// of pairs), in 16 batches, at a point at height h.
fn moments_where(
    scene: &Scene,
    h: f64,
    p: &Params,
    keep: impl Fn((u32, u32)) -> bool,
) -> ftpd3d::ftpd::moments::CellValue {
    let mut total = Moments::default();
    for batch in 0..16 {
        let mut s = Sampler::new(21, batch, 0);
        let mut b = Moments::default();
        for _ in 0..4000 {
            let mut sums = [0.0; 3];
            let smp = visit_point(scene, DVec3::new(0.0, h, 0.0), p, &mut s, &mut |pair| {
                if keep(pair.bounces) {
                    sums[0] += pair.c;
                    sums[1] += pair.c * pair.delta;
                    sums[2] += pair.c * pair.delta * pair.delta;
                }
            });
            let n = f64::from(p.design.pairs());
            b.add_unit(sums[0] / n, sums[1] / n, sums[2] / n, smp.weight);
        }
        total.add_batch(&b);
    }
    total.finalize()
}

#[test]
fn mirror_sigma_is_zero_where_both_walks_reflect_and_far_below_diffuse() {
    let mirror = load_scene(&scene_path("mirror_plane.obj")).unwrap();
    let diffuse = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let p = unweighted(0.5, 1.0, 5.0);
    for h in [0.1, 0.3] {
        // Restricted to pairs whose walks both reflect (or both go straight), σ vanishes: within 3
        // standard errors of 0, plus the f64 rounding floor of the end points.
        let m = moments_where(&mirror, h, &p, |b| b.0 == b.1);
        assert!(m.valid);
        assert!(
            m.sigma <= 3.0 * m.stderr + 1e-9,
            "h = {h}: σ = {} ± {}",
            m.sigma,
            m.stderr
        );
        // All pairs, including those where one walk reflects and the other does not: σ is small but
        // positive, far below the diffuse plane's (about 1 % of it: hundreds of standard errors
        // from either bound, whatever the seed).
        let all_m = moments_where(&mirror, h, &p, |_| true);
        let all_d = moments_where(&diffuse, h, &p, |_| true);
        let gap = all_d.sigma - all_m.sigma;
        println!(
            "h = {h}: restricted mirror σ {:.2e} ± {:.1e}; mirror σ {:.4} ± {:.4}, diffuse σ {:.4} \
             ± {:.4}",
            m.sigma, m.stderr, all_m.sigma, all_m.stderr, all_d.sigma, all_d.stderr
        );
        assert!(
            gap > 5.0 * (all_d.stderr.powi(2) + all_m.stderr.powi(2)).sqrt(),
            "h = {h}: mirror {all_m:?} diffuse {all_d:?}"
        );
        assert!(
            all_m.sigma < 0.2 * all_d.sigma,
            "h = {h}: mirror σ {} vs diffuse σ {}",
            all_m.sigma,
            all_d.sigma
        );
    }
}

#[test]
fn diffuse_wall_sigma_falls_with_distance() {
    let scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let p = unweighted(0.5, 1.0, 5.0);
    let plane = column(0.05, 1.5, 8);
    let (field, _) = run_plane(&scene, &plane, &p, &opts(4096, 5, 0)).unwrap();
    let v = field.values();
    // Cells along u (height): each nearer cell has larger σ than the next farther one, beyond
    // 3 combined standard errors, until walks no longer reach the wall (h > t1): there σ = 0. The
    // steps are 8.6 to 28 standard errors, so that a seed misses 3 with probability under 1e-7.
    for k in 0..plane.width - 1 {
        let (near, far) = (v[k], v[k + 1]);
        let h_far = 0.05 + (k as f64 + 1.0) * 1.45 / plane.width as f64;
        if h_far < 0.9 {
            let se = (near.stderr.powi(2) + far.stderr.powi(2)).sqrt();
            println!(
                "cell {k}: σ falls by {:.1} standard errors",
                (near.sigma - far.sigma) / se
            );
            assert!(
                near.sigma - far.sigma > 3.0 * se,
                "cell {k}: {} ± {} vs {} ± {}",
                near.sigma,
                near.stderr,
                far.sigma,
                far.stderr
            );
        }
    }
    assert_eq!(
        v[plane.width - 1].sigma,
        0.0,
        "beyond t1 nothing is reached"
    );
}

fn small_run(seed: u64, threads: usize) -> Field {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let plane = Plane::axis_slice(&scene.bounds, "z=0".parse().unwrap(), None, 24).unwrap();
    let p = crate::support::params(0.3, 1.5, 0.05, Weighting::Radiance, 16);
    run_plane(&scene, &plane, &p, &opts(16, seed, threads))
        .unwrap()
        .0
}

#[test]
fn same_seed_same_pixels_on_any_thread_count() {
    let a = small_run(7, 1);
    let b = small_run(7, 2);
    assert_eq!(a.cells, b.cells, "bit-identical sums");
    let c = small_run(8, 2);
    assert_ne!(a.cells, c.cells);
    let differing = a.cells.iter().zip(&c.cells).filter(|(x, y)| x != y).count();
    assert!(
        differing > a.cells.len() / 2,
        "different seeds change most cells: {differing}"
    );
}

#[test]
fn exr_round_trip_equals_the_field() {
    let field = small_run(3, 0);
    let dir = crate::support::temp_dir("ftpd", "round_trip");
    let path = dir.join("rt.exr");
    ftpd3d::output::exr::write_exr(&path, &field, &[]).unwrap();
    let back = ftpd3d::output::exr::read_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (field.width, field.height));
    assert_eq!(
        back.cells, field.cells,
        "exact sums, counts and batch statistics"
    );
    assert_eq!(back.meta, field.meta);
    assert_eq!(back.meta["embree"], ftpd3d::embree_version());
    // The display channel equals the finalised σ rounded to f32, in the same cell order.
    let (w, h, sigma) = ftpd3d::output::exr::read_channel(&path, "ftpd").unwrap();
    assert_eq!((w, h), (field.width, field.height));
    for (s, v) in sigma.iter().zip(field.values()) {
        assert_eq!(*s, v.sigma as f32);
    }
    let (_, _, valid) = ftpd3d::output::exr::read_channel(&path, "valid").unwrap();
    assert!(valid.iter().all(|v| *v == 0.0 || *v == 1.0));
    assert!(sigma.iter().all(|s| s.is_finite()));
}

#[test]
fn camera_image_of_an_empty_scene_is_zero_and_beauty_sees_the_light() {
    use ftpd3d::domain::CameraView;
    use ftpd3d::render::run_camera;
    use ftpd3d::scene::Camera;
    let cam = |eye: DVec3, forward: DVec3| Camera {
        name: "test".into(),
        eye,
        forward,
        up: if forward.y.abs() > 0.9 {
            DVec3::Z
        } else {
            DVec3::Y
        },
        fov_y: 0.6,
        aspect: None,
    };
    let p = crate::support::params(0.5, 2.0, 0.1, Weighting::Importance, 8);
    // Empty: the only geometry is 10 km behind the camera.
    let scene = load_scene(&scene_path("diffuse_plane.obj")).unwrap();
    let far = crate::support::translated(&scene, glam::Vec3::new(0.0, 1e4, 0.0));
    let view = CameraView::new(cam(DVec3::ZERO, -DVec3::Y), 16, 12).unwrap();
    let (field, _) = run_camera(&far, &view, &p, &opts(16, 1, 0)).unwrap();
    assert_eq!((field.width, field.height), (16, 12));
    for v in field.values() {
        assert!(v.valid);
        assert_eq!(v.sigma, 0.0);
    }
    // A camera in the Cornell box looking up at the light: its beauty image is bright where the
    // light is (radiance Ke = (17, 12, 4) seen directly), and the deflection pairs hit the ceiling.
    let cornell = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let view = CameraView::new(cam(DVec3::new(0.0, 1.0, 0.0), DVec3::Y), 9, 9).unwrap();
    let (field, _) = run_camera(&cornell, &view, &p, &opts(64, 1, 0)).unwrap();
    let centre = field.cells[4 * 9 + 4];
    let l = centre.fluence();
    assert!(
        (l.x - 17.0).abs() < 1e-9 && (l.y - 12.0).abs() < 1e-9 && (l.z - 4.0).abs() < 1e-9,
        "{l:?}"
    );
    assert_eq!(field.meta["domain"], "camera");
}
