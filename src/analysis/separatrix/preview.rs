//! Pictures of the lines: SVG over the grid, and σ's preview with the lines drawn over it (PNG).

use super::{LineKind, Separatrices};
use anyhow::Context;
use std::fmt::Write as _;
use std::path::Path;

/// Writes the polylines as SVG over the grid (one user unit per cell, y up as in the field).
pub fn write_svg(path: &Path, sep: &Separatrices) -> anyhow::Result<()> {
    let (w, h) = (sep.dims[0], sep.dims[1]);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {w} {h}\" width=\"{}\" \
         height=\"{}\">",
        w * 4,
        h * 4
    );
    let _ = writeln!(
        s,
        "<title>separatrices: scale {:.3} cells, tau {:e}, Z {}</title>",
        sep.scale, sep.tau, sep.z_threshold
    );
    let _ = writeln!(
        s,
        "<rect width=\"{w}\" height=\"{h}\" fill=\"white\" stroke=\"#888\" stroke-width=\"0.2\"/>"
    );
    for l in &sep.lines {
        let colour = match l.kind {
            LineKind::Jump => "#8e24aa",
            LineKind::Ridge => "#fb8c00",
        };
        let pts: Vec<String> = l
            .points
            .iter()
            .map(|p| format!("{:.3},{:.3}", p[0], h as f64 - p[1]))
            .collect();
        let _ = writeln!(
            s,
            "<polyline class=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"0.4\" \
             points=\"{}\"/>",
            l.kind.name(),
            pts.join(" ")
        );
    }
    let _ = writeln!(s, "</svg>");
    crate::output::write_atomically(path, |tmp| {
        std::fs::write(tmp, s.as_bytes()).with_context(|| format!("writing {}", tmp.display()))
    })
}

/// σ's preview with the lines drawn over it (jump lines magenta, ridges orange), upscaled so that
/// the longer side has at least 512 pixels.
pub fn write_overlay_png(
    path: &Path,
    sigma: &[f64],
    valid: &[bool],
    sep: &Separatrices,
) -> anyhow::Result<()> {
    let (bw, bh, img) = overlay_colors(sigma, valid, sep);
    Ok(crate::output::png::write_png(path, bw, bh, &img)?)
}

/// The pixels of [`write_overlay_png`]'s picture: width, height and colours (row 0 the bottom).
pub fn overlay_colors(
    sigma: &[f64],
    valid: &[bool],
    sep: &Separatrices,
) -> (usize, usize, Vec<[u8; 3]>) {
    let (w, h) = (sep.dims[0], sep.dims[1]);
    let base = crate::output::png::field_colors(sigma, valid, w, h);
    let f = (512 / w.max(h).max(1)).max(1);
    let (bw, bh) = (w * f, h * f);
    let mut img = vec![[0u8; 3]; bw * bh];
    for (y, row) in img.chunks_exact_mut(bw).enumerate() {
        for (x, px) in row.iter_mut().enumerate() {
            *px = base[(x / f) + w * (y / f)];
        }
    }
    let mut dot = |x: f64, y: f64, c: [u8; 3]| {
        let (px, py) = (
            (x * f as f64).floor() as isize,
            (y * f as f64).floor() as isize,
        );
        let r = (f as isize / 4).max(0);
        for dy in -r..=r {
            for dx in -r..=r {
                let (a, b) = (px + dx, py + dy);
                if a >= 0 && b >= 0 && (a as usize) < bw && (b as usize) < bh {
                    img[a as usize + bw * b as usize] = c;
                }
            }
        }
    };
    for l in &sep.lines {
        let c = match l.kind {
            LineKind::Jump => [230, 0, 230],
            LineKind::Ridge => [255, 140, 0],
        };
        for seg in l.points.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let steps = (((b[0] - a[0]).abs().max((b[1] - a[1]).abs())) * f as f64 * 2.0)
                .ceil()
                .max(1.0) as usize;
            for s in 0..=steps {
                let t = s as f64 / steps as f64;
                dot(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), c);
            }
        }
        if let [p] = l.points.as_slice() {
            dot(p[0], p[1], c);
        }
    }
    (bw, bh, img)
}
