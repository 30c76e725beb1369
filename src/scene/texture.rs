//! Textures: images decoded once, shared by every material that names them, looked up bilinearly
//! at a hit's interpolated UV.
//!
//! - Formats: PNG, JPEG, TGA and Radiance HDR through the `image` crate (only those codecs are
//!   compiled in), OpenEXR through `exr`.
//! - Colour textures (base colour, diffuse, emission, specular) in 8-bit formats are sRGB-encoded
//!   and decoded to linear with the exact sRGB transfer function; HDR and EXR texels are linear
//!   already. Data textures (alpha, metallic-roughness) are read as stored.
//! - Lookup: `(u, v)` with v up (OBJ's and glTF's conventions differ: glTF's v points down, and its
//!   loader flips it), wrapped per axis (repeat, clamp to edge, mirrored repeat, as glTF's sampler
//!   says), then bilinear between the four nearest texel centres.
//! - A [`TextureSet`] decodes each file once, in parallel, and reports the memory the texels take.
//! - Storage: 8-bit images keep their bytes (4 B per texel) and are decoded at lookup through a
//!   256-entry table (the same f32 values a decode at load gave); 16-bit and float images are
//!   kept as linear f32 RGBA (16 B per texel). A scene of hundreds of 8-bit textures so takes a
//!   quarter of the memory it would as floats.

use crate::math::Rgb;
use crate::scene::error::ImageError;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How a coordinate outside [0, 1] is brought back (glTF sampler wrap modes; OBJ repeats).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    #[default]
    Repeat,
    ClampToEdge,
    MirroredRepeat,
}

impl Wrap {
    /// The texel index for the (possibly out-of-range) integer index `i` of an axis of `n` texels.
    #[inline]
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        };
        k as usize
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1): an 8-bit-encoded value in [0, 1] to
/// linear.
#[inline]
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A decoded image: linear RGB and alpha per texel, row-major from the top row.
#[derive(Clone, PartialEq)]
pub struct Texture {
    pub width: usize,
    pub height: usize,
    texels: Texels,
    pub source: String,
    /// The channels the image has: 1 grey, 2 grey and alpha, 3 RGB, 4 RGBA.
    pub channels: u8,
    /// What the decode changed, for the loader's warnings (each names the image): texels that
    /// were negative or not finite, set to 0.
    pub notes: Vec<String>,
}

/// How a texture's texels are stored.
#[derive(Clone, PartialEq)]
enum Texels {
    /// Linear RGBA (16 B per texel).
    Float(Vec<[f32; 4]>),
    /// 8-bit RGBA as stored in the file (4 B per texel); colour channels sRGB-encoded when `srgb`.
    Byte { rgba: Vec<[u8; 4]>, srgb: bool },
}

/// The values 8-bit texels decode to: [sRGB-decoded, as stored], for byte values 0..=255; the
/// same expressions a decode of the whole image at load used (`image`'s u8 → f32 is c / 255).
fn byte_tables() -> &'static [[f32; 256]; 2] {
    static TABLES: std::sync::OnceLock<[[f32; 256]; 2]> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| {
        let stored: [f32; 256] = std::array::from_fn(|c| c as f32 / 255.0);
        [stored.map(|v| srgb_to_linear(v as f64) as f32), stored]
    })
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Texture({}, {}×{})",
            self.source, self.width, self.height
        )
    }
}

/// What a texture's values mean, which decides whether 8-bit values are sRGB-decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// Colours: 8-bit values are sRGB.
    Colour,
    /// Data (alpha, roughness): values as stored.
    Linear,
}

impl Texture {
    /// From RGBA texels (row-major from the top). Colour channels that are negative or not
    /// finite become 0 (light is never negative), alpha is brought into [0, 1] (1 where it is
    /// not a number); a note says how many texels changed.
    pub fn new(
        width: usize,
        height: usize,
        mut texels: Vec<[f32; 4]>,
        source: &str,
    ) -> Result<Texture, ImageError> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(ImageError::Invalid {
                name: Some(source.to_string()),
                what: "a texture needs at least one texel".into(),
            });
        }
        let mut changed = 0usize;
        for t in &mut texels {
            let before = *t;
            for c in &mut t[..3] {
                if !(*c >= 0.0 && c.is_finite()) {
                    *c = 0.0;
                }
            }
            t[3] = if t[3].is_nan() {
                1.0
            } else {
                t[3].clamp(0.0, 1.0)
            };
            changed += (before.map(f32::to_bits) != t.map(f32::to_bits)) as usize;
        }
        let notes = if changed > 0 {
            vec![format!(
                "{source}: {changed} of {} texels had negative or non-finite values, set to 0 \
                 (alpha into [0, 1])",
                texels.len()
            )]
        } else {
            Vec::new()
        };
        Ok(Texture {
            width,
            height,
            texels: Texels::Float(texels),
            source: source.to_string(),
            channels: 4,
            notes,
        })
    }

    /// Linear RGBA of texel `i` (row-major from the top).
    #[inline]
    pub fn texel(&self, i: usize) -> [f32; 4] {
        match &self.texels {
            Texels::Float(t) => t[i],
            Texels::Byte { rgba, srgb } => {
                let tables = byte_tables();
                let colour = &tables[if *srgb { 0 } else { 1 }];
                let [r, g, b, a] = rgba[i];
                [
                    colour[r as usize],
                    colour[g as usize],
                    colour[b as usize],
                    tables[1][a as usize],
                ]
            }
        }
    }

    /// True when every texel's red, green and blue are equal (a grey image, whatever its
    /// channel count).
    pub fn is_grey(&self) -> bool {
        match &self.texels {
            Texels::Float(t) => t.iter().all(|p| p[0] == p[1] && p[1] == p[2]),
            Texels::Byte { rgba, .. } => rgba.iter().all(|p| p[0] == p[1] && p[1] == p[2]),
        }
    }

    /// True when some texel's alpha is below 1 (the image has a coverage channel in use).
    pub fn has_partial_alpha(&self) -> bool {
        match &self.texels {
            Texels::Float(t) => t.iter().any(|p| p[3] < 1.0),
            Texels::Byte { rgba, .. } => rgba.iter().any(|p| p[3] < 255),
        }
    }

    /// Decodes `path`: PNG, JPEG, TGA, HDR through `image`, EXR through `exr`. Only a regular
    /// file is opened.
    pub fn load(path: &Path, encoding: Encoding) -> Result<Texture, ImageError> {
        let name = path.display().to_string();
        regular(path)?;
        let ext = crate::scene::files::extension(path);
        if ext.as_deref() == Some("exr") {
            let exr = crate::scene::files::read_exr(path).map_err(|source| ImageError::Decode {
                name: Some(name.clone()),
                what: "cannot read as an OpenEXR image",
                source,
            })?;
            let mut t = Texture::new(exr.width, exr.height, exr.rgba, &name)?;
            t.channels = exr.channels;
            return Ok(t);
        }
        let mut head = [0u8; 16];
        let n = std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
            .map_err(ImageError::failed(&name, "cannot open"))?;
        if let Some(format) = undecoded_format(&head[..n]) {
            return Err(not_decoded(Some(name), format));
        }
        let mut reader = image::ImageReader::open(path)
            .map_err(ImageError::failed(&name, "cannot open"))?
            .with_guessed_format()
            .map_err(ImageError::failed(&name, "cannot read"))?;
        reader.limits(decoder_limits());
        let img = reader.decode().map_err(|e| decode_error(Some(&name), e))?;
        // 8-bit and 16-bit images are encoded; float images (HDR) are linear.
        Texture::from_image(img, &name, encoding)
    }

    /// Decodes an image held in memory (PNG, JPEG, TGA, HDR), e.g. a glTF buffer view; `name`
    /// becomes the texture's [`source`](Texture::source). Errors name no file (the bytes have
    /// none): their holder says whose they are.
    pub fn from_bytes(bytes: &[u8], name: &str, encoding: Encoding) -> Result<Texture, ImageError> {
        if let Some(format) = undecoded_format(bytes) {
            return Err(not_decoded(None, format));
        }
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| ImageError::Decode {
                name: None,
                what: "cannot read",
                source: Box::new(e),
            })?;
        reader.limits(decoder_limits());
        let img = reader.decode().map_err(|e| decode_error(None, e))?;
        Texture::from_image(img, name, encoding).map_err(ImageError::unnamed)
    }

    /// Linear RGBA texels of a decoded image (8- and 16-bit colour textures are sRGB).
    fn from_image(
        img: image::DynamicImage,
        name: &str,
        encoding: Encoding,
    ) -> Result<Texture, ImageError> {
        let (w, h) = (img.width() as usize, img.height() as usize);
        let channels = img.color().channel_count();
        if matches!(
            img.color(),
            image::ColorType::L8
                | image::ColorType::La8
                | image::ColorType::Rgb8
                | image::ColorType::Rgba8
        ) {
            if w == 0 || h == 0 {
                return Err(ImageError::Invalid {
                    name: Some(name.to_string()),
                    what: "a texture needs at least one texel".into(),
                });
            }
            let rgba = img.into_rgba8().pixels().map(|p| p.0).collect();
            return Ok(Texture {
                width: w,
                height: h,
                texels: Texels::Byte {
                    rgba,
                    srgb: encoding == Encoding::Colour,
                },
                source: name.to_string(),
                channels,
                notes: Vec::new(),
            });
        }
        let encoded = !matches!(
            img.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgba = img.into_rgba32f();
        let decode = |c: f32| {
            if encoded && encoding == Encoding::Colour {
                srgb_to_linear(c as f64) as f32
            } else {
                c
            }
        };
        let texels = rgba
            .pixels()
            .map(|p| [decode(p[0]), decode(p[1]), decode(p[2]), p[3]])
            .collect();
        let mut t = Texture::new(w, h, texels, name)?;
        t.channels = channels;
        Ok(t)
    }

    /// Bytes the texels take.
    pub fn bytes(&self) -> usize {
        match &self.texels {
            Texels::Float(t) => t.len() * std::mem::size_of::<[f32; 4]>(),
            Texels::Byte { rgba, .. } => rgba.len() * 4,
        }
    }

    /// Bilinear RGBA at `(u, v)` (v up), with each axis wrapped by `wrap`.
    #[inline]
    pub fn lookup(&self, u: f64, v: f64, wrap: (Wrap, Wrap)) -> [f64; 4] {
        // Texel centres sit at (i + ½)/w; the top row is v = 1.
        let x = u * self.width as f64 - 0.5;
        let y = (1.0 - v) * self.height as f64 - 0.5;
        let (x, y) = (
            if x.is_finite() { x } else { 0.0 },
            if y.is_finite() { y } else { 0.0 },
        );
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // Far outside the texture the index saturates; the wrap brings it back either way.
        let (xi, yi) = (x0.clamp(-1e15, 1e15) as i64, y0.clamp(-1e15, 1e15) as i64);
        let ix = [
            wrap.0.index(xi, self.width),
            wrap.0.index(xi + 1, self.width),
        ];
        let iy = [
            wrap.1.index(yi, self.height),
            wrap.1.index(yi + 1, self.height),
        ];
        let mut out = [0.0; 4];
        for (j, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (i, wx) in [(0, 1.0 - fx), (1, fx)] {
                let t = self.texel(iy[j] * self.width + ix[i]);
                for c in 0..4 {
                    out[c] += wx * wy * t[c] as f64;
                }
            }
        }
        out
    }

    /// The RGB of [`lookup`](Self::lookup).
    #[inline]
    pub fn rgb(&self, u: f64, v: f64, wrap: (Wrap, Wrap)) -> Rgb {
        let [r, g, b, _] = self.lookup(u, v, wrap);
        Rgb::new(r, g, b)
    }
}

/// The memory the image decoder may use for one image: 4 GiB (a 16K × 16K RGBA image of 16-bit
/// channels takes 2 GiB), or `FTPD3D_IMAGE_LIMIT_GIB` gibibytes. The `image` crate's default of
/// 512 MiB refuses a 16K texture of 8-bit RGBA (1 GiB).
pub fn image_memory_limit() -> u64 {
    let gib = std::env::var(IMAGE_LIMIT_VAR)
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|g| *g > 0.0 && g.is_finite())
        .unwrap_or(4.0);
    (gib * (1u64 << 30) as f64).min(u64::MAX as f64) as u64
}

/// The environment variable that sets [`image_memory_limit`].
pub const IMAGE_LIMIT_VAR: &str = "FTPD3D_IMAGE_LIMIT_GIB";

fn decoder_limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(image_memory_limit());
    limits
}

/// A decode failure; one that exceeds the memory limit says which limit and how to raise it.
fn decode_error(name: Option<&str>, e: image::ImageError) -> ImageError {
    if let image::ImageError::Limits(_) = e {
        let gib = image_memory_limit() as f64 / (1u64 << 30) as f64;
        return ImageError::Invalid {
            name: name.map(str::to_string),
            what: format!(
                "needs more memory than the image decoder's limit of {gib} GiB; set \
                 {IMAGE_LIMIT_VAR} to a larger number of GiB to raise it"
            ),
        };
    }
    ImageError::Decode {
        name: name.map(str::to_string),
        what: "cannot decode (PNG, JPEG, TGA, HDR or EXR)",
        source: Box::new(e),
    }
}

/// Image formats recognised by their first bytes that this build does not decode.
fn undecoded_format(head: &[u8]) -> Option<&'static str> {
    const KTX2: &[u8] = b"\xABKTX 20\xBB\r\n\x1A\n";
    const KTX1: &[u8] = b"\xABKTX 11\xBB\r\n\x1A\n";
    if head.starts_with(KTX2) {
        Some("KTX2 (Basis Universal or GPU-compressed)")
    } else if head.starts_with(KTX1) {
        Some("KTX")
    } else if head.starts_with(b"RIFF") && head.get(8..12) == Some(b"WEBP") {
        Some("WebP")
    } else if head
        .get(4..12)
        .is_some_and(|b| b == b"ftypavif" || b == b"ftypavis")
    {
        Some("AVIF")
    } else if head.starts_with(b"DDS ") {
        Some("DDS")
    } else {
        None
    }
}

fn not_decoded(name: Option<String>, format: &str) -> ImageError {
    ImageError::Invalid {
        name,
        what: format!(
            "a {format} image, a format this build does not decode (PNG, JPEG, TGA, HDR and EXR \
             are)"
        ),
    }
}

/// Refuses what is not a regular file before it is opened (a FIFO would block the load).
pub fn regular(path: &Path) -> Result<(), ImageError> {
    match crate::scene::files::not_regular(path) {
        Some(kind) => Err(ImageError::NotRegular {
            name: path.display().to_string(),
            kind,
        }),
        None => Ok(()),
    }
}

/// A texture coordinate transform (glTF's `KHR_texture_transform`): scale, then rotate by
/// `rotation` radians (see [`apply`](Self::apply) for the sense), then offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub offset: [f64; 2],
    pub rotation: f64,
    pub scale: [f64; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform {
            offset: [0.0, 0.0],
            rotation: 0.0,
            scale: [1.0, 1.0],
        }
    }
}

impl UvTransform {
    /// The extension's `T · R · S` applied to `(u, v)` in glTF's UV space (v down):
    /// `u' = cos·u + sin·v`, `v' = −sin·u + cos·v` after the scale, then the offset. This is the
    /// turn the extension's worked example (offset (0, 1), rotation π/2, scale ½ uses the lower
    /// left quadrant, turned clockwise), its sample model TextureTransformTest and the common
    /// implementations agree on; the GLSL matrix in its text, read column-major, would turn the
    /// other way.
    #[inline]
    pub fn apply(&self, u: f64, v: f64) -> (f64, f64) {
        let (su, sv) = (u * self.scale[0], v * self.scale[1]);
        let (s, c) = self.rotation.sin_cos();
        (
            c * su + s * sv + self.offset[0],
            -s * su + c * sv + self.offset[1],
        )
    }
}

/// Every texture of a scene, each file decoded once.
#[derive(Clone, Debug, Default)]
pub struct TextureSet {
    pub textures: Vec<Arc<Texture>>,
}

impl TextureSet {
    /// Decodes the distinct `(path, encoding)` pairs in parallel; returns the set and, for each
    /// request, the index of its texture. Errors name the file (and the first that failed).
    pub fn load(requests: &[(PathBuf, Encoding)]) -> Result<(TextureSet, Vec<usize>), ImageError> {
        let mut distinct: Vec<(PathBuf, Encoding)> = Vec::new();
        let mut index: HashMap<(PathBuf, Encoding), usize> = HashMap::new();
        let ids: Vec<usize> = requests
            .iter()
            .map(|r| {
                *index.entry(r.clone()).or_insert_with(|| {
                    distinct.push(r.clone());
                    distinct.len() - 1
                })
            })
            .collect();
        let textures = distinct
            .par_iter()
            .map(|(p, e)| Texture::load(p, *e).map(Arc::new))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((TextureSet { textures }, ids))
    }

    /// Bytes all texels take.
    pub fn bytes(&self) -> usize {
        self.textures.iter().map(|t| t.bytes()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_matches_the_standard() {
        // IEC 61966-2-1 values: 0 → 0, 1 → 1, 0.5 → 0.21404, the linear segment below 0.04045.
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-15);
        assert!((srgb_to_linear(0.5) - 0.214_041_140_482_232_54).abs() < 1e-12);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-18);
        // Continuous at the joint (to the standard's rounding of its constants).
        let (a, b) = (srgb_to_linear(0.04045), srgb_to_linear(0.040_450_001));
        assert!((a - b).abs() < 1e-6);
    }

    #[test]
    fn bilinear_lookup_hits_texel_centres_and_interpolates_between() {
        // 2 × 2: top row (v = 1) is 0 and 1, bottom row 2 and 3 in every channel.
        let t = Texture::new(
            2,
            2,
            [0.0, 1.0, 2.0, 3.0]
                .iter()
                .map(|&x| [x, x, x, 1.0])
                .collect(),
            "t",
        )
        .unwrap();
        let c = (Wrap::ClampToEdge, Wrap::ClampToEdge);
        assert_eq!(t.lookup(0.25, 0.75, c)[0], 0.0);
        assert_eq!(t.lookup(0.75, 0.75, c)[0], 1.0);
        assert_eq!(t.lookup(0.25, 0.25, c)[0], 2.0);
        assert_eq!(t.lookup(0.75, 0.25, c)[0], 3.0);
        assert!((t.lookup(0.5, 0.5, c)[0] - 1.5).abs() < 1e-15);
        assert!((t.lookup(0.5, 0.75, c)[0] - 0.5).abs() < 1e-15);
        // Clamped beyond the edge; repeated: u = 1.25 is u = 0.25.
        assert_eq!(t.lookup(-3.0, 0.75, c)[0], 0.0);
        let r = (Wrap::Repeat, Wrap::Repeat);
        assert_eq!(t.lookup(1.25, 0.75, r), t.lookup(0.25, 0.75, r));
        // At u = 0 with repeat, half of each edge column.
        assert!((t.lookup(0.0, 0.75, r)[0] - 0.5).abs() < 1e-15);
        // Mirrored: u = 1.25 is u = 0.75.
        let m = (Wrap::MirroredRepeat, Wrap::MirroredRepeat);
        assert_eq!(t.lookup(1.25, 0.75, m), t.lookup(0.75, 0.75, m));
        // Non-finite coordinates give a texel, not a NaN.
        assert!(t.lookup(f64::NAN, f64::INFINITY, r)[0].is_finite());
    }

    #[test]
    fn wrap_modes_index_as_gltf_defines() {
        let n = 4;
        let idx = |w: Wrap| (-5..9).map(|i| w.index(i, n)).collect::<Vec<_>>();
        assert_eq!(
            idx(Wrap::Repeat),
            [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]
        );
        assert_eq!(
            idx(Wrap::ClampToEdge),
            [0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3]
        );
        assert_eq!(
            idx(Wrap::MirroredRepeat),
            [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]
        );
    }

    #[test]
    fn uv_transform_follows_khr_texture_transform() {
        // The extension's example: offset (0, 1), rotation π/2, scale ½ maps the unit square onto
        // the lower left quadrant (u ∈ [0, ½], v ∈ [½, 1], v down), turned clockwise: (1, 0) is
        // scaled to (½, 0), turned to (0, −½), offset to (0, ½); (0, 1) to (0, ½), (½, 0), (½, 1).
        let t = UvTransform {
            offset: [0.0, 1.0],
            rotation: std::f64::consts::FRAC_PI_2,
            scale: [0.5, 0.5],
        };
        let (u, v) = t.apply(1.0, 0.0);
        assert!(u.abs() < 1e-15 && (v - 0.5).abs() < 1e-15, "({u}, {v})");
        let (u, v) = t.apply(0.0, 1.0);
        assert!(
            (u - 0.5).abs() < 1e-15 && (v - 1.0).abs() < 1e-15,
            "({u}, {v})"
        );
        let (u, v) = t.apply(1.0, 1.0);
        assert!(
            (u - 0.5).abs() < 1e-15 && (v - 0.5).abs() < 1e-15,
            "({u}, {v})"
        );
        assert_eq!(UvTransform::default().apply(0.3, 0.7), (0.3, 0.7));
    }

    /// 8-bit storage decodes every byte to the f32 a decode of the whole image at load gives
    /// (`image`'s own u8 → f32, then the sRGB curve), bit for bit, for colour and data alike.
    #[test]
    fn byte_texels_decode_to_the_floats_of_a_full_decode() {
        let bytes: Vec<u8> = (0..=255u8)
            .flat_map(|c| [c, 255 - c, c / 2, 255 - c / 3])
            .collect();
        let img =
            image::DynamicImage::ImageRgba8(image::RgbaImage::from_raw(256, 1, bytes).unwrap());
        for encoding in [Encoding::Colour, Encoding::Linear] {
            let t = Texture::from_image(img.clone(), "ramp", encoding).unwrap();
            assert_eq!(t.bytes(), 256 * 4);
            let full = img.to_rgba32f();
            for (i, p) in full.pixels().enumerate() {
                let d = |c: f32| match encoding {
                    Encoding::Colour => srgb_to_linear(c as f64) as f32,
                    Encoding::Linear => c,
                };
                let want = [d(p[0]), d(p[1]), d(p[2]), p[3]];
                assert_eq!(
                    t.texel(i).map(f32::to_bits),
                    want.map(f32::to_bits),
                    "texel {i}"
                );
            }
        }
    }

    /// An image beyond the decoder's memory limit gets a message naming the limit and the
    /// variable that raises it; KTX2 bytes are named as such, not as undecodable PNG.
    #[test]
    fn limit_and_undecoded_formats_are_named() {
        let limit = image::ImageError::Limits(image::error::LimitError::from_kind(
            image::error::LimitErrorKind::InsufficientMemory,
        ));
        let msg = format!("{:#}", decode_error(Some("big.png"), limit));
        assert!(
            msg.contains("big.png") && msg.contains("GiB") && msg.contains(IMAGE_LIMIT_VAR),
            "{msg}"
        );
        assert!(image_memory_limit() >= 1 << 32 || std::env::var(IMAGE_LIMIT_VAR).is_ok());
        let ktx2 = b"\xABKTX 20\xBB\r\n\x1A\n\0\0\0\0";
        let e = Texture::from_bytes(ktx2, "t", Encoding::Colour).unwrap_err();
        assert!(format!("{e}").contains("KTX2"), "{e}");
    }

    #[test]
    fn png_textures_are_decoded_once_and_srgb_to_linear() {
        let dir = std::env::temp_dir().join(format!("ftpd3d-tex-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.png");
        // 2 × 1: sRGB 128 and 255.
        let img = image::RgbImage::from_raw(2, 1, vec![128, 128, 128, 255, 255, 255]).unwrap();
        img.save(&p).unwrap();
        let reqs = vec![
            (p.clone(), Encoding::Colour),
            (p.clone(), Encoding::Colour),
            (p.clone(), Encoding::Linear),
        ];
        let (set, ids) = TextureSet::load(&reqs).unwrap();
        assert_eq!(set.textures.len(), 2);
        assert_eq!(ids, [0, 0, 1]);
        let colour = &set.textures[0];
        let expect = srgb_to_linear(128.0 / 255.0);
        assert!((colour.texel(0)[0] as f64 - expect).abs() < 1e-6);
        assert_eq!(colour.texel(1)[0], 1.0);
        assert!((set.textures[1].texel(0)[0] as f64 - 128.0 / 255.0).abs() < 1e-6);
        // 8-bit images keep their bytes: 4 B per texel.
        assert_eq!(set.bytes(), 2 * 2 * 4);
        let missing = TextureSet::load(&[(dir.join("nope.png"), Encoding::Colour)]).unwrap_err();
        assert!(format!("{missing:#}").contains("nope.png"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
