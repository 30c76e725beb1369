//! PNG previews of a scalar field on a slice: the field itself, histogram-equalised and colour-coded
//! along a CIELAB ramp, and its Sobel gradient with direction as chromaticity and magnitude as
//! lightness (the two views of the paper's section 6.2).
//!
//! Conventions shared by every function here:
//! - A field is `width * height` values stored row by row; **row 0 is the bottom row** of the slice
//!   (the slice's v axis points up). [`write_png`] flips rows so that the picture shows v up; no other
//!   function flips anything. Consequently the `gy` of [`sobel`] is the derivative along +v (towards
//!   larger row indices, i.e. up in the picture).
//! - A cell takes part only if its `valid` flag is set **and** its value is finite; NaN and ±Inf are
//!   treated exactly like cells flagged invalid. Missing entries (a `valid` or `values` slice shorter
//!   than the field) are also invalid, so mismatched lengths never panic.
//! - Invalid cells are painted [`INVALID_RGB`], a neutral grey that neither colour map produces at
//!   full chroma, so holes in the domain stay recognisable.
//!
//! Colour: all colours are designed in CIELAB (D65) and converted to 8-bit sRGB with `palette`.
//! Colours outside the sRGB gamut are clipped by lowering chroma at constant L* and hue (bisection),
//! never by clamping channels, so lightness — the cue that carries order — is exactly preserved.
//!
//! `colormap` holds the field view (equalisation and the CIELAB colour map), `gradient` the
//! gradient view (Sobel filter and its colours); this module writes either as a PNG.

mod colormap;
mod gradient;

pub use colormap::{
    EQUALIZE_LINEAR_BLEND, FLAT_RELATIVE_TOLERANCE, equalize, field_colors, lab_colormap,
};
pub use gradient::{gradient_colors, sobel};

use crate::output::FileError;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Colour of invalid cells (outside the domain, or a non-finite value): neutral sRGB grey
/// (L* ≈ 54). Both colour maps give mid-lightness cells a clearly visible hue, so a grey without
/// chroma reads as "no data".
pub const INVALID_RGB: [u8; 3] = [128, 128, 128];

/// Whether cell `i` takes part: flagged valid, present in both slices, and finite.
#[inline]
fn cell_ok(values: &[f64], valid: &[bool], i: usize) -> bool {
    valid.get(i).copied().unwrap_or(false) && values.get(i).is_some_and(|v| v.is_finite())
}

/// Writes an 8-bit sRGB PNG of `width * height` pixels given in field order: `rgb[y * width + x]`
/// with **row 0 the bottom row**, so rows are flipped on output (v axis up in the picture).
///
/// The image is written to a hidden temporary file in the destination directory, flushed to disk and
/// renamed over `path`, so `path` is never seen half-written; on failure the temporary file is
/// removed. Errors if a dimension is 0 or too large for PNG, or `rgb.len() != width * height`.
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    rgb: &[[u8; 3]],
) -> Result<(), FileError> {
    if width == 0 || height == 0 {
        return Err(FileError::unfit(
            path,
            format!("empty PNG image ({width}x{height})"),
        ));
    }
    const PNG_MAX: usize = (1 << 31) - 1;
    if width > PNG_MAX || height > PNG_MAX {
        return Err(FileError::unfit(
            path,
            format!("{width}x{height} exceeds the PNG size limit"),
        ));
    }
    if width.checked_mul(height) != Some(rgb.len()) {
        return Err(FileError::unfit(
            path,
            format!("{} pixels given for a {width}x{height} PNG", rgb.len()),
        ));
    }
    let mut data = Vec::with_capacity(rgb.len() * 3);
    for row in rgb.chunks_exact(width).rev() {
        data.extend(row.iter().flatten());
    }

    if path.file_name().is_none() {
        return Err(FileError::unfit(path, "not a file path for a PNG"));
    }
    crate::output::write_file_atomically(path, |tmp| {
        write_png_file(tmp, width as u32, height as u32, &data).map_err(|e| match e {
            png::EncodingError::IoError(source) => FileError::write(path, source),
            e => FileError::encode(path, e),
        })
    })
}

/// Encodes packed RGB8 rows (top row first) to `path` and syncs the file.
fn write_png_file(
    path: &Path,
    width: u32,
    height: u32,
    data: &[u8],
) -> Result<(), png::EncodingError> {
    let file = File::create(path)?;
    let mut out = BufWriter::new(file);
    encode_rows(&mut out, width, height, data)?;
    out.flush()?;
    out.get_ref().sync_all()?;
    Ok(())
}

/// Encodes packed RGB8 rows (top row first) as an 8-bit sRGB PNG into `out`.
fn encode_rows(
    out: impl Write,
    width: u32,
    height: u32,
    data: &[u8],
) -> Result<(), png::EncodingError> {
    let mut encoder = png::Encoder::new(out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(data)?;
    writer.finish()
}

/// The bytes of the PNG that [`write_png`] writes for the same pixels (row 0 the bottom row), in
/// memory (the live view serves them). Errors where `write_png` would refuse the image.
pub fn png_bytes(width: usize, height: usize, rgb: &[[u8; 3]]) -> Result<Vec<u8>, String> {
    if width == 0 || height == 0 || width.checked_mul(height) != Some(rgb.len()) {
        return Err(format!("{} pixels for a {width}x{height} PNG", rgb.len()));
    }
    let (w, h) = (
        u32::try_from(width).map_err(|e| e.to_string())?,
        u32::try_from(height).map_err(|e| e.to_string())?,
    );
    let mut data = Vec::with_capacity(rgb.len() * 3);
    for row in rgb.chunks_exact(width).rev() {
        data.extend(row.iter().flatten());
    }
    let mut out = Vec::new();
    encode_rows(&mut out, w, h, &data).map_err(|e| e.to_string())?;
    Ok(out)
}

/// Writes the field view ([`field_colors`]) of a field as a PNG (see [`write_png`]).
pub fn write_field_preview(
    path: &Path,
    values: &[f64],
    valid: &[bool],
    width: usize,
    height: usize,
) -> Result<(), FileError> {
    write_png(
        path,
        width,
        height,
        &field_colors(values, valid, width, height),
    )
}

/// Writes the gradient view ([`gradient_colors`]) of a field as a PNG (see [`write_png`]).
pub fn write_gradient_preview(
    path: &Path,
    values: &[f64],
    valid: &[bool],
    width: usize,
    height: usize,
) -> Result<(), FileError> {
    write_png(
        path,
        width,
        height,
        &gradient_colors(values, valid, width, height),
    )
}

/// Helpers of the tests of this module and its submodules.
#[cfg(test)]
mod test_support {
    use palette::convert::FromColorUnclamped;
    use palette::white_point::D65;
    use palette::{Lab, Srgb};

    /// Deterministic xorshift64* uniform in [0, 1) for test data.
    pub(super) struct Rng(pub(super) u64);
    impl Rng {
        pub(super) fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    pub(super) fn lab_of(rgb: [f64; 3]) -> Lab<D65, f64> {
        Lab::from_color_unclamped(Srgb::new(rgb[0], rgb[1], rgb[2]))
    }

    pub(super) fn lab_of_u8(c: [u8; 3]) -> Lab<D65, f64> {
        lab_of(c.map(|x| x as f64 / 255.0))
    }
}

#[cfg(test)]
mod tests {
    use super::colormap::{lab_to_srgb_clipped, to_u8};
    use super::gradient::gradient_lab;
    use super::test_support::Rng;
    use super::*;

    /// A fresh empty directory under the system temp dir.
    fn test_dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("ftpd3d-png-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn png_round_trip_flips_rows() {
        let dir = test_dir("roundtrip");
        let path = dir.join("img.png");
        let (w, h) = (3, 2);
        // Row 0 (bottom) is red-ish, row 1 (top) blue-ish; every pixel distinct.
        let rgb: Vec<[u8; 3]> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as u8, (i / w) as u8);
                [200 - 100 * y, 10 * x, 50 + 100 * y]
            })
            .collect();
        write_png(&path, w, h, &rgb).unwrap();
        // Overwriting an existing file works too.
        write_png(&path, w, h, &rgb).unwrap();

        let file = std::io::BufReader::new(File::open(&path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (w as u32, h as u32));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        for img_y in 0..h {
            for x in 0..w {
                let o = img_y * info.line_size + 3 * x;
                let field_y = h - 1 - img_y;
                assert_eq!(buf[o..o + 3], rgb[field_y * w + x], "pixel ({x}, {img_y})");
            }
        }
        // Only the final file remains: no temporary left behind.
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("img.png")]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn png_errors_are_reported_not_panicked() {
        let dir = test_dir("errors");
        let p = dir.join("x.png");
        assert!(write_png(&p, 0, 3, &[]).is_err());
        assert!(write_png(&p, 2, 2, &[[0; 3]; 3]).is_err());
        // Missing folders are created; a file where a folder should be is an error.
        std::fs::write(dir.join("blocker"), b"").unwrap();
        assert!(write_png(&dir.join("blocker/x.png"), 1, 1, &[[0; 3]]).is_err());
        assert!(write_png(Path::new("/"), 1, 1, &[[0; 3]]).is_err());
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "only the blocker"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes example previews to /tmp/ftpd3d-png-preview for a person to look at:

    #[test]
    #[ignore = "writes example images to /tmp for visual inspection"]
    fn render_example_previews() {
        let dir = Path::new("/tmp/ftpd3d-png-preview");
        std::fs::create_dir_all(dir).unwrap();
        let (w, h) = (320, 240);
        let mut rng = Rng(7);
        let mut step = Vec::with_capacity(w * h);
        let mut radial = Vec::with_capacity(w * h);
        let mut valid = Vec::with_capacity(w * h);
        for i in 0..w * h {
            let (x, y) = ((i % w) as f64 / w as f64, (i / w) as f64 / h as f64);
            // A smooth background with a jump along a slanted line and a kink (first-order
            // discontinuity) along a vertical one, plus a little noise, FTPD-like in range.
            let jump = if y > 0.3 + 0.4 * x { 3.0 } else { 0.0 };
            let kink = 4.0 * (x - 0.7).max(0.0);
            step.push((1.0 + 2.0 * x + y * y + jump + kink) * 10f64.powf(y) + 0.02 * rng.next());
            let r =
                ((x - 0.5).powi(2) + (y - 0.5).powi(2) * (h * h) as f64 / (w * w) as f64).sqrt();
            radial.push((-12.0 * r * r).exp() + 0.3 * (30.0 * r).cos() * (-4.0 * r).exp());
            // A hole (e.g. inside an object) and a NaN.
            valid.push(((x - 0.2).powi(2) + (y - 0.75).powi(2)).sqrt() > 0.08);
        }
        step[5] = f64::NAN;
        write_field_preview(&dir.join("step_field.png"), &step, &valid, w, h).unwrap();
        write_gradient_preview(&dir.join("step_grad.png"), &step, &valid, w, h).unwrap();
        write_field_preview(&dir.join("radial_field.png"), &radial, &valid, w, h).unwrap();
        write_gradient_preview(&dir.join("radial_grad.png"), &radial, &valid, w, h).unwrap();
        // Colour bar: t along x, bottom half the colour map, top half a direction/magnitude wheel.
        let (bw, bh) = (256, 64);
        let bar: Vec<f64> = (0..bw * bh).map(|i| (i % bw) as f64).collect();
        write_field_preview(
            &dir.join("colorbar.png"),
            &bar,
            &vec![true; bw * bh],
            bw,
            bh,
        )
        .unwrap();
        let wheel: Vec<[u8; 3]> = (0..128 * 128)
            .map(|i| {
                let (x, y) = ((i % 128) as f64 - 63.5, (i / 128) as f64 - 63.5);
                let m = (x.hypot(y) / 63.5).min(1.0);
                let (l, a, b) = gradient_lab(m, y.atan2(x));
                to_u8(lab_to_srgb_clipped(l, a, b))
            })
            .collect();
        write_png(&dir.join("gradient_wheel.png"), 128, 128, &wheel).unwrap();
    }
}
