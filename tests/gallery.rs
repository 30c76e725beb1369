//! The gallery of the paper's figures: `scenes/paper/gallery.txt` (written by
//! `scenes/generate_paper.py`, rendered by `scripts/gallery.sh`). Every run in it is run here
//! through the binary with its own settings, only smaller (`--res`, `--size`, `--spp`), and with
//! `--separatrices` as the gallery does: it must succeed and give finite channels, the fluence
//! where radiance-weighted, the beauty image for cameras, the flatland and bounce-cap settings in
//! the header, some cells with σ > 0, and the separatrix outputs. Nothing is regenerated here.

use crate::support::{exr_parts, ftpd3d_in, scene_path, temp_dir};
use std::path::Path;

struct Entry {
    name: String,
    figure: String,
    args: Vec<String>,
}

fn gallery() -> Vec<Entry> {
    let path = scene_path("paper/gallery.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    text.lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let cols: Vec<&str> = l.split('\t').collect();
            assert_eq!(cols.len(), 4, "{}: {l}", path.display());
            assert!(
                !cols[3].contains(['"', '\'']),
                "arguments are split on spaces: {l}"
            );
            Entry {
                name: cols[0].to_string(),
                figure: cols[1].to_string(),
                args: cols[3].split_whitespace().map(String::from).collect(),
            }
        })
        .collect()
}

/// The entry's arguments with the grid and the samples made tiny.
fn tiny(args: &[String]) -> Vec<String> {
    let mut out = args.to_vec();
    for i in 0..out.len().saturating_sub(1) {
        let small = match out[i].as_str() {
            "--res" => "12",
            "--size" => "12,9",
            "--spp" => "4",
            _ => continue,
        };
        out[i + 1] = small.to_string();
    }
    out
}

fn value_of<'a>(args: &'a [String], flag: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == flag)
        .map(|i| args[i + 1].as_str())
}

#[test]
fn the_gallery_lists_every_figure_and_every_scene_of_scenes_paper() {
    let entries = gallery();
    let figures: Vec<&str> = entries.iter().map(|e| e.figure.as_str()).collect();
    for f in [
        "3a", "3b", "3c", "4a", "4c", "5", "6a", "6b", "6c", "7a", "7c",
    ] {
        assert!(figures.contains(&f), "Fig. {f} is not in the gallery");
    }
    // Every scene file of scenes/paper is run: OBJs directly or through a sidecar.
    let used: Vec<String> = entries
        .iter()
        .map(|e| value_of(&e.args, "--scene").unwrap().to_string())
        .collect();
    let dir = scene_path("paper");
    for f in std::fs::read_dir(&dir).unwrap() {
        let name = f.unwrap().file_name().into_string().unwrap();
        let stem = name.rsplit_once('.').map_or(name.as_str(), |(s, _)| s);
        if name.ends_with(".obj") || name.ends_with(".toml") {
            assert!(
                used.iter().any(|u| Path::new(u)
                    .file_stem()
                    .is_some_and(|s| s.to_str() == Some(stem))),
                "scenes/paper/{name} is in no gallery run"
            );
        }
    }
}

#[test]
fn every_gallery_run_works_at_a_tiny_size() {
    let dir = temp_dir("gallery", "tiny");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for e in gallery() {
        let mut args = tiny(&e.args);
        let out = dir.join(format!("{}.exr", e.name));
        let extra = ["--batches", "2", "--separatrices", "--quiet", "-o"];
        args.extend(extra.iter().map(|s| s.to_string()));
        args.push(out.to_str().unwrap().to_string());
        let arg_refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let run = ftpd3d_in(root, &arg_refs);
        assert!(run.ok, "{}: ftpd3d {}\n{}", e.name, args.join(" "), run.err);

        let parts = exr_parts(&out);
        let part = &parts[0];
        let channel = |name: &str| {
            part.channel_data
                .list
                .iter()
                .find(|c| c.name.to_string() == name)
                .map(|c| c.sample_data.values_as_f32().collect::<Vec<f32>>())
        };
        let attr = |key: &str| -> String {
            crate::support::ftpd3d_attribute(part, key)
                .unwrap_or_else(|| panic!("{}: no header attribute ftpd3d.{key}", e.name))
        };
        let camera = e.args.iter().any(|a| a == "--camera");
        let weighting =
            value_of(&e.args, "--weight").unwrap_or(if camera { "importance" } else { "radiance" });
        let mut expected = vec!["ftpd", "ftpd.stderr", "valid", "separatrix"];
        match (camera, weighting) {
            (true, _) => expected.extend(["radiance.R", "radiance.G", "radiance.B"]),
            (false, "radiance") => expected.extend(["fluence.R", "fluence.G", "fluence.B"]),
            _ => {}
        }
        for name in &expected {
            let v = channel(name).unwrap_or_else(|| panic!("{}: no channel {name}", e.name));
            assert!(
                v.iter().all(|x| x.is_finite()),
                "{}: {name} is not finite everywhere",
                e.name
            );
        }
        if weighting != "radiance" {
            assert!(channel("fluence.R").is_none(), "{}: fluence", e.name);
        }
        let sigma = channel("ftpd").unwrap();
        let valid = channel("valid").unwrap();
        let lit = sigma
            .iter()
            .zip(&valid)
            .filter(|(s, v)| **v > 0.0 && **s > 0.0)
            .count();
        assert!(lit > 0, "{}: no cell has σ > 0", e.name);
        if !camera {
            let flat = e.args.iter().any(|a| a == "--flatland");
            assert_eq!(attr("flatland"), flat.to_string(), "{}", e.name);
        }
        if let Some(cap) = value_of(&e.args, "--max-bounces") {
            assert_eq!(attr("max_bounces"), cap, "{}", e.name);
        }
        if let Some(cap) = value_of(&e.args, "--radiance-bounces") {
            assert_eq!(attr("radiance_bounces"), cap, "{}", e.name);
        }
        for suffix in ["png", "sep.png", "sep.vtp", "sep.svg"] {
            let f = out.with_extension(suffix);
            assert!(f.is_file(), "{}: no {}", e.name, f.display());
        }
    }
}
