//! `--light-scale NAME=FACTOR`: a scene file's own lights switched off and scaled
//! (`ftpd3d::scene::dimmer`). Scaling every light by a power of two scales every radiance weight
//! exactly, so the weighted sums and fluence double bit for bit and σ, a ratio of them, is the
//! same bit for bit; a light switched off changes the field; names the scene lacks are refused.

use crate::support::{Run, assert_resume_keeps, scene_path, small_slice, temp_dir};
use ftpd3d::output::exr::read_exr;

/// Every cell of `scaled` holds the weighted sums and fluence of `plain` times `k` (a power of
/// two: exactly), and the same σ, mean, second moment, standard error and validity, bit for bit.
fn assert_scaled(plain: &ftpd3d::field::Field, scaled: &ftpd3d::field::Field, k: f64, what: &str) {
    assert_eq!(plain.cells.len(), scaled.cells.len());
    let mut weighted = 0;
    for (i, (a, b)) in plain.cells.iter().zip(&scaled.cells).enumerate() {
        let (sa, sb) = (a.sums(), b.sums());
        assert_eq!(
            [sa.0 * k, sa.1 * k, sa.2 * k].map(f64::to_bits),
            [sb.0, sb.1, sb.2].map(f64::to_bits),
            "{what}: cell {i}: the weighted sums scale by {k}"
        );
        assert_eq!(
            (a.fluence() * k).to_array().map(f64::to_bits),
            b.fluence().to_array().map(f64::to_bits),
            "{what}: cell {i}: fluence scales by {k}"
        );
        let (va, vb) = (a.finalize(), b.finalize());
        assert_eq!(
            [va.sigma, va.mean, va.m2, va.stderr].map(f64::to_bits),
            [vb.sigma, vb.mean, vb.m2, vb.stderr].map(f64::to_bits),
            "{what}: cell {i}: σ and its moments are scale-invariant"
        );
        assert_eq!((va.valid, va.estimated), (vb.valid, vb.estimated));
        weighted += usize::from(sa.0 > 0.0);
    }
    assert!(
        weighted > 0,
        "{what}: no cell carried weight: the test shows nothing"
    );
}

#[test]
fn scaling_every_light_by_a_power_of_two_scales_the_weights_and_keeps_sigma_bit_for_bit() {
    let dir = temp_dir("light_scale", "invariance");
    // An emissive material (OBJ; in flatland, its cross-section), a glTF KHR_lights_punctual
    // light, a sidecar's point light, and a sidecar's sun and environment map.
    for (scene, k, flags) in [
        ("cornell_mirror.obj", "2", &[][..]),
        ("flat_mirrors.obj", "2", &["--flatland"][..]),
        ("cornell_point.gltf", "0.25", &[][..]),
        ("plane_point.toml", "2", &[][..]),
        ("courtyard/courtyard.toml", "2", &[][..]),
    ] {
        let path = scene_path(scene);
        let out = |n: &str| {
            let name = scene.replace('/', "_");
            dir.join(format!("{name}.{n}.exr")).display().to_string()
        };
        let run = |extra: &[&str], o: &str| {
            let r = small_slice(&path, &[flags, extra, &["--spp", "8", "-o", o]].concat());
            assert!(r.ok, "{scene}: {}", r.err);
        };
        run(&[], &out("plain"));
        run(&["--light-scale", &format!("*={k}")], &out("scaled"));
        let plain = read_exr(out("plain").as_ref()).unwrap();
        let scaled = read_exr(out("scaled").as_ref()).unwrap();
        assert_scaled(&plain, &scaled, k.parse().unwrap(), scene);
        assert!(!plain.meta.contains_key("light_scale"));
        let recorded = &scaled.meta["light_scale"];
        assert!(recorded.ends_with(&format!("={k}")), "{scene}: {recorded}");
    }
}

#[test]
fn a_light_switched_off_changes_the_field_and_all_off_is_diagnosed() {
    let dir = temp_dir("light_scale", "off");
    let scene = scene_path("cornell_mirror.obj");
    let out = |n: &str| dir.join(n).display().to_string();
    let lamp = ["--point-light", "0.3,0.5,0.2:3,3,3"];
    let run = |extra: &[&str]| -> Run { small_slice(&scene, extra) };
    for (name, extra) in [
        ("both.exr", &[][..]),
        ("lamp.exr", &["--light-scale", "light=0"][..]),
        ("dim.exr", &["--light-scale", "light=0.5"][..]),
    ] {
        let r = run(&[&lamp[..], extra, &["--spp", "8", "-o", &out(name)]].concat());
        assert!(r.ok, "{}", r.err);
    }
    let read = |n: &str| read_exr(out(n).as_ref()).unwrap();
    let (both, lamp_only, dim) = (read("both.exr"), read("lamp.exr"), read("dim.exr"));
    assert_ne!(
        both.sigma(),
        lamp_only.sigma(),
        "switching the lamp off changed nothing"
    );
    assert_ne!(
        both.sigma(),
        dim.sigma(),
        "dimming one of two lights changed nothing"
    );
    assert_eq!(lamp_only.meta["light_scale"], "light=0");
    assert_eq!(dim.meta["light_scale"], "light=0.5");

    // Every light off: radiance weighting has nothing to weight by, and says why.
    let r = run(&["--light-scale", "*=0", "--spp", "4", "-o", &out("dark.exr")]);
    assert!(
        !r.ok && r.err.contains("switched its lights off"),
        "{}",
        r.err
    );
    assert!(!dir.join("dark.exr").exists(), "a refused run wrote a file");

    // Names the scene does not have, twice, or bad factors: refused, naming the flag.
    for (flags, says) in [
        (&["--light-scale", "bulb=1"][..], "its lights: light"),
        (
            &["--light-scale", "light=1", "--light-scale", "light=2"][..],
            "scaled twice",
        ),
        (&["--light-scale", "light=-1"][..], "finite number ≥ 0"),
        (&["--light-scale", "light"][..], "NAME=FACTOR"),
    ] {
        let r = run(&[flags, &["--spp", "4", "-o", &out("bad.exr")]].concat());
        assert!(
            !r.ok && r.err.contains("--light-scale") && r.err.contains(says),
            "{flags:?}: {}",
            r.err
        );
    }

    // A file computed with other light scales does not resume without them.
    let again = out("again.exr");
    let cells = || read_exr(again.as_ref()).unwrap().cells;
    let one_go = {
        let r = run(&[
            &lamp[..],
            &["--light-scale", "light=0.5", "--spp", "8"],
            &["-o", &out("one.exr")],
        ]
        .concat());
        assert!(r.ok, "{}", r.err);
        read("one.exr").cells
    };
    assert_eq!(one_go, dim.cells);
    let with_lamp = |extra: &[&str]| run(&[&lamp[..], extra].concat());
    assert_resume_keeps(
        with_lamp,
        &["--light-scale", "light=0.5"],
        "light_scale",
        &again,
        cells,
        &one_go,
    );
}
