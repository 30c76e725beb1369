//! What the OBJ parser produces: the file's arrays and events ([`ObjData`]), and per chunk of
//! lines the same with the bookkeeping of indices relative to the chunk ([`Lines`]).

use crate::scene::obj::tolerance::{LineFault, Tally};
use glam::{Vec2, Vec3};

/// A face corner without a normal or texture-coordinate index.
pub const MISSING: u32 = u32::MAX;

/// A statement that changes what the faces after it belong to.
#[derive(Clone, Debug, PartialEq)]
pub enum Statement {
    /// `o` or `g`: a new object or group.
    Group,
    /// `usemtl NAME` (`None`: no name given).
    Usemtl(Option<String>),
    /// `mtllib FILE`.
    Mtllib(String),
}

/// A [`Statement`] at a line, before triangle `tri` (the number of triangles read before it).
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    pub line: usize,
    pub tri: usize,
    pub what: Statement,
}

/// The parsed file.
#[derive(Debug, Default)]
pub struct ObjData {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// The `vt` table: (u, v), v up as the file has it (a third coordinate is dropped).
    pub texcoords: Vec<Vec2>,
    /// Position indices (from 0) of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Normal indices (from 0) of each triangle's corners, [`MISSING`] where the face gives none.
    pub tri_normals: Vec<[u32; 3]>,
    /// Texture-coordinate indices (from 0) of each triangle's corners, [`MISSING`] where the face
    /// gives none; empty when the file has no `vt` statement.
    pub tri_texcoords: Vec<[u32; 3]>,
    pub events: Vec<Event>,
    pub oddities: [Tally; 4],
    /// Statements the loader does not use: keyword and tally, in order of first appearance.
    pub unused: Vec<(String, Tally)>,
    pub lines: usize,
}

/// A parse error: the line (1-based, within what was parsed) and what is wrong with it.
pub(super) type LineError = (usize, LineFault);

/// The counts of positions, texture coordinates and normals before a chunk, and its first line.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Base {
    pub(super) counts: [usize; 3],
    pub(super) line: usize,
}

/// The parse of one chunk's lines, with indices as described in [`crate::scene::obj::reader`].
#[derive(Debug, Default)]
pub(super) struct Lines {
    pub(super) data: ObjData,
    /// Triangle corners holding relative indices: (triangle, corner × 4 + [`POSITION`],
    /// [`TEXCOORD`] or [`NORMAL`]); the chunk's base count of that kind is added to them when
    /// stitching.
    pub(super) relative: Vec<(u32, u8)>,
    /// The largest count of positions, texture coordinates, normals that must precede the chunk
    /// for all its references to be valid.
    pub(super) need: [i64; 3],
    pub(super) error: Option<LineError>,
    /// Scratch space for the corners of one face.
    pub(super) corners: Vec<Corner>,
}

impl Lines {
    /// Empties the parse for the next chunk, keeping its buffers.
    pub(super) fn reset(&mut self) {
        let d = &mut self.data;
        d.positions.clear();
        d.normals.clear();
        d.texcoords.clear();
        d.triangles.clear();
        d.tri_normals.clear();
        d.tri_texcoords.clear();
        d.events.clear();
        d.oddities = Default::default();
        d.unused.clear();
        d.lines = 0;
        self.relative.clear();
        self.need = [0; 3];
        self.error = None;
    }
}

/// Kinds of index, as in [`Base::counts`] (and the low two bits of [`Lines::relative`]).
pub(super) const POSITION: u8 = 0;
pub(super) const TEXCOORD: u8 = 1;
pub(super) const NORMAL: u8 = 2;

/// One face corner: position, texture-coordinate and normal index, with "relative to the chunk"
/// flags.
#[derive(Clone, Copy, Debug)]
pub(super) struct Corner {
    /// By kind ([`POSITION`], [`TEXCOORD`], [`NORMAL`]).
    pub(super) index: [u32; 3],
    /// Bit k: `index[k]` is relative to the chunk.
    pub(super) relative: u8,
}
