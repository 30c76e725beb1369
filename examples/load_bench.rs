//! Loading benchmark: loads one scene (parse, then the BVH build) and prints the times and the
//! memory it takes.
//!
//!     cargo run --release --example load_bench -- SCENE.obj
//!
//! Prints the parse and BVH seconds, the process's resident memory after loading (`VmRSS`) and
//! at its peak (`VmHWM`), the bytes Embree holds (BVH, its copies of vertices and indices) now and
//! at its peak, counted by Embree's memory monitor, and per triangle what stays resident besides
//! Embree. One load per process, so that the peak is this load's: run it again for another sample.
//! The 10 M-triangle scene of the README is `python3 scripts/heavy_scene.py OUT.obj 20 3
//! --attributes --materials 300`.

use std::time::Instant;

/// A `/proc/self/status` field in bytes (Linux; 0 elsewhere).
fn status_bytes(key: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix(':'))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

fn main() -> anyhow::Result<()> {
    let Some(path) = std::env::args().nth(1) else {
        anyhow::bail!("usage: load_bench SCENE");
    };
    let rss_before = status_bytes("VmRSS");
    let start = Instant::now();
    let scene = ftpd3d::scene::load::load_scene(std::path::Path::new(&path))?;
    let seconds = start.elapsed().as_secs_f64();
    let (embree, embree_peak) = ftpd3d::accel::embree_memory();
    let (rss, hwm) = (status_bytes("VmRSS"), status_bytes("VmHWM"));
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    let n = scene.triangles.len().max(1) as f64;
    let mb = |b: u64| b as f64 / 1e6;
    println!("scene            {path}");
    println!(
        "triangles        {} ({} vertices{})",
        scene.triangles.len(),
        scene.positions.len(),
        if scene.has_shading_normals() {
            ", shading normals"
        } else {
            ""
        }
    );
    println!(
        "load             {seconds:.2} s: parse {:.2} s, BVH {:.2} s",
        scene.report.parse_seconds, scene.report.bvh_seconds
    );
    println!(
        "resident         {:.0} MB after loading, {:.0} MB at the peak (process before: {:.0} MB)",
        mb(rss),
        mb(hwm),
        mb(rss_before)
    );
    println!(
        "Embree           {:.0} MB after loading, {:.0} MB at its peak",
        mb(embree),
        mb(embree_peak)
    );
    println!(
        "per triangle     {:.0} B resident besides Embree after loading; peak {:.0} B besides \
         Embree's peak; Embree {:.0} B",
        (rss.saturating_sub(rss_before + embree)) as f64 / n,
        (hwm.saturating_sub(rss_before + embree_peak)) as f64 / n,
        embree as f64 / n
    );
    Ok(())
}
