//! Files of one test: a fresh temporary directory, and the outputs read by readers that are not the
//! project's own (the exr crate directly, vtkio for `.vti`).

use std::path::{Path, PathBuf};

/// A fresh, empty directory for one test, removed when the test ends, and kept (its path printed)
/// when the test fails, so that its files can be looked at.
pub struct TempDir(PathBuf);

/// A fresh, empty directory for one test: `ftpd3d-<module>-<test>-<pid>` under the system's
/// temporary directory.
pub fn temp_dir(module: &str, test: &str) -> TempDir {
    let dir = std::env::temp_dir().join(format!("ftpd3d-{module}-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    TempDir(dir)
}

impl std::ops::Deref for TempDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("the failed test's files are kept in {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Every part of an EXR file with all its channels and attributes, read by the exr crate directly
/// (not by the project's reader).
pub fn exr_parts(
    path: &Path,
) -> Vec<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>> {
    use exr::prelude::*;
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap()
        .layer_data
        .into_vec()
}

/// The text attribute `ftpd3d.<key>` of an EXR part (`None` where it has none); panics where it is
/// not text.
pub fn ftpd3d_attribute(
    part: &exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>,
    key: &str,
) -> Option<String> {
    part.attributes
        .other
        .iter()
        .find(|(k, _)| k.to_string() == format!("ftpd3d.{key}"))
        .map(|(_, v)| match v {
            exr::prelude::AttributeValue::Text(t) => t.to_string(),
            other => panic!("ftpd3d.{key} is not text: {other:?}"),
        })
}

/// A `.vti` as the independent vtkio reader sees it: extent, origin, spacing and the point arrays
/// by name, in the file's order.
pub struct VtiImage {
    pub extent: vtkio::model::Extent,
    pub origin: [f32; 3],
    pub spacing: [f32; 3],
    pub arrays: Vec<(String, vtkio::model::IOBuffer)>,
}

/// Reads `path` with vtkio (which drops arrays it cannot read: a test that lists every array name
/// proves each was readable).
pub fn read_vti(path: &Path) -> VtiImage {
    use vtkio::model::{Attribute, DataSet, Piece};
    let vtk = vtkio::Vtk::import(path).expect("vtkio reads the file");
    let DataSet::ImageData {
        extent,
        origin,
        spacing,
        pieces,
        ..
    } = vtk.data
    else {
        panic!("{}: not ImageData", path.display());
    };
    let Piece::Inline(piece) = &pieces[0] else {
        panic!("{}: piece not inline", path.display())
    };
    let arrays = piece
        .data
        .point
        .iter()
        .map(|a| match a {
            Attribute::DataArray(d) => (d.name.clone(), d.data.clone()),
            Attribute::Field { .. } => panic!("{}: field attribute", path.display()),
        })
        .collect();
    VtiImage {
        extent,
        origin,
        spacing,
        arrays,
    }
}

impl VtiImage {
    /// The names of the point arrays, in the file's order.
    pub fn names(&self) -> Vec<&str> {
        self.arrays.iter().map(|a| a.0.as_str()).collect()
    }

    fn array(&self, name: &str) -> &vtkio::model::IOBuffer {
        match self.arrays.iter().find(|a| a.0 == name) {
            Some((_, b)) => b,
            None => panic!("no array {name} in {:?}", self.names()),
        }
    }

    pub fn f64s(&self, name: &str) -> &[f64] {
        match self.array(name) {
            vtkio::model::IOBuffer::F64(v) => v,
            other => panic!("{name}: {other:?}"),
        }
    }

    pub fn f32s(&self, name: &str) -> &[f32] {
        match self.array(name) {
            vtkio::model::IOBuffer::F32(v) => v,
            other => panic!("{name}: {other:?}"),
        }
    }

    pub fn u32s(&self, name: &str) -> &[u32] {
        match self.array(name) {
            vtkio::model::IOBuffer::U32(v) => v,
            other => panic!("{name}: {other:?}"),
        }
    }

    pub fn u8s(&self, name: &str) -> &[u8] {
        match self.array(name) {
            vtkio::model::IOBuffer::U8(v) => v,
            other => panic!("{name}: {other:?}"),
        }
    }
}
