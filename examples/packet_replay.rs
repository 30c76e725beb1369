//! Would Embree's packet traversal pay for the kernel's rays? Records the closest-hit rays of a
//! radiance-weighted run over the slice z = 0 of each scene (one thread), then replays them one by
//! one (`rtcIntersect1`) and in packets of four consecutive rays (`rtcIntersect4`), best of five,
//! and counts the rays whose packet hit differs from the single-ray hit in any bit.
//!
//! ```sh
//! cargo run --release --example packet_replay -- [RES] [SPP] [SCENE ...]
//! ```

use ftpd3d::cli::bench::packet_replay;
use ftpd3d::domain::Plane;
use ftpd3d::params::EstimatorArgs;
use ftpd3d::render::RenderOptions;
use ftpd3d::scene::load::load_scene;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let res: usize = args.first().map_or(Ok(128), |a| a.parse())?;
    let spp: u32 = args.get(1).map_or(Ok(32), |a| a.parse())?;
    let scenes: Vec<String> = if args.len() > 2 {
        args[2..].to_vec()
    } else {
        vec!["cornell_mirror.obj".into(), "stair_wall.obj".into()]
    };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    println!(
        "| scene | closest-hit rays | rtcIntersect1 s | rtcIntersect4 s | packet/single time | differing hits |"
    );
    println!("|---|---|---|---|---|---|");
    for name in &scenes {
        let scene = load_scene(&root.join(name))?;
        let plane = Plane::axis_slice(
            &scene.bounds,
            "z=0".parse().map_err(anyhow::Error::msg)?,
            None,
            res,
        )?;
        let params = EstimatorArgs::default().resolve(&scene)?;
        let opts = RenderOptions {
            spp,
            threads: 1,
            ..RenderOptions::default()
        };
        let r = packet_replay(&scene, &plane, &params, &opts, 5)?;
        println!(
            "| {name} | {} | {:.3} | {:.3} | {:.2} | {} |",
            r.rays,
            r.single_seconds,
            r.packet_seconds,
            r.packet_seconds / r.single_seconds,
            r.differing
        );
    }
    Ok(())
}
