//! Output of computed fields: PNG previews (and, alongside, the EXR data files).
pub mod png;
