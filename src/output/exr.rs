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
//!
//! Image rows run top to bottom, so the first row is the plane's largest v.

use crate::field::Field;
use crate::ftpd::Weighting;
use crate::ftpd::moments::Moments;
use crate::output::{EXACT, FileError, f32_of};
use crate::run_info::DomainKind;
use exr::prelude::*;
// The prelude brings `exr::Result`; the functions here return the room's errors.
use std::collections::BTreeMap;
use std::path::Path;
use std::result::Result;

/// The compensations of the weighted sums, stored exactly like [`EXACT`]; files without them read
/// as zero compensation.
const EXACT_COMP: &[(&str, usize)] = &[("sum.w.comp", 0), ("sum.wd.comp", 1), ("sum.wd2.comp", 2)];

/// Writes a 2D field (depth 1) with optional extra f32 channels (e.g. `grad.x`), each one value per
/// cell in field order. Written to a temporary name, then renamed.
pub fn write_exr(path: &Path, field: &Field, extra: &[(&str, Vec<f64>)]) -> Result<(), FileError> {
    let (w, h) = (field.width, field.height);
    if field.depth != 1 || w == 0 || h == 0 {
        return Err(FileError::unfit(
            path,
            format!("an EXR holds one 2D slice (got {w}x{h}x{})", field.depth),
        ));
    }
    // Field row 0 is the bottom (v minimal); EXR row 0 is the top.
    let order: Vec<usize> = (0..h)
        .rev()
        .flat_map(|j| (0..w).map(move |i| j * w + i))
        .collect();
    let vals = field.values();
    let per =
        |f: &dyn Fn(usize) -> f64| -> Vec<f32> { order.iter().map(|&k| f32_of(f(k))).collect() };
    let mut chans: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut f32ch =
        |name: &str, data: Vec<f32>| chans.push(AnyChannel::new(name, FlatSamples::F32(data)));
    f32ch("ftpd", per(&|k| vals[k].sigma));
    // FreeImage's EXR loader knows only colour models (R,G,B[,A] or Y) and refuses a part whose
    // channels are all named otherwise ("Unsupported color model"): σ as grey.
    for c in ["R", "G", "B"] {
        f32ch(c, per(&|k| vals[k].sigma));
    }
    f32ch("ftpd.mean", per(&|k| vals[k].mean));
    f32ch("ftpd.m2", per(&|k| vals[k].m2));
    f32ch("ftpd.stderr", per(&|k| vals[k].stderr));
    f32ch(
        "ftpd.relerr",
        per(&|k| {
            if vals[k].valid && vals[k].sigma > 0.0 {
                vals[k].stderr / vals[k].sigma
            } else {
                0.0
            }
        }),
    );
    f32ch("weight", per(&|k| vals[k].weight));
    f32ch("valid", per(&|k| if vals[k].valid { 1.0 } else { 0.0 }));
    f32ch("sum.w", per(&|k| field.cells[k].sums().0));
    f32ch("sum.wd", per(&|k| field.cells[k].sums().1));
    f32ch("sum.wd2", per(&|k| field.cells[k].sums().2));
    f32ch("samples", per(&|k| field.cells[k].n as f64));
    f32ch("batches", per(&|k| field.cells[k].batches as f64));
    // The description decides the colour channels (and a malformed one is refused before writing).
    let info = field.info(&path.display().to_string())?;
    if info.domain == Some(DomainKind::Camera) {
        // Camera runs keep the beauty image's radiance in the fluence sums.
        let fl: Vec<_> = field.cells.iter().map(Moments::fluence).collect();
        f32ch("radiance.R", per(&|k| fl[k].x));
        f32ch("radiance.G", per(&|k| fl[k].y));
        f32ch("radiance.B", per(&|k| fl[k].z));
    } else if info.weighting == Some(Weighting::Radiance) {
        let fl: Vec<_> = field.cells.iter().map(Moments::fluence).collect();
        f32ch("fluence.R", per(&|k| fl[k].x));
        f32ch("fluence.G", per(&|k| fl[k].y));
        f32ch("fluence.B", per(&|k| fl[k].z));
    }
    for (name, data) in extra {
        if data.len() != w * h {
            return Err(FileError::unfit(
                path,
                format!("channel {name}: {} values for {} cells", data.len(), w * h),
            ));
        }
        f32ch(name, per(&|k| data[k]));
    }
    let mut exact_chans: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut u32ch = |name: String, data: Vec<u32>| {
        exact_chans.push(AnyChannel::new(name.as_str(), FlatSamples::U32(data)))
    };
    if let Some(c) = field.cells.iter().find(|c| c.n > u32::MAX as u64) {
        return Err(FileError::unfit(
            path,
            format!(
                "a cell holds {} samples, more than an EXR u32 channel can count",
                c.n
            ),
        ));
    }
    u32ch(
        "samples".into(),
        order.iter().map(|&k| field.cells[k].n as u32).collect(),
    );
    u32ch(
        "batches".into(),
        order
            .iter()
            .map(|&k| field.cells[k].batches.min(u32::MAX as u64) as u32)
            .collect(),
    );
    u32ch(
        "groups".into(),
        order
            .iter()
            .map(|&k| field.cells[k].groups as u32)
            .collect(),
    );
    let bits_of = |get: &dyn Fn(&Moments) -> f64| -> Vec<u64> {
        order
            .iter()
            .map(|&k| get(&field.cells[k]).to_bits())
            .collect()
    };
    let mut exact: Vec<(&str, Vec<u64>)> = EXACT
        .iter()
        .map(|(name, get, _)| (*name, bits_of(get)))
        .collect();
    exact.extend(
        EXACT_COMP
            .iter()
            .map(|(name, c)| (*name, bits_of(&|m: &Moments| m.comp[*c]))),
    );
    for (name, bits) in exact {
        u32ch(
            format!("exact.{name}.hi"),
            bits.iter().map(|b| (b >> 32) as u32).collect(),
        );
        u32ch(
            format!("exact.{name}.lo"),
            bits.iter().map(|b| *b as u32).collect(),
        );
    }

    let mut attrs = LayerAttributes::named("ftpd");
    for (k, v) in &field.meta {
        attrs.other.insert(
            Text::from(format!("ftpd3d.{k}").as_str()),
            AttributeValue::Text(Text::from(v.as_str())),
        );
    }
    let view = Layer::new(
        (w, h),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(chans.into()),
    );
    let exact = Layer::new(
        (w, h),
        LayerAttributes::named("exact"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(exact_chans.into()),
    );
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions((w, h))),
        vec![view, exact],
    );
    crate::output::write_file_atomically(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| match e {
            exr::error::Error::Io(source) => FileError::write(path, source),
            e => FileError::encode(path, e),
        })
    })
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
    let size = image.layer_data[0].size;
    let (w, h) = (size.x(), size.y());
    let has = |name: &str| find_channel(&image, name, |_| true).is_some();
    if has("exact.batch.sigma.hi") && !has("exact.sum.w.w.hi") {
        return Err(FileError::EarlierVersion {
            path: path.to_path_buf(),
        });
    }
    // Written before the standard error was taken over groups of samples: see `legacy_groups`.
    let legacy = !has("groups");
    let chan = |name: &str| -> Result<&FlatSamples, FileError> {
        find_channel(&image, name, |d| matches!(d, FlatSamples::U32(_))).ok_or_else(|| {
            FileError::format(
                path,
                format!("channel '{name}' missing (not an ftpd3d field?)"),
            )
        })
    };
    let u32s = |name: &str| -> Result<Vec<u32>, FileError> {
        match chan(name)? {
            FlatSamples::U32(v) => Ok(v.clone()),
            _ => Err(FileError::format(
                path,
                format!("channel '{name}' is not u32"),
            )),
        }
    };
    let mut field = Field::new(w, h, 1);
    // EXR row r holds field row h-1-r.
    let idx = |e: usize| -> usize { (h - 1 - e / w) * w + e % w };
    for (e, n) in u32s("samples")?.into_iter().enumerate() {
        field.cells[idx(e)].n = n as u64;
    }
    for (e, n) in u32s("batches")?.into_iter().enumerate() {
        field.cells[idx(e)].batches = n as u64;
    }
    if legacy {
        crate::output::legacy_groups(&mut field);
    } else {
        for (e, n) in u32s("groups")?.into_iter().enumerate() {
            field.cells[idx(e)].groups = n as u64;
        }
    }
    for (name, _, set) in EXACT {
        if legacy && crate::output::is_triple_sum(name) {
            continue;
        }
        let hi = u32s(&format!("exact.{name}.hi"))?;
        let lo = u32s(&format!("exact.{name}.lo"))?;
        for e in 0..w * h {
            set(
                &mut field.cells[idx(e)],
                f64::from_bits(((hi[e] as u64) << 32) | lo[e] as u64),
            );
        }
    }
    for (name, k) in EXACT_COMP {
        let (hi, lo) = (format!("exact.{name}.hi"), format!("exact.{name}.lo"));
        if chan(&hi).is_err() {
            continue; // written before the sums were compensated
        }
        let (hi, lo) = (u32s(&hi)?, u32s(&lo)?);
        for e in 0..w * h {
            field.cells[idx(e)].comp[*k] = f64::from_bits(((hi[e] as u64) << 32) | lo[e] as u64);
        }
    }
    let mut meta = BTreeMap::new();
    for (k, v) in image.layer_data.iter().flat_map(|l| &l.attributes.other) {
        if let (Some(key), AttributeValue::Text(t)) = (k.to_string().strip_prefix("ftpd3d."), v) {
            meta.insert(key.to_string(), t.to_string());
        }
    }
    field.meta = meta;
    // Every attribute reads as what it should be, or the file is refused naming it.
    field.info(&path.display().to_string())?;
    Ok(field)
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
    let mut out = vec![0.0; w * h];
    for (e, x) in v.into_iter().enumerate() {
        out[(h - 1 - e / w) * w + e % w] = x;
    }
    Ok((w, h, out))
}
