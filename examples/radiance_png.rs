//! The radiance a finished field carries, as a PNG: `fluence.R/G/B` of a radiance-weighted slice
//! (the incident radiance integrated over all directions, e.g. the paper's Fig. 5a) or the beauty
//! image `radiance.R/G/B` of a camera run. `scripts/gallery.sh` uses it.
//!
//! ```sh
//! cargo run --release --example radiance_png -- FIELD.exr OUT.png
//! ```
//!
//! Exposure: the 99th percentile of the luminance over the valid cells maps to white (so a few
//! very bright cells, such as a light's own, do not darken the rest), then the sRGB transfer
//! curve. Slice cells without a defined σ (`valid` = 0, e.g. inside solids) are grey, as in the σ
//! preview.

use anyhow::{Context, bail};
use ftpd3d::output::exr::read_channel;
use std::path::Path;

fn srgb(x: f64) -> u8 {
    let x = x.clamp(0.0, 1.0);
    let v = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (v * 255.0).round() as u8
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [field, out] = args.as_slice() else {
        bail!("usage: radiance_png FIELD.exr OUT.png");
    };
    let field = Path::new(field);
    let channels = |prefix: &str| -> anyhow::Result<(usize, usize, [Vec<f32>; 3])> {
        let (w, h, r) = read_channel(field, &format!("{prefix}.R"))?;
        let (_, _, g) = read_channel(field, &format!("{prefix}.G"))?;
        let (_, _, b) = read_channel(field, &format!("{prefix}.B"))?;
        Ok((w, h, [r, g, b]))
    };
    let slice = channels("fluence");
    let camera = slice.is_err();
    let (w, h, [r, g, b]) = slice.or_else(|_| channels("radiance")).with_context(|| {
        format!(
            "{}: neither fluence.R/G/B (radiance-weighted slices) nor radiance.R/G/B \
                 (camera images)",
            field.display()
        )
    })?;
    // A camera's beauty image is defined at every pixel, also where σ is not (the sky).
    let valid = if camera {
        vec![1.0; w * h]
    } else {
        read_channel(field, "valid")?.2
    };
    let lum = |k: usize| 0.2126 * r[k] as f64 + 0.7152 * g[k] as f64 + 0.0722 * b[k] as f64;
    let mut lit: Vec<f64> = (0..w * h)
        .filter(|&k| valid[k] > 0.0)
        .map(lum)
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    lit.sort_by(f64::total_cmp);
    let white = lit
        .get(((lit.len() as f64 - 1.0) * 0.99) as usize)
        .copied()
        .unwrap_or(1.0);
    let scale = if white > 0.0 { 1.0 / white } else { 1.0 };
    let rgb: Vec<[u8; 3]> = (0..w * h)
        .map(|k| {
            if valid[k] > 0.0 {
                [r[k], g[k], b[k]].map(|x| {
                    let x = x as f64 * scale;
                    srgb(if x.is_finite() { x } else { 0.0 })
                })
            } else {
                [128, 128, 128]
            }
        })
        .collect();
    ftpd3d::output::png::write_png(Path::new(out), w, h, &rgb)?;
    println!("{out}: {w}x{h}, white at luminance {white:.4e} (99th percentile)");
    Ok(())
}
