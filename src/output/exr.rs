//! OpenEXR output of 2D fields (exr crate): a two-part file. Part 0 (`ftpd`) holds only f32 channels
//! named by quantity and the run's description ([`crate::run_info::RunInfo`]) as string header
//! attributes `ftpd3d.<key>`, so that every EXR reader (Blender, tev, OpenImageIO, Python OpenEXR,
//! and FreeImage, which reads only part 0, only when all its channels have one type, and only `R`,
//! `G`, `B`, `A` or `Y` of them) opens it as an image. Part 1 (`exact`) keeps the raw sums exact as
//! pairs of u32 channels holding the high and low 32 bits of each f64, with the exact sample and
//! batch counts: what merge and resume read. (Files of earlier versions, one part with everything,
//! still read.)
//!
//! | channel                      | type | meaning                                                  |
//! |------------------------------|------|----------------------------------------------------------|
//! | `ftpd`                       | f32  | σ (eq. 14); 0 where `valid` = 0                          |
//! | `R`, `G`, `B`                | f32  | σ again, as grey: what readers that know only colour images show (FreeImage) |
//! | `ftpd.mean`, `ftpd.m2`       | f32  | weighted mean and second moment of Δ                     |
//! | `ftpd.stderr`, `ftpd.relerr` | f32  | standard error of σ (delta method over independent groups of samples, skewness-corrected), /σ |
//! | `weight`                     | f32  | mean contribution weight ΣP / samples                    |
//! | `fluence.R/G/B`              | f32  | incident radiance integrated over the sphere (radiance weighting only) |
//! | `radiance.R/G/B`             | f32  | camera images: a path-traced beauty image along the same pixel rays |
//! | `samples`, `batches`         | f32  | samples taken at the cell, batches (passes) that sampled it (rounded above 2²⁴) |
//! | `valid`                      | f32  | 1 where σ is defined (ΣP > 0)                             |
//! | `sum.w`, `sum.wd`, `sum.wd2` | f32  | ΣP, ΣPΔ, ΣPΔ² rounded, for viewing                        |
//!
//! Part 1, `exact`:
//!
//! | channel                      | type | meaning                                                  |
//! |------------------------------|------|----------------------------------------------------------|
//! | `samples`, `batches`, `groups` | u32 | the exact counts (groups: the independent groups of samples the standard error is taken over) |
//! | `exact.<sum>.hi/.lo`         | u32  | the exact f64 bits of every sum (ΣP, ΣPΔ, ΣPΔ², their compensations, fluence, product sums over groups `sum.w.w` … `sum.wd2.wd2`, triple product sums `sum3.w.w.w` … `sum3.wd2.wd2.wd2`) |
//! | `exact.shift.rNN.<sum>.hi/.lo` | u32 | gradient-domain runs only (`ftpd3d.gradient.alpha`): per replicate `r00` … `r15` the samples (`n`), their sums (`w`, `wd`, `wd2`) and those of their replays at the upper neighbour along `x` and `y` (`x.w` … `y.wd2`), as f64 bits ([`crate::gradient_domain::Shift`]) |
//!
//! Image rows run top to bottom, so the first row is the plane's largest v.

use crate::field::Field;
use crate::ftpd::Weighting;
use crate::ftpd::moments::Moments;
use crate::output::exact::{EXACT, EXACT_COMP, ExactArrays, read_exact, read_shift, shift_columns};
use crate::output::{FileError, f32_of, write_file_atomically};
use crate::run_info::DomainKind;
use exr::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;
// The prelude brings `exr::Result`; the functions here return the room's errors.
use std::result::Result;

/// Writes a 2D field (depth 1) with optional extra f32 channels (e.g. `grad.x`), each one value per
/// cell in field order. Written to a temporary name, then renamed.
pub fn write_exr(path: &Path, field: &Field, extra: &[(&str, Vec<f64>)]) -> Result<(), FileError> {
    let (w, h) = (field.width, field.height);
    let view = view_channels(path, field, extra)?
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::F32(data)))
        .collect();
    let exact = exact_channels(path, field, &file_order(w, h))?;
    let header = header_attributes(path, &field.meta)?;
    let image = two_parts(w, h, header, view, exact);
    write_file_atomically(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| match e {
            exr::error::Error::Io(source) => FileError::write(path, source),
            e => FileError::encode(path, e),
        })
    })
}

/// Refuses a field an EXR cannot hold: a volume, or an empty grid.
pub(super) fn check_2d(path: &Path, field: &Field) -> Result<(), FileError> {
    let (w, h) = (field.width, field.height);
    if field.depth != 1 || w == 0 || h == 0 {
        return Err(FileError::unfit(
            path,
            format!("an EXR holds one 2D slice (got {w}x{h}x{})", field.depth),
        ));
    }
    Ok(())
}

/// The field index of each pixel in file order: field row 0 is the bottom (v minimal), EXR row 0
/// the top. (The map is its own inverse.)
fn file_order(w: usize, h: usize) -> Vec<usize> {
    (0..h)
        .rev()
        .flat_map(|j| (0..w).map(move |i| j * w + i))
        .collect()
}

type Channels = Vec<AnyChannel<FlatSamples>>;

/// Part 0's f32 channels of a 2D field (depth 1) as [`write_exr`] writes them, which calls it: σ
/// (and as grey), its moments and error, weight, validity, the rounded sums and counts, the
/// fluence or a camera's beauty image, and `extra` (one value per cell in field order). Each is
/// its name and one value per cell in file order (row 0 at the top, the plane's largest v), and
/// they come sorted by name, as the file lists them. The run's description (`field.meta`) decides
/// the colour channels; `path` names the field in errors. A front end that shows a field without
/// writing it gets the file's channels from here, bit for bit.
pub fn view_channels(
    path: &Path,
    field: &Field,
    extra: &[(&str, Vec<f64>)],
) -> Result<Vec<(String, Vec<f32>)>, FileError> {
    check_2d(path, field)?;
    let (w, h) = (field.width, field.height);
    // A malformed description is refused before anything is computed.
    let info = field.info(&path.display().to_string())?;
    let order = file_order(w, h);
    let vals = field.values();
    let per =
        |f: &dyn Fn(usize) -> f64| -> Vec<f32> { order.iter().map(|&k| f32_of(f(k))).collect() };
    let mut chans: Vec<(String, Vec<f32>)> = Vec::new();
    let mut f32ch = |name: &str, data: Vec<f32>| chans.push((name.to_string(), data));
    f32ch("ftpd", per(&|k| vals[k].sigma));
    // FreeImage's EXR loader knows only colour models (R,G,B[,A] or Y) and refuses a part whose
    // channels are all named otherwise ("Unsupported color model"): σ as grey.
    for c in ["R", "G", "B"] {
        f32ch(c, per(&|k| vals[k].sigma));
    }
    f32ch("ftpd.mean", per(&|k| vals[k].mean));
    f32ch("ftpd.m2", per(&|k| vals[k].m2));
    f32ch("ftpd.stderr", per(&|k| vals[k].stderr));
    f32ch("ftpd.relerr", per(&|k| vals[k].relative_error()));
    f32ch("weight", per(&|k| vals[k].weight));
    f32ch("valid", per(&|k| if vals[k].valid { 1.0 } else { 0.0 }));
    f32ch("sum.w", per(&|k| field.cells[k].sums().0));
    f32ch("sum.wd", per(&|k| field.cells[k].sums().1));
    f32ch("sum.wd2", per(&|k| field.cells[k].sums().2));
    f32ch("samples", per(&|k| field.cells[k].n as f64));
    f32ch("batches", per(&|k| field.cells[k].batches as f64));
    // Camera runs keep the beauty image's radiance in the fluence sums.
    let colour = if info.domain == Some(DomainKind::Camera) {
        Some("radiance")
    } else if info.weighting == Some(Weighting::Radiance) {
        Some("fluence")
    } else {
        None
    };
    if let Some(prefix) = colour {
        let fl: Vec<_> = field.cells.iter().map(Moments::fluence).collect();
        f32ch(&format!("{prefix}.R"), per(&|k| fl[k].x));
        f32ch(&format!("{prefix}.G"), per(&|k| fl[k].y));
        f32ch(&format!("{prefix}.B"), per(&|k| fl[k].z));
    }
    for (name, data) in extra {
        if data.len() != order.len() {
            return Err(FileError::unfit(
                path,
                format!(
                    "channel {name}: {} values for {} cells",
                    data.len(),
                    order.len()
                ),
            ));
        }
        f32ch(name, per(&|k| data[k]));
    }
    chans.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(chans)
}

/// Part 1's u32 channels of a 2D field as [`write_exr`] writes them: the exact counts (`samples`,
/// `batches`, `groups`) and the bits of every exact sum as hi/lo pairs (`exact.<sum>.hi/.lo`),
/// each in file order (row 0 at the top), in the order they are made (the file lists them sorted
/// by name).
pub fn exact_channel_values(
    path: &Path,
    field: &Field,
) -> Result<Vec<(String, Vec<u32>)>, FileError> {
    check_2d(path, field)?;
    exact_u32(path, field, &file_order(field.width, field.height))
}

/// Part 1's u32 channels: the exact counts, and the bits of every exact sum as hi/lo pairs.
fn exact_channels(path: &Path, field: &Field, order: &[usize]) -> Result<Channels, FileError> {
    Ok(exact_u32(path, field, order)?
        .into_iter()
        .map(|(name, data)| AnyChannel::new(name.as_str(), FlatSamples::U32(data)))
        .collect())
}

/// The exact counts and sums, by name, in `order`.
fn exact_u32(
    path: &Path,
    field: &Field,
    order: &[usize],
) -> Result<Vec<(String, Vec<u32>)>, FileError> {
    if let Some(c) = field.cells.iter().find(|c| c.n > u32::MAX as u64) {
        return Err(FileError::unfit(
            path,
            format!(
                "a cell holds {} samples, more than an EXR u32 channel can count",
                c.n
            ),
        ));
    }
    let cells = &field.cells;
    let per =
        |f: &dyn Fn(&Moments) -> u32| -> Vec<u32> { order.iter().map(|&k| f(&cells[k])).collect() };
    let mut chans: Vec<(String, Vec<u32>)> = Vec::new();
    let mut u32ch = |name: &str, data: Vec<u32>| chans.push((name.to_string(), data));
    u32ch("samples", per(&|c| c.n as u32));
    u32ch("batches", per(&|c| c.batches.min(u32::MAX as u64) as u32));
    u32ch("groups", per(&|c| c.groups as u32));
    for (name, get, _) in EXACT.iter().chain(EXACT_COMP) {
        u32ch(
            &format!("exact.{name}.hi"),
            per(&|c| (get(c).to_bits() >> 32) as u32),
        );
        u32ch(
            &format!("exact.{name}.lo"),
            per(&|c| get(c).to_bits() as u32),
        );
    }
    for c in shift_columns(path, field)? {
        let bits =
            |f: &dyn Fn(u64) -> u32| order.iter().map(|&k| f(c.value(k).to_bits())).collect();
        u32ch(&format!("exact.{}.hi", c.name), bits(&|b| (b >> 32) as u32));
        u32ch(&format!("exact.{}.lo", c.name), bits(&|b| b as u32));
    }
    Ok(chans)
}

/// The longest attribute name an EXR holds, in bytes (OpenEXR's limit for long names).
const MAX_NAME_BYTES: usize = 255;

/// Refuses a run description the EXR header cannot hold, naming the file and the attribute:
/// called before a run ([`crate::app`]) with the description it will write, and by the writer
/// itself, so that nothing fails after the run. Values are any text (written as UTF-8 bytes, the
/// encoding OpenEXR and its Python bindings read); an attribute name must be 1 to 255 bytes
/// without a NUL, and a value must fit the header's 32-bit size.
pub fn check_header(path: &Path, meta: &BTreeMap<String, String>) -> Result<(), FileError> {
    header_attributes(path, meta).map(drop)
}

/// The run's description as `ftpd3d.<key>` text attributes, each name and value as UTF-8 bytes
/// (see [`check_header`]).
fn header_attributes(
    path: &Path,
    meta: &BTreeMap<String, String>,
) -> Result<Vec<(Text, Text)>, FileError> {
    meta.iter()
        .map(|(k, v)| {
            let name = format!("ftpd3d.{k}");
            if name.len() > MAX_NAME_BYTES || name.contains('\0') {
                return Err(FileError::unfit(
                    path,
                    format!(
                        "header attribute {name:?}: an EXR attribute name is at most \
                         {MAX_NAME_BYTES} bytes without a NUL character"
                    ),
                ));
            }
            if i32::try_from(v.len()).is_err() {
                return Err(FileError::unfit(
                    path,
                    format!(
                        "header attribute {name}: {} bytes, more than an EXR attribute holds",
                        v.len()
                    ),
                ));
            }
            Ok((
                Text::from_slice_unchecked(name.as_bytes()),
                Text::from_slice_unchecked(v.as_bytes()),
            ))
        })
        .collect()
}

/// A text attribute as written: UTF-8, or (files of earlier versions, which wrote each character
/// below 256 as one byte) Latin-1.
fn attribute_text(t: &Text) -> String {
    match std::str::from_utf8(t.bytes()) {
        Ok(s) => s.to_string(),
        Err(_) => t.to_string(),
    }
}

/// The two-part image: `ftpd` (the view, with the run's description as `ftpd3d.<key>` text
/// attributes, [`header_attributes`]) and `exact`.
fn two_parts(
    w: usize,
    h: usize,
    header: Vec<(Text, Text)>,
    view: Channels,
    exact: Channels,
) -> Image<Layers<AnyChannels<FlatSamples>>> {
    let mut attrs = LayerAttributes::named("ftpd");
    for (name, value) in header {
        attrs.other.insert(name, AttributeValue::Text(value));
    }
    let view = Layer::new(
        (w, h),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(view.into()),
    );
    let exact = Layer::new(
        (w, h),
        LayerAttributes::named("exact"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(exact.into()),
    );
    Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((w, h))),
        vec![view, exact],
    )
}

type AnyImage = Image<Layers<AnyChannels<FlatSamples>>>;

/// Every part of an EXR file, all channels and attributes.
fn read_image(path: &Path) -> Result<AnyImage, FileError> {
    let file = std::fs::File::open(path).map_err(|source| FileError::read(path, source))?;
    let image: AnyImage = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_unbuffered(file)
        .map_err(|e| FileError::format(path, format!("not a readable EXR file ({e})")))?;
    let Some(first) = image.layer_data.first() else {
        return Err(FileError::format(path, "an EXR file without image parts"));
    };
    if image.layer_data.iter().any(|l| l.size != first.size) {
        return Err(FileError::format(
            path,
            "its parts differ in size (not an ftpd3d field)",
        ));
    }
    Ok(image)
}

/// The channel `name` of the first part that has it, with a sample type `want` accepts.
fn find_channel<'a>(
    image: &'a AnyImage,
    name: &str,
    want: impl Fn(&FlatSamples) -> bool,
) -> Option<&'a FlatSamples> {
    image.layer_data.iter().find_map(|l| {
        l.channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name) && want(&c.sample_data))
            .map(|c| &c.sample_data)
    })
}

/// Reads a field written by [`write_exr`] back (exact sums, sample counts, metadata).
pub fn read_exr(path: &Path) -> Result<Field, FileError> {
    let image = read_image(path)?;
    let file = ExrArrays::of(path, &image);
    if file.has("exact.batch.sigma.hi") && !file.has("exact.sum.w.w.hi") {
        return Err(FileError::EarlierVersion {
            path: path.to_path_buf(),
        });
    }
    let mut field = Field::new(file.w, file.h, 1);
    read_exact(&mut field, &file)?;
    for (k, v) in image.layer_data.iter().flat_map(|l| &l.attributes.other) {
        if let (Some(key), AttributeValue::Text(t)) = (attribute_text(k).strip_prefix("ftpd3d."), v)
        {
            field.meta.insert(key.to_string(), attribute_text(t));
        }
    }
    // Every attribute reads as what it should be, or the file is refused naming it.
    field.info(&path.display().to_string())?;
    read_shift(path, &mut field, &file)?;
    Ok(field)
}

/// The u32 channels of an EXR file as the exact accumulator's arrays, in field order.
struct ExrArrays<'a> {
    path: &'a Path,
    image: &'a AnyImage,
    w: usize,
    h: usize,
}

impl<'a> ExrArrays<'a> {
    fn of(path: &'a Path, image: &'a AnyImage) -> Self {
        let size = image.layer_data[0].size;
        ExrArrays {
            path,
            image,
            w: size.x(),
            h: size.y(),
        }
    }

    /// Whether any part has a channel `name`, of any type.
    fn has(&self, name: &str) -> bool {
        find_channel(self.image, name, |_| true).is_some()
    }

    /// The u32 channel `name`, in field order.
    fn u32s(&self, name: &str) -> Result<Vec<u32>, FileError> {
        let Some(FlatSamples::U32(v)) =
            find_channel(self.image, name, |d| matches!(d, FlatSamples::U32(_)))
        else {
            return Err(FileError::format(
                self.path,
                format!("channel '{name}' missing (not an ftpd3d field?)"),
            ));
        };
        Ok(file_order(self.w, self.h)
            .into_iter()
            .map(|e| v[e])
            .collect())
    }
}

impl ExactArrays for ExrArrays<'_> {
    fn has_groups(&self) -> bool {
        self.has("groups")
    }

    fn counts(&self, name: &str) -> Result<Vec<u64>, FileError> {
        Ok(self.u32s(name)?.into_iter().map(u64::from).collect())
    }

    fn sums(&self, name: &str) -> Result<Vec<f64>, FileError> {
        let hi = self.u32s(&format!("exact.{name}.hi"))?;
        let lo = self.u32s(&format!("exact.{name}.lo"))?;
        Ok(hi
            .into_iter()
            .zip(lo)
            .map(|(hi, lo)| f64::from_bits(((hi as u64) << 32) | lo as u64))
            .collect())
    }

    fn compensation(&self, name: &str) -> Result<Option<Vec<f64>>, FileError> {
        let hi = format!("exact.{name}.hi");
        if find_channel(self.image, &hi, |d| matches!(d, FlatSamples::U32(_))).is_none() {
            return Ok(None); // written before the sums were compensated
        }
        self.sums(name).map(Some)
    }
}

/// Reads one channel of an EXR as f32 in field order (row 0 = bottom), for tests and tools: the
/// first part that has it (part 0's f32 view before part 1's exact u32 counts).
pub fn read_channel(path: &Path, name: &str) -> Result<(usize, usize, Vec<f32>), FileError> {
    let image = read_image(path)?;
    let size = image.layer_data[0].size;
    let (w, h) = (size.x(), size.y());
    let c = find_channel(&image, name, |_| true).ok_or_else(|| FileError::NoChannel {
        path: path.to_path_buf(),
        name: name.to_string(),
    })?;
    let v: Vec<f32> = c.values_as_f32().collect();
    Ok((w, h, file_order(w, h).into_iter().map(|e| v[e]).collect()))
}

/// Every f32 channel of an EXR file, by name (the first part's where two parts have one), each in
/// field order (row 0 = bottom): for a reader that keeps the channels a field's sums do not give
/// back (the separatrices', an interrupted pass's), to write them again as they were.
pub fn read_f32_channels(path: &Path) -> Result<Vec<(String, Vec<f32>)>, FileError> {
    let image = read_image(path)?;
    let size = image.layer_data[0].size;
    let order = file_order(size.x(), size.y());
    let mut out: Vec<(String, Vec<f32>)> = Vec::new();
    for layer in &image.layer_data {
        for c in &layer.channel_data.list {
            let name = c.name.to_string();
            if let FlatSamples::F32(v) = &c.sample_data
                && !out.iter().any(|(n, _)| *n == name)
            {
                out.push((name, order.iter().map(|&e| v[e]).collect()));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Text in any script is written as UTF-8 and read back as given; an attribute name the
    /// format cannot hold is an error naming it, not a panic.
    #[test]
    fn header_text_in_any_script_round_trips() {
        let d = std::env::temp_dir().join(format!("ftpd3d-exr-header-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let path = d.join("h.exr");
        let mut field = Field::new(2, 2, 1);
        for c in &mut field.cells {
            c.add_sample(0.25, 1.0, glam::DVec3::splat(0.5));
        }
        let scene = "scène/目录/🎉.obj";
        field.meta.insert("scene".into(), scene.into());
        write_exr(&path, &field, &[]).unwrap();
        assert_eq!(read_exr(&path).unwrap().meta["scene"], scene);
        let mut bad = BTreeMap::new();
        bad.insert("k".repeat(300), "v".to_string());
        let e = check_header(&path, &bad).unwrap_err().to_string();
        assert!(e.contains("at most 255 bytes"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }
}
