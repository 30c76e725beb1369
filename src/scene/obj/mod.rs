//! Wavefront OBJ + MTL loading: triangulated meshes, shading normals when present, one material
//! per triangle. The OBJ text is read by chunks of lines in parallel (`reader`: lines are
//! tokenized in `token`, parsed as statements in `lines`, faces resolved in `face`, into
//! `data`), with what mainstream loaders go on past tallied as warnings or, with strict loading,
//! refused (`tolerance`). The MTL libraries are read here and parsed by tobj (`mtl`), their
//! texture maps and cut-outs read by `maps`. See [`crate::scene::material`] for the MTL table.
//! Statement syntax (such as lines continued with `\`) belongs to `lines` and `token`; `reader`
//! decides which lines a chunk owns, so a continued line must stay in the chunk it starts in.

mod data;
mod face;
mod lines;
mod maps;
mod mtl;
mod reader;
mod token;
mod tolerance;

use crate::scene::error::LoadError;
use crate::scene::files::Reach;
use crate::scene::material::Material;
use crate::scene::model::{LoadReport, Scene, Shading, TexCoords};
use crate::scene::texture::TextureSet;
use data::{MISSING, ObjData, Statement};
use glam::Vec3;
use reader::ParseError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use tolerance::LineFault;

/// Loads an OBJ file (and the MTL files it names) into a [`Scene`].
///
/// The file is parsed by `reader` (in parallel, by chunks of lines): every
/// `v`, `vt`, `vn` and `f` statement is validated and the first bad one is reported as
/// `FILE:LINE`. What mainstream loaders go on past is one warning per kind, with the count and
/// the first line (an error at that line with `strict`): faces of fewer than 3 vertices (skipped),
/// `usemtl` without a name (default material), `mtllib` without a name, statements the loader does
/// not use, and lines that are not UTF-8 (read as Latin-1). Material libraries are read by this
/// loader too (`mtl::load_mtl`), so that a missing or malformed one is a warning naming it (its
/// materials become grey diffuse), never a panic in the parser. A file without faces is an error.
///
/// What the scene keeps is what tobj (a mainstream OBJ parser) gives, triangle for triangle:
/// polygons fanned from their first vertex in file order; materials resolved by name at
/// the `usemtl` line against the libraries named before it (a later library's material of the
/// same name wins); shading normals from `vn` for every face of an object or material run whose
/// faces all give them, zero (the geometric normal) for the faces of a run where one does not, and
/// none at all when no face has a non-zero one.
///
/// Texture coordinates (`vt`, v up as in the file) are kept per face corner, as an index into the
/// `vt` table, when some material reads a texture ([`Material::maps`]); a corner whose face
/// gives no `vt` index reads (0, 0), and so do faces of files without `vt`.
pub fn load(path: &Path, strict: bool) -> Result<Scene, LoadError> {
    load_within(path, strict, &Reach::of(path, false))
}

/// As [`load`], reading material libraries and their maps within `reach` (by default the OBJ
/// file's folder): a library or map outside it is a [`LoadError::Outside`] (`mtllib` names a
/// library relative to the OBJ file, a map is relative to its library).
pub fn load_within(path: &Path, strict: bool, reach: &Reach) -> Result<Scene, LoadError> {
    let file = path.display().to_string();
    if let Some(kind) = crate::scene::files::not_regular(path) {
        return Err(LoadError::NotRegular {
            file: path.to_path_buf(),
            kind,
        });
    }
    if let Err(source) = std::fs::metadata(path) {
        return Err(LoadError::unopened(path, source));
    }
    refuse_utf16(path)?;
    let data = read(path, strict)?;
    let mut report = LoadReport {
        warnings: tolerance::warnings(&file, &data.oddities, &data.unused),
        ..Default::default()
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    let (libraries, runs) = Libraries::read((path, dir), &data, reach)?;
    let (materials, textures) = libraries.materials(path, &mut report, reach)?;
    // Index of the default material for faces without one (the last).
    let default_id = materials.len() as u32 - 1;
    let tri_material = tri_materials(&runs, data.triangles.len(), default_id);
    let shading = shading_normals(&data, &runs);
    // What the scene does not keep is freed here, before its own buffers are made and Embree
    // builds; texture coordinates are kept only for textured materials (`Scene::from_parts`
    // checks it too).
    let ObjData {
        positions,
        triangles,
        texcoords,
        tri_texcoords,
        normals,
        tri_normals,
        ..
    } = data;
    drop((normals, tri_normals));
    let texcoords = if materials.iter().any(|m| m.maps.reads_textures()) && !texcoords.is_empty() {
        TexCoords::PerCorner {
            table: texcoords,
            corners: tri_texcoords,
        }
    } else {
        drop((texcoords, tri_texcoords));
        TexCoords::None
    };
    let mut scene = Scene::from_parts(
        path,
        positions,
        triangles,
        tri_material,
        shading,
        texcoords,
        materials,
        report,
    )
    .map_err(|source| LoadError::Build {
        file: path.to_path_buf(),
        source,
    })?;
    if scene.triangles.is_empty() {
        return Err(LoadError::NoGeometry {
            file: path.to_path_buf(),
            what: format!(
                "all {} triangles are degenerate (zero area or non-finite coordinates)",
                scene.report.triangles_read
            ),
        });
    }
    scene.attach_textures(textures);
    Ok(scene)
}

/// Parses the OBJ file at `path`, and checks that it has faces and that its indices fit.
fn read(path: &Path, strict: bool) -> Result<ObjData, LoadError> {
    let file = path.to_path_buf();
    let data = reader::parse_file(path, strict).map_err(|e| match e {
        ParseError::Io(source) => LoadError::Unreadable { file, source },
        ParseError::Changed => LoadError::Changed { file },
        ParseError::Line(line, LineFault::Malformed(what)) => LoadError::Malformed {
            file,
            line: Some(line),
            what,
        },
        ParseError::Line(line, LineFault::Strict(what)) => LoadError::Strict { file, line, what },
    })?;
    if data.positions.len() >= u32::MAX as usize
        || data.normals.len() >= u32::MAX as usize
        || data.texcoords.len() >= u32::MAX as usize
    {
        return Err(LoadError::TooLarge {
            file: path.to_path_buf(),
            what: "more than 2^32 - 2 vertices, normals or texture coordinates".into(),
        });
    }
    if data.triangles.is_empty() {
        return Err(LoadError::NoGeometry {
            file: path.to_path_buf(),
            what: format!(
                "the file has no faces ('f' statements){}",
                if data.positions.is_empty() {
                    " and no vertices"
                } else {
                    ""
                }
            ),
        });
    }
    Ok(data)
}

/// The material libraries an OBJ file names, read in file order: their materials (tobj's), each
/// material's library directory (texture paths are relative to it), materials by name (a later
/// library's material of the same name wins), the notes about libraries that could not be read
/// and the last error.
struct Libraries {
    list: Vec<tobj::Material>,
    dirs: Vec<PathBuf>,
    by_name: HashMap<String, usize>,
    notes: Vec<String>,
    error: Option<tobj::LoadError>,
}

impl Libraries {
    /// Reads the libraries `data` names (relative to `dir`, the folder of the OBJ file at `path`,
    /// and within `reach`) and resolves each `usemtl` against those named before it; returns
    /// them and the runs of faces, (first triangle, material or `None`), which end at `o`, `g` and
    /// a `usemtl` that changes the material.
    #[allow(clippy::type_complexity)]
    fn read(
        (path, dir): (&Path, &Path),
        data: &ObjData,
        reach: &Reach,
    ) -> Result<(Libraries, Vec<(usize, Option<usize>)>), LoadError> {
        let file = &path.display().to_string();
        let mut libs = Libraries {
            list: Vec::new(),
            dirs: Vec::new(),
            by_name: HashMap::new(),
            notes: Vec::new(),
            error: None,
        };
        let mut runs: Vec<(usize, Option<usize>)> = vec![(0, None)];
        for event in &data.events {
            match &event.what {
                Statement::Mtllib(lib) => {
                    let at = reach.resolve(dir, lib).map_err(|o| LoadError::Outside {
                        file: path.to_path_buf(),
                        what: "mtllib".into(),
                        name: lib.clone(),
                        folder: o.folder,
                        why: o.why,
                    })?;
                    libs.add(file, &at)
                }
                Statement::Usemtl(name) => {
                    let id = name.as_ref().and_then(|n| libs.by_name.get(n).copied());
                    let current = runs.last().and_then(|r| r.1);
                    if id != current {
                        push_run(&mut runs, event.tri, id);
                    }
                }
                Statement::Group => {
                    let current = runs.last().and_then(|r| r.1);
                    push_run(&mut runs, event.tri, current);
                }
            }
        }
        Ok((libs, runs))
    }

    /// Reads the library at `at` and adds its materials.
    fn add(&mut self, file: &str, at: &Path) {
        match mtl::load_mtl(file, at, &mut self.notes) {
            Ok((mut mats, map)) => {
                let offset = self.list.len();
                // Texture paths are relative to the library's own directory.
                let lib_dir = at.parent().map(Path::to_path_buf);
                self.dirs
                    .extend(std::iter::repeat_n(lib_dir.unwrap_or_default(), mats.len()));
                self.list.append(&mut mats);
                self.by_name
                    .extend(map.into_iter().map(|(k, i)| (k, i + offset)));
            }
            Err(e) => self.error = Some(e),
        }
    }

    /// The materials of the libraries converted, with their texture maps, and the default
    /// material (for faces without one) last; the textures they read. Warnings go to `report`.
    fn materials(
        self,
        path: &Path,
        report: &mut LoadReport,
        reach: &Reach,
    ) -> Result<(Vec<Material>, TextureSet), LoadError> {
        let file = &path.display().to_string();
        let mut materials = mtl::convert_materials(file, &self.list, report);
        let textures = maps::apply(
            (path, reach),
            &self.list,
            &self.dirs,
            &mut materials,
            report,
        )?;
        if materials.is_empty()
            && let Some(e) = self.error
            && self.notes.is_empty()
        {
            report.warnings.push(format!(
                "{file}: material library not loaded ({}); using grey diffuse",
                mtl::describe(&e)
            ));
        }
        report.warnings.extend(self.notes);
        materials.push(Material::default_grey());
        Ok((materials, textures))
    }
}

/// Starts a run of faces at triangle `tri` (replacing the previous run when it is still empty).
fn push_run(runs: &mut Vec<(usize, Option<usize>)>, tri: usize, id: Option<usize>) {
    match runs.last_mut() {
        Some(last) if last.0 == tri => last.1 = id,
        _ => runs.push((tri, id)),
    }
}

/// The shading normals of every triangle's corners (see [`load`]), on huge pages like the other
/// per-triangle records the hit code reads.
fn shading_normals(data: &ObjData, runs: &[(usize, Option<usize>)]) -> Shading {
    use rayon::prelude::*;
    if data.normals.is_empty() {
        return Shading::None;
    }
    let n = data.triangles.len();
    let end_of = |k: usize| runs.get(k + 1).map_or(n, |r| r.0);
    // A run whose faces all give normals keeps them; the others get zero normals.
    let complete: Vec<bool> = (0..runs.len())
        .into_par_iter()
        .map(|k| {
            data.tri_normals[runs[k].0..end_of(k)]
                .iter()
                .all(|t| !t.contains(&MISSING))
        })
        .collect();
    if !complete.iter().any(|&c| c) {
        return Shading::None;
    }
    let normals = &data.normals;
    let mut shading: Vec<[Vec3; 3]> = crate::accel::vec_with_huge_pages(n);
    shading.par_extend(rayon::iter::repeat_n([Vec3::ZERO; 3], n));
    const CHUNK: usize = 1 << 16;
    shading
        .par_chunks_mut(CHUNK)
        .zip(data.tri_normals.par_chunks(CHUNK))
        .enumerate()
        .for_each(|(j, (out, vns))| {
            let t0 = j * CHUNK;
            // The run of the chunk's first triangle: the last one starting at or before it.
            let mut k = runs.partition_point(|r| r.0 <= t0) - 1;
            for (i, (o, vn)) in out.iter_mut().zip(vns).enumerate() {
                while t0 + i >= end_of(k) {
                    k += 1;
                }
                if complete[k] {
                    *o = vn.map(|i| normals[i as usize]);
                }
            }
        });
    let non_zero = || {
        shading
            .par_iter()
            .any(|c| c.iter().any(|v| *v != Vec3::ZERO))
    };
    if complete.iter().all(|&c| c) || non_zero() {
        Shading::PerCorner(shading)
    } else {
        // Runs without normals and only zero ones elsewhere: no shading normals (tobj's result).
        Shading::None
    }
}

/// Each triangle's material: the run's, or `default_id` for runs without one.
fn tri_materials(runs: &[(usize, Option<usize>)], n: usize, default_id: u32) -> Vec<u32> {
    let mut tri_material = Vec::with_capacity(n);
    for (k, &(start, id)) in runs.iter().enumerate() {
        let end = runs.get(k + 1).map_or(n, |r| r.0);
        let id = id.map_or(default_id, |i| i as u32);
        tri_material.extend(std::iter::repeat_n(id, end - start));
    }
    tri_material
}

/// Refuses an OBJ file saved as UTF-16 (a byte-order mark, or every other byte 0 at its start),
/// which would otherwise read as lines of nothing the loader knows.
fn refuse_utf16(path: &Path) -> Result<(), LoadError> {
    let mut head = [0u8; 64];
    let n = std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .map_err(|source| LoadError::Unreadable {
            file: path.to_path_buf(),
            source,
        })?;
    let head = &head[..n];
    let bom = head.starts_with(&[0xFF, 0xFE]) || head.starts_with(&[0xFE, 0xFF]);
    let zeros_at = |k: usize| head.iter().skip(k).step_by(2).all(|&b| b == 0);
    let no_zeros_at = |k: usize| head.iter().skip(k).step_by(2).all(|&b| b != 0);
    let interleaved =
        n >= 8 && ((zeros_at(1) && no_zeros_at(0)) || (zeros_at(0) && no_zeros_at(1)));
    if bom || interleaved {
        return Err(LoadError::Malformed {
            file: path.to_path_buf(),
            line: None,
            what: "the file is UTF-16 text; OBJ files are read as UTF-8 (or ASCII): save it \
                   as UTF-8"
                .into(),
        });
    }
    Ok(())
}
