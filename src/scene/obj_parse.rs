//! The OBJ statement parser, built for files of millions of faces: the file is cut into chunks of
//! about 1 MB that start and end at line ends, a block of them at a time; the chunks of a block
//! are read (positioned reads, each into its own reused buffer) and parsed in parallel (rayon),
//! and then copied in parallel into the file's arrays, in file order. A chunk does not know how
//! many vertices come before it, so it keeps face indices that count from the start of the file
//! as they are, indices that count back (negative) relative to its own vertices with a note to add
//! the chunk's base later, and the largest base any of its references needs; when a chunk needs
//! more than it gets (or has a malformed line), it is parsed again with its base and first line
//! known, which finds the first bad line exactly as a sequential parse would (`FILE:LINE: ...`).
//!
//! A chunk owns the lines that start in its byte range: it reads one byte before the range (to
//! see whether the range starts a line) and on past its end to the end of its last line. Adjacent
//! chunks must then meet exactly, and the file must have the length and modification time it had
//! when it was opened; otherwise the file changed while it was read, which is an error, not a
//! half-read scene. (The file is read, not memory-mapped: a mapped file that another program
//! shortens kills the reading process with SIGBUS, and its pages would count as resident.)
//!
//! What is kept per face corner is the position index, and the normal and texture-coordinate
//! indices ([`MISSING`] where the face gives none); the `vt` table is kept, the per-corner `vt`
//! indices only when the file has `vt` statements. Polygons are fanned from their first vertex,
//! (a, b, c), (a, c, d), ..., in file order.
//!
//! Recoverable oddities (faces of fewer than 3 vertices, `usemtl` or `mtllib` without a name,
//! statements the loader does not use, lines that are not UTF-8, read as Latin-1) are tallied
//! (count and first line) for one warning per kind; with `strict` they are errors at their line.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::fs::File;

/// A face corner without a normal or texture-coordinate index.
pub const MISSING: u32 = u32::MAX;

/// Chunks per block: a block's chunks are read, parsed and stitched while nothing else of the file
/// is held (their buffers are reused from block to block).
const BLOCK_CHUNKS: usize = 32;
/// The byte range of a chunk (the unit of parallel work).
const CHUNK_BYTES: usize = 1 << 20;
/// Bytes read past a chunk's range at first, to finish its last line (more when it is longer).
const SLACK_BYTES: usize = 8 << 10;

/// The message for a file that changed while it was read.
const CHANGED: &str = "the file changed while it was read; load it again once it is complete";

/// The statements the loader uses (`#` starts a comment).
const KEYWORDS: &[&str] = &["v", "vt", "vn", "f", "o", "g", "s", "mtllib", "usemtl"];

/// Kinds of recoverable oddities, one warning each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Oddity {
    /// `f` with fewer than 3 vertices (a point or a line): skipped.
    ShortFace = 0,
    /// `usemtl` without a name: the faces after it get the default material.
    BareUsemtl = 1,
    /// `mtllib` without a file name: ignored.
    BareMtllib = 2,
    /// A line that is not UTF-8: read as Latin-1.
    NotUtf8 = 3,
}

pub const ODDITIES: [Oddity; 4] = [
    Oddity::ShortFace,
    Oddity::BareUsemtl,
    Oddity::BareMtllib,
    Oddity::NotUtf8,
];

/// How often something occurred and the first line (1-based) where it did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    pub count: usize,
    pub first: usize,
}

impl Tally {
    fn add(&mut self, line: usize) {
        if self.count == 0 {
            self.first = line;
        }
        self.count += 1;
    }
    /// Adds a later chunk's tally whose lines are `offset` lines further on.
    fn merge(&mut self, later: &Tally, offset: usize) {
        if later.count > 0 {
            if self.count == 0 {
                self.first = later.first + offset;
            }
            self.count += later.count;
        }
    }
}

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

/// A parse error: the line (1-based, within what was parsed) and the message after `FILE:LINE: `.
type LineError = (usize, String);

/// The counts of positions, texture coordinates and normals before a chunk, and its first line.
#[derive(Clone, Copy, Debug, Default)]
struct Base {
    counts: [usize; 3],
    line: usize,
}

/// One chunk's statements, with indices as described in the module docs.
#[derive(Debug, Default)]
struct Chunk {
    data: ObjData,
    /// Triangle corners holding relative indices: (triangle, corner × 4 + [`POSITION`],
    /// [`TEXCOORD`] or [`NORMAL`]); the chunk's base count of that kind is added to them when
    /// stitching.
    relative: Vec<(u32, u8)>,
    /// The largest count of positions, texture coordinates, normals that must precede the chunk
    /// for all its references to be valid.
    need: [i64; 3],
    error: Option<LineError>,
    /// Scratch space for the corners of one face.
    corners: Vec<Corner>,
    /// The bytes read for the chunk (reused; only the first `have` are this chunk's), from file
    /// offset `from`.
    buf: Vec<u8>,
    from: u64,
    have: usize,
    /// File offsets where the chunk's first line starts and its last line ends (after its
    /// `\n`); equal when no line starts in its range.
    span: (u64, u64),
    /// A read error, or a file that is shorter than when it was opened.
    io_error: Option<String>,
}

impl Chunk {
    /// Empties the chunk for the next one, keeping its buffers.
    fn reset(&mut self) {
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
        self.have = 0;
        self.io_error = None;
    }

    /// Reads `more` bytes (fewer at the end of the file) after those the chunk has.
    fn read_more(&mut self, file: &File, len: u64, more: usize) -> Result<(), String> {
        let at = self.from + self.have as u64;
        let want = (more as u64).min(len.saturating_sub(at)) as usize;
        let new = self.have + want;
        if self.buf.len() < new {
            // Grows only: a reused buffer is not zeroed again.
            self.buf.resize(new, 0);
        }
        read_exact_at(file, &mut self.buf[self.have..new], at).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                CHANGED.to_string()
            } else {
                format!("cannot read ({e})")
            }
        })?;
        self.have = new;
        Ok(())
    }

    /// The offset of the first `\n` at or after file offset `at` (at least `from`), reading on
    /// as needed; `len` when the file ends first.
    fn newline_from(&mut self, file: &File, len: u64, at: u64) -> Result<u64, String> {
        let mut i = (at - self.from) as usize;
        loop {
            if i < self.have
                && let Some(k) = memchr::memchr(b'\n', &self.buf[i..self.have])
            {
                return Ok(self.from + (i + k) as u64);
            }
            if self.from + self.have as u64 >= len {
                return Ok(len);
            }
            i = i.max(self.have);
            self.read_more(file, len, self.have.max(SLACK_BYTES))?;
        }
    }

    /// Reads the lines that start in the file's byte range `[start, end)` (`first`: `start` is
    /// known to start a line) and parses them.
    fn read_and_parse(
        &mut self,
        file: &File,
        len: u64,
        range: (u64, u64),
        first: bool,
        strict: bool,
    ) {
        self.reset();
        let (start, end) = range;
        self.from = if first { start } else { start - 1 };
        let read = (|| {
            self.read_more(file, len, (end - self.from) as usize + SLACK_BYTES)?;
            let p = if first {
                start
            } else {
                (self.newline_from(file, len, start - 1)? + 1).min(len)
            };
            if p >= end {
                return Ok((p, p));
            }
            let e = (self.newline_from(file, len, end - 1)? + 1).min(len);
            Ok((p, e))
        })();
        match read {
            Ok(span) => {
                self.span = span;
                let buf = std::mem::take(&mut self.buf);
                let bytes = &buf[(span.0 - self.from) as usize..(span.1 - self.from) as usize];
                parse_chunk(self, bytes, strict, None);
                self.buf = buf;
            }
            Err(e) => self.io_error = Some(e),
        }
    }

    /// The chunk's lines, as read.
    fn bytes(&self) -> &[u8] {
        &self.buf[(self.span.0 - self.from) as usize..(self.span.1 - self.from) as usize]
    }
}

/// Fills `buf` from file offset `at`.
#[cfg(unix)]
fn read_exact_at(file: &File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, at)
}

/// Fills `buf` from file offset `at`.
#[cfg(not(unix))]
fn read_exact_at(file: &File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = file;
    f.seek(SeekFrom::Start(at))?;
    f.read_exact(buf)
}

/// Parses the OBJ file at `path` (see the module docs). `Err` is `(line, message)` for a bad line,
/// or an I/O error (or a file that changed while it was read) as `(0, message)`.
pub fn parse_file(path: &std::path::Path, strict: bool) -> Result<ObjData, LineError> {
    let io = |e: std::io::Error| (0, format!("cannot read ({e})"));
    let file = File::open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    let len = meta.len();
    let mut out = ObjData::default();
    // The chunks' buffers, reused from block to block (fresh memory costs a page fault each
    // page; reused memory does not).
    let mut pool: Vec<Chunk> = Vec::new();
    let mut at = 0;
    while at < len {
        at = parse_block(&file, len, at, strict, &mut pool, &mut out)?;
    }
    let now = file.metadata().map_err(io)?;
    if now.len() != len || now.modified().ok() != meta.modified().ok() {
        return Err((0, CHANGED.into()));
    }
    out.positions.shrink_to_fit();
    out.normals.shrink_to_fit();
    out.texcoords.shrink_to_fit();
    out.triangles.shrink_to_fit();
    out.tri_normals.shrink_to_fit();
    if out.texcoords.is_empty() {
        out.tri_texcoords = Vec::new();
    }
    out.tri_texcoords.shrink_to_fit();
    Ok(out)
}

/// Reads and parses the block of chunks that starts at file offset `start` (a line start) in
/// parallel, appends them to `out` in order, and returns where the next block starts.
fn parse_block(
    file: &File,
    len: u64,
    start: u64,
    strict: bool,
    pool: &mut Vec<Chunk>,
    out: &mut ObjData,
) -> Result<u64, LineError> {
    let n = ((len - start).div_ceil(CHUNK_BYTES as u64) as usize).min(BLOCK_CHUNKS);
    if pool.len() < n {
        pool.resize_with(n, Chunk::default);
    }
    let chunks = &mut pool[..n];
    chunks.par_iter_mut().enumerate().for_each(|(k, c)| {
        let from = start + (k * CHUNK_BYTES) as u64;
        let range = (from, (from + CHUNK_BYTES as u64).min(len));
        c.read_and_parse(file, len, range, k == 0, strict);
    });
    // Each chunk's base (the counts and lines before it) and first triangle, in order.
    let mut bases = Vec::with_capacity(n);
    let mut base = Base {
        counts: [out.positions.len(), out.texcoords.len(), out.normals.len()],
        line: out.lines,
    };
    let mut tris = out.triangles.len();
    let mut at = start;
    for chunk in chunks.iter() {
        if let Some(e) = &chunk.io_error {
            return Err((0, e.clone()));
        }
        if chunk.span.0 != at {
            return Err((0, CHANGED.into()));
        }
        at = chunk.span.1;
        let short = (0..3).any(|i| chunk.need[i] > base.counts[i] as i64);
        if chunk.error.is_some() || short {
            // Again with the base known: the first bad line, as a sequential parse finds it.
            let mut again = Chunk::default();
            parse_chunk(&mut again, chunk.bytes(), strict, Some(base));
            let (line, msg) = again
                .error
                .unwrap_or_else(|| (1, "inconsistent parse (please report it)".into()));
            return Err((base.line + line, msg));
        }
        bases.push((base, tris));
        let d = &chunk.data;
        base.counts[0] += d.positions.len();
        base.counts[1] += d.texcoords.len();
        base.counts[2] += d.normals.len();
        base.line += d.lines;
        tris += d.triangles.len();
    }
    append(out, chunks, &bases);
    Ok(at)
}

/// `v` lengthened to `len` by default values, written in parallel (the pages they touch are
/// faulted in on both cores).
fn grow<T: Copy + Default + Send>(v: &mut Vec<T>, len: usize) {
    v.par_extend(rayon::iter::repeat_n(T::default(), len - v.len()));
}

/// `v[from..]` cut into consecutive slices of the given lengths.
fn split<T>(v: &mut [T], from: usize, lens: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut rest = &mut v[from..];
    lens.map(|n| {
        let (part, after) = std::mem::take(&mut rest).split_at_mut(n);
        rest = after;
        part
    })
    .collect()
}

/// Where one chunk's arrays go in the file's.
struct Dest<'a> {
    positions: &'a mut [Vec3],
    normals: &'a mut [Vec3],
    texcoords: &'a mut [Vec2],
    triangles: &'a mut [[u32; 3]],
    tri_normals: &'a mut [[u32; 3]],
    tri_texcoords: Option<&'a mut [[u32; 3]]>,
}

/// Appends a block's parsed chunks to everything before them (their arrays copied in parallel),
/// given each chunk's base and first triangle.
fn append(out: &mut ObjData, chunks: &[Chunk], bases: &[(Base, usize)]) {
    let old = (
        [out.positions.len(), out.texcoords.len(), out.normals.len()],
        out.triangles.len(),
    );
    let sum = |f: fn(&ObjData) -> usize| chunks.iter().map(|c| f(&c.data)).sum::<usize>();
    let tris = old.1 + sum(|d| d.triangles.len());
    grow(&mut out.positions, old.0[0] + sum(|d| d.positions.len()));
    grow(&mut out.texcoords, old.0[1] + sum(|d| d.texcoords.len()));
    grow(&mut out.normals, old.0[2] + sum(|d| d.normals.len()));
    grow(&mut out.triangles, tris);
    grow(&mut out.tri_normals, tris);
    // Per-corner texture-coordinate indices once the file has had a `vt` (the triangles before
    // the first one have none).
    let with_vt = !out.texcoords.is_empty();
    if with_vt {
        if out.tri_texcoords.len() < old.1 {
            out.tri_texcoords.resize(old.1, [MISSING; 3]);
        }
        grow(&mut out.tri_texcoords, tris);
    }
    let lens = |f: fn(&ObjData) -> usize| chunks.iter().map(move |c| f(&c.data));
    let mut tri_texcoords: Vec<Option<&mut [[u32; 3]]>> = if with_vt {
        split(&mut out.tri_texcoords, old.1, lens(|d| d.triangles.len()))
            .into_iter()
            .map(Some)
            .collect()
    } else {
        (0..chunks.len()).map(|_| None).collect()
    };
    let dests: Vec<Dest> = split(&mut out.positions, old.0[0], lens(|d| d.positions.len()))
        .into_iter()
        .zip(split(&mut out.normals, old.0[2], lens(|d| d.normals.len())))
        .zip(split(
            &mut out.texcoords,
            old.0[1],
            lens(|d| d.texcoords.len()),
        ))
        .zip(split(
            &mut out.triangles,
            old.1,
            lens(|d| d.triangles.len()),
        ))
        .zip(split(
            &mut out.tri_normals,
            old.1,
            lens(|d| d.triangles.len()),
        ))
        .zip(tri_texcoords.drain(..))
        .map(
            |(((((positions, normals), texcoords), triangles), tri_normals), tri_texcoords)| Dest {
                positions,
                normals,
                texcoords,
                triangles,
                tri_normals,
                tri_texcoords,
            },
        )
        .collect();
    dests
        .into_par_iter()
        .zip(chunks.par_iter().zip(bases))
        .for_each(|(d, (chunk, (base, _)))| {
            let data = &chunk.data;
            d.positions.copy_from_slice(&data.positions);
            d.normals.copy_from_slice(&data.normals);
            d.texcoords.copy_from_slice(&data.texcoords);
            d.triangles.copy_from_slice(&data.triangles);
            d.tri_normals.copy_from_slice(&data.tri_normals);
            let mut tri_texcoords = d.tri_texcoords;
            if let Some(t) = tri_texcoords.as_deref_mut() {
                t.copy_from_slice(&data.tri_texcoords);
            }
            for &(t, which) in &chunk.relative {
                let (t, c, kind) = (t as usize, (which >> 2) as usize, which & 3);
                let v = match kind {
                    POSITION => &mut d.triangles[t][c],
                    NORMAL => &mut d.tri_normals[t][c],
                    // A relative vt index means the chunk has vt, so the file has.
                    _ => match tri_texcoords.as_deref_mut() {
                        Some(tt) => &mut tt[t][c],
                        None => continue,
                    },
                };
                *v = v.wrapping_add(base.counts[kind as usize] as u32);
            }
        });
    for (chunk, (base, tri0)) in chunks.iter().zip(bases) {
        let data = &chunk.data;
        out.events.extend(data.events.iter().map(|e| Event {
            line: e.line + base.line,
            tri: e.tri + tri0,
            what: e.what.clone(),
        }));
        for (t, later) in out.oddities.iter_mut().zip(&data.oddities) {
            t.merge(later, base.line);
        }
        for (kw, later) in &data.unused {
            match out.unused.iter_mut().find(|(k, _)| k == kw) {
                Some((_, t)) => t.merge(later, base.line),
                None => {
                    let mut t = Tally::default();
                    t.merge(later, base.line);
                    out.unused.push((kw.clone(), t));
                }
            }
        }
        out.lines += data.lines;
    }
}

/// The first 60 characters of a line, for messages.
fn shown(line: &str) -> String {
    let line = line.trim();
    let mut s: String = line.chars().take(60).collect();
    if line.chars().count() > 60 {
        s.push('…');
    }
    s
}

/// Latin-1 text of bytes that are not UTF-8 (every byte is the code point of the same value).
fn latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|&b| b as char).collect()
}

/// Parses one chunk of whole lines. With `known`, the counts before the chunk are known and face
/// references are checked against them exactly (the slow path that names the first bad line).
fn parse_chunk(c: &mut Chunk, bytes: &[u8], strict: bool, known: Option<Base>) {
    parse_lines(c, bytes, strict, known, known.is_none());
}

/// [`parse_chunk`], with the byte-level path for the lines of real files when `fast`.
fn parse_lines(c: &mut Chunk, bytes: &[u8], strict: bool, known: Option<Base>, fast: bool) {
    c.reset();
    let mut owned: String;
    let mut start = 0;
    let mut line_no = 0;
    while start < bytes.len() {
        let end = memchr::memchr(b'\n', &bytes[start..]).map_or(bytes.len(), |i| start + i);
        line_no += 1;
        let raw = &bytes[start..end];
        start = end + 1;
        // The lines of real files first, byte by byte; whatever they do not take (and every line
        // when the counts before the chunk are known, to name the first bad one) goes through
        // `statement`.
        if fast && fast_statement(raw, c).is_some() {
            continue;
        }
        let line: &str = match std::str::from_utf8(raw) {
            Ok(s) => s,
            Err(_) => {
                if strict {
                    c.error = Some((line_no, "not UTF-8 text (--strict)".into()));
                    break;
                }
                c.data.oddities[Oddity::NotUtf8 as usize].add(line_no);
                owned = latin1(raw);
                &owned
            }
        };
        if let Err(msg) = statement(line, line_no, strict, known, c) {
            c.error = Some((line_no, msg));
            break;
        }
    }
    c.data.lines = line_no;
}

/// Whether `b` separates words (what `split_ascii_whitespace` splits at).
#[inline]
fn is_space(b: u8) -> bool {
    b.is_ascii_whitespace()
}

/// The next word of `b` (after leading white space) and what follows it.
#[inline]
fn next_word(b: &[u8]) -> Option<(&[u8], &[u8])> {
    let s = b.iter().position(|&c| !is_space(c))?;
    let b = &b[s..];
    let e = b.iter().position(|&c| is_space(c)).unwrap_or(b.len());
    Some((&b[..e], &b[e..]))
}

/// Exactly `N` numbers and nothing else after them.
#[inline]
fn fast_numbers<const N: usize>(mut b: &[u8]) -> Option<[f32; N]> {
    let mut v = [0f32; N];
    for x in &mut v {
        let (w, rest) = next_word(b)?;
        *x = real_number(w)?;
        b = rest;
    }
    next_word(b).is_none().then_some(v)
}

/// The statements of real files on a fast path: `v x y z`, `vn x y z`, `vt u v` and faces with
/// positive indices. `Some` when the line was one of them (and is taken), `None` to leave it to
/// [`statement`] unchanged: for what it takes, [`statement`] gives the same result.
#[inline]
fn fast_statement(b: &[u8], c: &mut Chunk) -> Option<()> {
    match b {
        [b'v', b' ', rest @ ..] => {
            let [x, y, z] = fast_numbers::<3>(rest)?;
            c.data.positions.push(Vec3::new(x, y, z));
        }
        [b'v', b'n', b' ', rest @ ..] => {
            let [x, y, z] = fast_numbers::<3>(rest)?;
            c.data.normals.push(Vec3::new(x, y, z));
        }
        [b'v', b't', b' ', rest @ ..] => {
            let [u, v] = fast_numbers::<2>(rest)?;
            c.data.texcoords.push(Vec2::new(u, v));
        }
        [b'f', b' ', rest @ ..] => fast_face(rest, c)?,
        _ => return None,
    }
    Some(())
}

/// A face whose corners are `v`, `v/vt`, `v//vn` or `v/vt/vn` with positive indices of at most
/// 18 digits (see [`fast_statement`]).
#[inline]
fn fast_face(mut b: &[u8], c: &mut Chunk) -> Option<()> {
    let local = [
        c.data.positions.len(),
        c.data.texcoords.len(),
        c.data.normals.len(),
    ];
    let mut need = c.need;
    let mut corners = std::mem::take(&mut c.corners);
    corners.clear();
    let ok = (|| {
        while let Some((w, rest)) = next_word(b) {
            b = rest;
            let mut corner = Corner {
                index: [0, MISSING, MISSING],
                relative: 0,
            };
            let mut parts = w.split(|&x| x == b'/');
            for k in 0..3 {
                let Some(part) = parts.next() else { break };
                if part.is_empty() && k > 0 {
                    continue;
                }
                if part.is_empty() || part.len() > 18 || !part.iter().all(u8::is_ascii_digit) {
                    return None;
                }
                let i = part.iter().fold(0i64, |a, &d| a * 10 + (d - b'0') as i64);
                if i == 0 {
                    return None;
                }
                need[k] = need[k].max(i - local[k] as i64);
                corner.index[k] = (i - 1) as u32;
            }
            if parts.next().is_some() {
                return None;
            }
            corners.push(corner);
        }
        (corners.len() >= 3).then_some(())
    })();
    if ok.is_some() {
        c.need = need;
        fan(c, &corners);
    }
    c.corners = corners;
    ok
}

fn numbers<'a>(words: impl Iterator<Item = &'a str>, out: &mut [f32; 8]) -> Option<usize> {
    let mut n = 0;
    for w in words {
        let x = real_number(w.as_bytes())?;
        if n < out.len() {
            out[n] = x;
        }
        n += 1;
    }
    Some(n)
}

/// One line's statement.
fn statement(
    line: &str,
    line_no: usize,
    strict: bool,
    known: Option<Base>,
    c: &mut Chunk,
) -> Result<(), String> {
    let mut words = line.split_ascii_whitespace();
    let Some(kw) = words.next() else {
        return Ok(());
    };
    if kw.starts_with('#') {
        return Ok(());
    }
    let mut v = [0f32; 8];
    match kw {
        "v" => match numbers(words, &mut v) {
            Some(3) | Some(6) => c.data.positions.push(Vec3::new(v[0], v[1], v[2])),
            Some(4) if v[3] != 0.0 => {
                let w = v[3];
                c.data
                    .positions
                    .push(Vec3::new(v[0] / w, v[1] / w, v[2] / w));
            }
            Some(4) => {
                return Err(format!(
                    "vertex with w = 0 (a point at infinity): '{}'",
                    shown(line)
                ));
            }
            _ => {
                return Err(format!(
                    "malformed vertex: expected 'v x y z' (optionally w, or r g b) with numbers, got '{}'",
                    shown(line)
                ));
            }
        },
        "vt" => match numbers(words, &mut v) {
            Some(2 | 3) => c.data.texcoords.push(Vec2::new(v[0], v[1])),
            _ => {
                return Err(format!(
                    "malformed texture coordinate: expected 'vt u v' (optionally w) with numbers, got '{}'",
                    shown(line)
                ));
            }
        },
        "vn" => match numbers(words, &mut v) {
            Some(3) => c.data.normals.push(Vec3::new(v[0], v[1], v[2])),
            _ => {
                return Err(format!(
                    "malformed normal: expected 'vn x y z' with numbers, got '{}'",
                    shown(line)
                ));
            }
        },
        "f" => face(line, words, line_no, strict, known, c)?,
        "o" | "g" => c.data.events.push(Event {
            line: line_no,
            tri: c.data.triangles.len(),
            what: Statement::Group,
        }),
        "usemtl" | "mtllib" => {
            let rest = line.trim_ascii_start()[kw.len()..].trim();
            if rest.is_empty() {
                if strict {
                    return Err(format!("'{kw}' needs a name: '{}' (--strict)", shown(line)));
                }
                let odd = if kw == "usemtl" {
                    Oddity::BareUsemtl
                } else {
                    Oddity::BareMtllib
                };
                c.data.oddities[odd as usize].add(line_no);
                if kw == "mtllib" {
                    return Ok(());
                }
            }
            let what = if kw == "usemtl" {
                Statement::Usemtl((!rest.is_empty()).then(|| rest.to_string()))
            } else {
                Statement::Mtllib(rest.to_string())
            };
            c.data.events.push(Event {
                line: line_no,
                tri: c.data.triangles.len(),
                what,
            });
        }
        "s" => {}
        other => {
            if strict {
                return Err(format!(
                    "'{other}' statements are not supported: '{}' (--strict)",
                    shown(line)
                ));
            }
            match c.data.unused.iter_mut().find(|(k, _)| k == other) {
                Some((_, t)) => t.add(line_no),
                None => {
                    let mut t = Tally::default();
                    t.add(line_no);
                    c.data.unused.push((other.to_string(), t));
                }
            }
        }
    }
    debug_assert!(KEYWORDS.contains(&kw) || !strict);
    Ok(())
}

/// Kinds of index, as in [`Base::counts`] (and the low two bits of [`Chunk::relative`]).
const POSITION: u8 = 0;
const TEXCOORD: u8 = 1;
const NORMAL: u8 = 2;

/// One face corner: position, texture-coordinate and normal index, with "relative to the chunk"
/// flags.
#[derive(Clone, Copy, Debug)]
struct Corner {
    /// By kind ([`POSITION`], [`TEXCOORD`], [`NORMAL`]).
    index: [u32; 3],
    /// Bit k: `index[k]` is relative to the chunk.
    relative: u8,
}

/// An `f` statement: checks every vertex reference, then fans the polygon into triangles.
fn face<'a>(
    line: &str,
    words: impl Iterator<Item = &'a str> + Clone,
    line_no: usize,
    strict: bool,
    known: Option<Base>,
    c: &mut Chunk,
) -> Result<(), String> {
    if strict {
        let n = words.clone().count();
        if n < 3 {
            return Err(format!(
                "a face needs at least 3 vertices, this one has {n}: '{}' (--strict)",
                shown(line)
            ));
        }
    }
    let local = [
        c.data.positions.len(),
        c.data.texcoords.len(),
        c.data.normals.len(),
    ];
    let mut corners = std::mem::take(&mut c.corners);
    corners.clear();
    for r in words {
        match face_vertex(r, local, known, &mut c.need) {
            Ok(q) => corners.push(q),
            Err(e) => {
                c.corners = corners;
                return Err(e);
            }
        }
    }
    if corners.len() < 3 {
        c.data.oddities[Oddity::ShortFace as usize].add(line_no);
    } else {
        fan(c, &corners);
    }
    c.corners = corners;
    Ok(())
}

/// Fans a polygon's corners into triangles, (a, b, c), (a, c, d), ..., noting the corners whose
/// indices are relative to the chunk.
fn fan(c: &mut Chunk, corners: &[Corner]) {
    let a = corners[0];
    for k in 1..corners.len() - 1 {
        let tri = [a, corners[k], corners[k + 1]];
        let t = c.data.triangles.len() as u32;
        for (i, q) in tri.iter().enumerate() {
            if q.relative != 0 {
                for kind in [POSITION, TEXCOORD, NORMAL] {
                    if q.relative & (1 << kind) != 0 {
                        c.relative.push((t, ((i as u8) << 2) | kind));
                    }
                }
            }
        }
        c.data
            .triangles
            .push(tri.map(|q| q.index[POSITION as usize]));
        c.data
            .tri_normals
            .push(tri.map(|q| q.index[NORMAL as usize]));
        c.data
            .tri_texcoords
            .push(tri.map(|q| q.index[TEXCOORD as usize]));
    }
}

/// Powers of ten that are exact in f32.
const POW10: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// `s` as an f32, bit for bit what `str::parse::<f32>` gives, with a fast path for the short
/// decimals of real files (`-0.123456`): with at most 2^24 as the digits' integer and at most 10
/// of them after the point, both that integer and the power of ten are exact in f32, so one
/// correctly rounded division gives the correctly rounded value (the classic exact fast path of
/// decimal conversion, which the standard library's parser takes for them too). Everything else goes to the standard parser.
#[inline]
fn real_number(b: &[u8]) -> Option<f32> {
    let slow = || std::str::from_utf8(b).ok()?.parse().ok();
    let (neg, digits) = match b.first() {
        Some(b'-') => (true, &b[1..]),
        _ => (false, b),
    };
    let (mut m, mut count, mut after, mut point) = (0u32, 0u32, 0usize, false);
    for &c in digits {
        if c.is_ascii_digit() {
            if count == 9 {
                return slow();
            }
            m = m * 10 + (c - b'0') as u32;
            count += 1;
            after += point as usize;
        } else if c == b'.' && !point {
            point = true;
        } else {
            return slow();
        }
    }
    if count == 0 || m > 1 << 24 || after >= POW10.len() {
        return slow();
    }
    let x = m as f32 / POW10[after];
    Some(if neg { -x } else { x })
}

/// `s` as an i64, accepting exactly what `str::parse::<i64>` accepts (an optional sign and
/// decimal digits), with a fast path for the short unsigned indices of real files.
#[inline]
fn whole_number(s: &str) -> Option<i64> {
    let b = s.as_bytes();
    if !b.is_empty() && b.len() <= 18 && b.iter().all(u8::is_ascii_digit) {
        return Some(b.iter().fold(0i64, |a, &d| a * 10 + (d - b'0') as i64));
    }
    s.parse::<i64>().ok()
}

/// Checks one vertex of a face (`v`, `v/vt`, `v//vn`, `v/vt/vn`) and resolves its indices: against
/// the counts before the chunk when they are `known`, else recording in `need` what the chunk
/// must be preceded by.
fn face_vertex(
    r: &str,
    local: [usize; 3],
    known: Option<Base>,
    need: &mut [i64; 3],
) -> Result<Corner, String> {
    const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    const WHATS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    let mut parts = [""; 3];
    let mut n = 0;
    let mut from = 0;
    let bytes = r.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'/' {
            if n == 2 {
                n = 4;
                break;
            }
            parts[n] = &r[from..i];
            n += 1;
            from = i + 1;
        }
    }
    if n < 3 {
        parts[n] = &r[from..];
        n += 1;
    }
    if n > 3 || parts[0].is_empty() {
        return Err(format!(
            "malformed face vertex '{r}': expected v, v/vt, v//vn or v/vt/vn"
        ));
    }
    let mut corner = Corner {
        index: [0, MISSING, MISSING],
        relative: 0,
    };
    for (k, part) in parts[..n].iter().enumerate() {
        if part.is_empty() {
            continue; // v//vn
        }
        let Some(i) = whole_number(part) else {
            return Err(format!(
                "malformed face vertex '{r}': '{part}' is not a whole number"
            ));
        };
        if i == 0 {
            return Err(format!(
                "face {} index 0 in '{r}': OBJ indices start at 1 (or count back from -1)",
                WHAT[k]
            ));
        }
        let needs = i.unsigned_abs().min(i64::MAX as u64) as i64 - local[k] as i64;
        match known {
            Some(base) if needs > base.counts[k] as i64 => {
                return Err(format!(
                    "face refers to {} {i} (in '{r}'), but only {} {} are defined before this line",
                    WHAT[k],
                    base.counts[k] + local[k],
                    WHATS[k]
                ));
            }
            _ => need[k] = need[k].max(needs),
        }
        // In range once the base is checked (at most 2^32 - 1 of each, see the loader).
        let (index, rel) = if i > 0 {
            ((i - 1) as u32, 0)
        } else {
            ((local[k] as i64 + i) as u32, 1)
        };
        corner.index[k] = index;
        corner.relative |= rel << k;
    }
    Ok(corner)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses `text` as an OBJ file (written to a temporary file).
    fn parse(name: &str, text: &str) -> ObjData {
        let path = std::env::temp_dir().join(format!(
            "ftpd3d-obj-parse-{name}-{}.obj",
            std::process::id()
        ));
        std::fs::write(&path, text).unwrap();
        let data = parse_file(&path, false);
        let _ = std::fs::remove_file(&path);
        data.unwrap()
    }

    #[test]
    fn real_numbers_are_the_standard_parsers_bit_for_bit() {
        let fixed = [
            "0",
            "-0",
            "0.0",
            "-0.0",
            "1",
            "1.",
            ".5",
            "-.5",
            "0.1",
            "0.123456",
            "-0.812345",
            "16777216",
            "16777217",
            "16777215.5",
            "1234567.8",
            "0.0000001",
            "0.00000000001",
            "123456789",
            "1234567890",
            "99999999.9",
            "3.4028235e38",
            "1e-3",
            "+1.5",
            "inf",
            "-nan",
            "1.2.3",
            "",
            "-",
            ".",
            "1-2",
            "0x10",
            "00000000000001.5",
        ];
        for s in fixed {
            assert_eq!(
                real_number(s.as_bytes()).map(f32::to_bits),
                s.parse::<f32>().ok().map(f32::to_bits),
                "'{s}'"
            );
        }
        // Random decimals with 0-10 places and up to 10 digits, as exporters write them.
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = 1 + (x % 10) as usize;
            let m = (x >> 8) % 10u64.pow(digits as u32);
            let places = ((x >> 40) % 11) as usize;
            let mut s = format!("{m:0>width$}", width = places + 1);
            if places > 0 {
                s.insert(s.len() - places, '.');
            }
            if x & (1 << 60) != 0 {
                s.insert(0, '-');
            }
            assert_eq!(
                real_number(s.as_bytes()).map(f32::to_bits),
                s.parse::<f32>().ok().map(f32::to_bits),
                "'{s}'"
            );
        }
    }

    #[test]
    fn texture_coordinates_are_kept_per_corner_with_missing_ones_marked() {
        let d = parse(
            "vt",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nvt 0.25 0.5\nvt 1 0 7\nvt 0 1\n\
             f 1/1 2/2 3/3 4/1\nf 1/1/ 2/-1 3/-2\nf -4/-3/ 2/2 3\n",
        );
        assert_eq!(
            d.texcoords,
            [
                Vec2::new(0.25, 0.5),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.0, 1.0)
            ]
        );
        assert_eq!(d.triangles.len(), 5);
        assert_eq!(
            d.tri_texcoords,
            [
                [MISSING; 3],
                [0, 1, 2],
                [0, 2, 0],
                [0, 2, 1],
                [0, 1, MISSING]
            ]
        );
        let none = parse("no-vt", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
        assert!(none.texcoords.is_empty() && none.tri_texcoords.is_empty());
    }

    #[test]
    fn chunks_stitch_texture_coordinate_indices_relative_and_absolute() {
        // Several 1 MB chunks: each quad's corners refer to its own vt by negative indices and to
        // the file's first vt by a positive one; the vt first appear after some faces.
        let mut text = String::from("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
        let quads = 60_000;
        for q in 0..quads {
            text.push_str(&format!(
                "v {q} 0 0\nv {q} 1 0\nv {q} 1 1\nv {q} 0 1\nvt {q} 0\nvt {q} 1\nvt {q} 2\n\
                 f -4/-3 -3/-2 -2/-1 -1/1\n"
            ));
        }
        assert!(text.len() > 4 * CHUNK_BYTES);
        let d = parse("chunks", &text);
        assert_eq!(d.texcoords.len(), 3 * quads);
        assert_eq!(d.triangles.len(), 1 + 2 * quads);
        assert_eq!(d.tri_texcoords[0], [MISSING; 3]);
        for q in 0..quads {
            let (v, t) = (3 + 4 * q as u32, 3 * q as u32);
            assert_eq!(d.triangles[1 + 2 * q], [v, v + 1, v + 2]);
            assert_eq!(d.triangles[2 + 2 * q], [v, v + 2, v + 3]);
            assert_eq!(d.tri_texcoords[1 + 2 * q], [t, t + 1, t + 2]);
            assert_eq!(d.tri_texcoords[2 + 2 * q], [t, t + 2, 0]);
            assert_eq!(d.texcoords[t as usize + 2], Vec2::new(q as f32, 2.0));
        }
    }

    /// A random statement of the kinds the byte-level path looks at (`v`, `vn`, `vt`, `f`). Most
    /// are well formed, in the spellings of real files and others (signs, exponents, long
    /// mantissas, tabs, `\r`, `v/vt/vn` corner forms, relative indices); one in eight is drawn
    /// from malformed pieces (missing, extra or bad numbers, zero and huge indices, comments,
    /// other statements, bytes that are not UTF-8), which the byte-level path must leave to
    /// [`statement`].
    fn random_line(rng: &mut rand_pcg::Pcg64Mcg) -> Vec<u8> {
        use rand_core::Rng;
        let mut pick = |n: usize| rng.next_u32() as usize % n;
        const GOOD_NUMBERS: [&str; 16] = [
            "0",
            "-0",
            "1",
            "-1.5",
            "0.25",
            ".5",
            "5.",
            "+2",
            "1e3",
            "-2.5E-3",
            "16777217",
            "3.14159265358979",
            "0.1234567890123",
            "123456789012",
            "1e-45",
            "-7.000001",
        ];
        const BAD_NUMBERS: [&str; 9] = [
            "1e",
            "1.2.3",
            "nan",
            "inf",
            "0x10",
            "1,5",
            "x",
            "99999999999999999999e-20",
            "--1",
        ];
        const GOOD_INDICES: [&str; 6] = ["1", "2", "3", "7", "-1", "-2"];
        const BAD_INDICES: [&str; 8] = [
            "0",
            "",
            "a",
            "4294967296",
            "12345678901234567890",
            "+1",
            "1.0",
            "-99",
        ];
        const SPACES: [&str; 5] = [" ", " ", "  ", "\t", " \t "];
        let good = pick(8) != 0;
        let number = |pick: &mut dyn FnMut(usize) -> usize| {
            if good || pick(2) == 0 {
                GOOD_NUMBERS[pick(GOOD_NUMBERS.len())]
            } else {
                BAD_NUMBERS[pick(BAD_NUMBERS.len())]
            }
        };
        let index = |pick: &mut dyn FnMut(usize) -> usize| {
            if good || pick(2) == 0 {
                GOOD_INDICES[pick(GOOD_INDICES.len())]
            } else {
                BAD_INDICES[pick(BAD_INDICES.len())]
            }
        };
        let mut line = String::new();
        let (keyword, count) = match pick(if good { 5 } else { 8 }) {
            0 | 1 => ("v", 3),
            2 => ("vn", 3),
            3 => ("vt", 2),
            4 => ("f", 3 + pick(3)),
            5 => ("#", 2),
            6 => ("usemtl", 1),
            _ => ("vp", 2),
        };
        let count = if good { count } else { pick(6) };
        line.push_str(keyword);
        // Corner form of the whole face: v, v/vt, v//vn or v/vt/vn.
        let form = pick(4);
        for _ in 0..count {
            line.push_str(SPACES[if good && pick(2) == 0 { 0 } else { pick(5) }]);
            if keyword != "f" {
                line.push_str(number(&mut pick));
                continue;
            }
            line.push_str(index(&mut pick));
            let form = if good { form } else { pick(4) };
            if form == 1 || form == 3 {
                line.push('/');
                line.push_str(index(&mut pick));
            }
            if form == 2 {
                line.push('/');
            }
            if form >= 2 {
                line.push('/');
                line.push_str(index(&mut pick));
            }
        }
        if pick(8) == 0 {
            line.push_str(SPACES[pick(5)]);
        }
        let mut bytes = line.into_bytes();
        match pick(16) {
            0 => bytes.push(b'\r'),
            1 if !good => bytes.insert(pick(bytes.len() + 1), 0xE9),
            _ => {}
        }
        bytes
    }

    /// The byte-level path takes a line only where [`statement`] gives the same result: chunks of
    /// random lines parse to the same data, indices, needs and first error with and without it.
    #[test]
    fn byte_level_path_agrees_with_the_statement_parser() {
        use rand_core::SeedableRng;
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(13);
        let (mut fast, mut slow) = (Chunk::default(), Chunk::default());
        let mut taken = 0;
        for _ in 0..3000 {
            let mut bytes = Vec::new();
            for _ in 0..1 + (rand_core::Rng::next_u32(&mut rng) % 12) {
                bytes.extend(random_line(&mut rng));
                bytes.push(b'\n');
            }
            for strict in [false, true] {
                parse_lines(&mut fast, &bytes, strict, None, true);
                parse_lines(&mut slow, &bytes, strict, None, false);
                let state = |c: &Chunk| format!("{:?}", (&c.data, &c.relative, c.need, &c.error));
                assert_eq!(
                    state(&fast),
                    state(&slow),
                    "{}",
                    String::from_utf8_lossy(&bytes)
                );
                taken += fast.data.positions.len() + fast.data.triangles.len();
            }
        }
        // The lines are not all refused: both parsers take many of them.
        assert!(taken > 10_000, "{taken}");
    }

    #[test]
    fn lines_longer_than_chunks_and_errors_past_them_keep_their_line_numbers() {
        // Comment lines of 2.5 and 1.5 chunks: chunks in which no line starts, lines that start
        // in one chunk and end several chunks on, block edges inside a line.
        let long = |n: usize| format!("# {}\n", "x".repeat(n));
        let mut text = long(5 * CHUNK_BYTES / 2);
        let mut lines = 1;
        for q in 0..40_000 {
            text.push_str(&format!("v {q} 0 0\nv {q} 1 0\nv {q} 1 1\nf -3 -2 -1\n"));
            lines += 4;
            if q == 20_000 {
                text.push_str(&long(3 * CHUNK_BYTES / 2));
                lines += 1;
            }
        }
        let d = parse("long-lines", &text);
        assert_eq!(
            (d.triangles.len(), d.positions.len(), d.lines),
            (40_000, 120_000, lines)
        );
        assert_eq!(d.triangles[39_999], [119_997, 119_998, 119_999]);
        // The same file with a bad line at the end, and again without a final newline.
        for end in ["f 1 2 999999\n", "f 1 2 999999"] {
            let bad = format!("{text}{end}");
            let path = std::env::temp_dir().join(format!(
                "ftpd3d-obj-parse-long-bad-{}.obj",
                std::process::id()
            ));
            std::fs::write(&path, &bad).unwrap();
            let err = parse_file(&path, false).unwrap_err();
            let _ = std::fs::remove_file(&path);
            assert_eq!(err.0, lines + 1, "{err:?}");
            assert!(err.1.contains("vertex 999999"), "{err:?}");
        }
    }
}
