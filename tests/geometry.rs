//! Ray-offset robustness: rays leaving random points of random triangles never hit their own
//! triangle again, also when the scene sits far from the origin.

use crate::support::{scene_path, translated};
use ftpd3d::rng::Sampler;
use ftpd3d::scene::Scene;
use ftpd3d::transport::sampling::{sample_uniform_sphere, sample_uniform_triangle};
use glam::Vec3;
use std::path::Path;

fn self_hits(scene: &Scene, rays: usize) -> usize {
    let mut s = Sampler::new(5, 0, 0);
    let mut bad = 0;
    for k in 0..rays {
        let tri = k % scene.triangles.len();
        let [a, b, c] = scene.triangles[tri].map(|i| scene.positions[i as usize].as_dvec3());
        let (b0, b1, b2) = sample_uniform_triangle(s.next_2d());
        let p = b0 * a + b1 * b + b2 * c;
        // A direction on a random side, away from the surface.
        let mut d = sample_uniform_sphere(s.next_2d());
        let n = scene.tri_normal(tri);
        if d.dot(n).abs() < 1e-3 {
            continue;
        }
        // Probe the exact hit point from outside to get Embree's own reconstruction.
        let side = d.dot(n).signum();
        let probe_o = p + n * side * 0.1 * scene.extent();
        let Some(h) = scene.intersect(probe_o, (p - probe_o).normalize(), f64::INFINITY) else {
            continue;
        };
        if h.prim as usize != tri {
            continue;
        }
        if d.dot(h.ng) * side < 0.0 {
            d = -d;
        }
        let o = h.spawn_origin(d);
        if scene
            .intersect(o, d, f64::INFINITY)
            .is_some_and(|h2| h2.prim as usize == tri)
        {
            bad += 1;
        }
    }
    bad
}

#[test]
fn rays_from_triangles_never_rehit_their_own() {
    let scene = ftpd3d::scene::load::load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    assert_eq!(self_hits(&scene, 20_000), 0);
    let far = translated(&scene, Vec3::splat(1e4));
    assert_eq!(self_hits(&far, 20_000), 0);
}

/// Per-corner texture coordinates (OBJ's `vt`) follow their triangles when degenerate ones are
/// dropped, read (0, 0) where a corner has none, and are kept only when a material has a texture.
#[test]
fn geometry_per_corner_texture_coordinates_follow_their_triangles() {
    use ftpd3d::math::Rgb;
    use ftpd3d::scene::material::TextureRef;
    use ftpd3d::scene::{Material, Shading, TexCoords};
    use glam::Vec2;
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
    // The middle triangle is degenerate (two equal corners) and dropped.
    let triangles = vec![[0, 1, 2], [0, 0, 1], [1, 3, 2]];
    let table = vec![
        Vec2::new(0.1, 0.2),
        Vec2::new(0.3, 0.4),
        Vec2::new(0.5, 0.6),
    ];
    let corners = vec![[0, 1, 2], [2, 2, 2], [1, u32::MAX, 0]];
    let build = |m: Material| {
        Scene::from_parts(
            Path::new("uv.obj"),
            positions.clone(),
            triangles.clone(),
            vec![0; 3],
            Shading::None,
            TexCoords::PerCorner {
                table: table.clone(),
                corners: corners.clone(),
            },
            vec![m],
            Default::default(),
        )
        .unwrap()
    };
    let mut textured = Material::default_grey();
    textured.maps.base_color = Some(TextureRef {
        texture: 0,
        factor: Rgb::ONE,
        wrap: Default::default(),
        transform: Default::default(),
    });
    let scene = build(textured);
    assert_eq!(scene.triangles[..], [[0, 1, 2], [1, 3, 2]]);
    assert_eq!(scene.report.degenerate_dropped, 1);
    assert_eq!(scene.corner_uvs(0), [table[0], table[1], table[2]]);
    assert_eq!(scene.corner_uvs(1), [table[1], Vec2::ZERO, table[0]]);
    // No textured material: nothing kept, every corner reads (0, 0).
    let plain = build(Material::default_grey());
    assert!(plain.texcoords().is_none());
    assert_eq!(plain.corner_uvs(1), [Vec2::ZERO; 3]);
}
