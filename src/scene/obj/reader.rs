//! Reading an OBJ file, built for files of millions of faces: the file is cut into chunks of
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
//! Recoverable oddities are tallied per chunk and added up here, in file order
//! ([`crate::scene::obj::tolerance`]); with `strict` they are errors at their line.

use crate::scene::obj::data::{Base, Event, Lines, MISSING, NORMAL, ObjData, POSITION};
use crate::scene::obj::lines::parse_chunk;
use crate::scene::obj::tolerance::{LineFault, Tally};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::fs::File;

/// Chunks per block: a block's chunks are read, parsed and stitched while nothing else of the file
/// is held (their buffers are reused from block to block).
const BLOCK_CHUNKS: usize = 32;
/// The byte range of a chunk (the unit of parallel work).
const CHUNK_BYTES: usize = 1 << 20;
/// Bytes read past a chunk's range at first, to finish its last line (more when it is longer).
const SLACK_BYTES: usize = 8 << 10;

/// Why an OBJ file could not be parsed.
#[derive(Debug)]
pub(super) enum ParseError {
    /// Reading failed.
    Io(std::io::Error),
    /// The file changed while it was read: a chunk found fewer bytes, or adjacent chunks did not
    /// meet, or the length or modification time changed.
    Changed,
    /// A line (1-based) that cannot be read, or that strict loading refuses.
    Line(usize, LineFault),
}

/// One chunk: the bytes read for it and the parse of its lines.
#[derive(Debug, Default)]
struct Chunk {
    lines: Lines,
    /// The bytes read for the chunk (reused; only the first `have` are this chunk's), from file
    /// offset `from`.
    buf: Vec<u8>,
    from: u64,
    have: usize,
    /// File offsets where the chunk's first line starts and its last line ends (after its
    /// `\n`); equal when no line starts in its range.
    span: (u64, u64),
    /// A read error, or a file that is shorter than when it was opened.
    io_error: Option<ParseError>,
}

impl Chunk {
    /// Empties the chunk for the next one, keeping its buffers.
    fn reset(&mut self) {
        self.lines.reset();
        self.have = 0;
        self.io_error = None;
    }

    /// Reads `more` bytes (fewer at the end of the file) after those the chunk has.
    fn read_more(&mut self, file: &File, len: u64, more: usize) -> Result<(), ParseError> {
        let at = self.from + self.have as u64;
        let want = (more as u64).min(len.saturating_sub(at)) as usize;
        let new = self.have + want;
        if self.buf.len() < new {
            // Grows only: a reused buffer is not zeroed again.
            self.buf.resize(new, 0);
        }
        read_exact_at(file, &mut self.buf[self.have..new], at).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                ParseError::Changed
            } else {
                ParseError::Io(e)
            }
        })?;
        self.have = new;
        Ok(())
    }

    /// The offset of the first `\n` at or after file offset `at` (at least `from`), reading on
    /// as needed; `len` when the file ends first.
    fn newline_from(&mut self, file: &File, len: u64, at: u64) -> Result<u64, ParseError> {
        let mut i = (at - self.from) as usize;
        loop {
            if i < self.have
                && let Some(k) = memchr::memchr(b'\n', &self.buf[i..self.have])
            {
                // A line that ends in `\` goes on on the next one: not a line end.
                if crate::scene::obj::token::continued(&self.buf[..i + k]) {
                    i += k + 1;
                    continue;
                }
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
                let bytes = &self.buf[(span.0 - self.from) as usize..(span.1 - self.from) as usize];
                parse_chunk(&mut self.lines, bytes, strict, None);
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

/// Parses the OBJ file at `path` (see the module docs).
pub(super) fn parse_file(path: &std::path::Path, strict: bool) -> Result<ObjData, ParseError> {
    let io = ParseError::Io;
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
        return Err(ParseError::Changed);
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
) -> Result<u64, ParseError> {
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
    for chunk in chunks.iter_mut() {
        if let Some(e) = chunk.io_error.take() {
            return Err(e);
        }
        if chunk.span.0 != at {
            return Err(ParseError::Changed);
        }
        at = chunk.span.1;
        let short = (0..3).any(|i| chunk.lines.need[i] > base.counts[i] as i64);
        if chunk.lines.error.is_some() || short {
            // Again with the base known: the first bad line, as a sequential parse finds it.
            let mut again = Lines::default();
            parse_chunk(&mut again, chunk.bytes(), strict, Some(base));
            let (line, fault) = again.error.unwrap_or_else(|| {
                let what = "inconsistent parse (please report it)";
                (1, LineFault::Malformed(what.into()))
            });
            return Err(ParseError::Line(base.line + line, fault));
        }
        bases.push((base, tris));
        let d = &chunk.lines.data;
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
    let with_vt = grow_arrays(out, chunks, old);
    destinations(out, chunks, old, with_vt)
        .into_par_iter()
        .zip(chunks.par_iter().zip(bases))
        .for_each(|(d, (chunk, (base, _)))| d.fill(&chunk.lines, base));
    for (chunk, (base, tri0)) in chunks.iter().zip(bases) {
        append_events(out, &chunk.lines.data, base, *tri0);
    }
}

/// Lengthens the file's arrays by what the chunks hold (the counts before them are `old`:
/// positions, texture coordinates, normals; triangles); returns whether the per-corner texture
/// coordinate indices are kept, which they are once the file has had a `vt` (the triangles before
/// the first one have none).
fn grow_arrays(out: &mut ObjData, chunks: &[Chunk], old: ([usize; 3], usize)) -> bool {
    let sum = |f: fn(&ObjData) -> usize| chunks.iter().map(|c| f(&c.lines.data)).sum::<usize>();
    let tris = old.1 + sum(|d| d.triangles.len());
    grow(&mut out.positions, old.0[0] + sum(|d| d.positions.len()));
    grow(&mut out.texcoords, old.0[1] + sum(|d| d.texcoords.len()));
    grow(&mut out.normals, old.0[2] + sum(|d| d.normals.len()));
    grow(&mut out.triangles, tris);
    grow(&mut out.tri_normals, tris);
    let with_vt = !out.texcoords.is_empty();
    if with_vt {
        if out.tri_texcoords.len() < old.1 {
            out.tri_texcoords.resize(old.1, [MISSING; 3]);
        }
        grow(&mut out.tri_texcoords, tris);
    }
    with_vt
}

/// Where each chunk's arrays go in the file's (grown by [`grow_arrays`]).
fn destinations<'a>(
    out: &'a mut ObjData,
    chunks: &[Chunk],
    old: ([usize; 3], usize),
    with_vt: bool,
) -> Vec<Dest<'a>> {
    let lens = |f: fn(&ObjData) -> usize| chunks.iter().map(move |c| f(&c.lines.data));
    let mut tri_texcoords: Vec<Option<&mut [[u32; 3]]>> = if with_vt {
        split(&mut out.tri_texcoords, old.1, lens(|d| d.triangles.len()))
            .into_iter()
            .map(Some)
            .collect()
    } else {
        (0..chunks.len()).map(|_| None).collect()
    };
    split(&mut out.positions, old.0[0], lens(|d| d.positions.len()))
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
        .collect()
}

impl Dest<'_> {
    /// Copies a chunk's arrays here, adding its base counts to its relative indices.
    fn fill(self, lines: &Lines, base: &Base) {
        let data = &lines.data;
        self.positions.copy_from_slice(&data.positions);
        self.normals.copy_from_slice(&data.normals);
        self.texcoords.copy_from_slice(&data.texcoords);
        self.triangles.copy_from_slice(&data.triangles);
        self.tri_normals.copy_from_slice(&data.tri_normals);
        let mut tri_texcoords = self.tri_texcoords;
        if let Some(t) = tri_texcoords.as_deref_mut() {
            t.copy_from_slice(&data.tri_texcoords);
        }
        for &(t, which) in &lines.relative {
            let (t, c, kind) = (t as usize, (which >> 2) as usize, which & 3);
            let v = match kind {
                POSITION => &mut self.triangles[t][c],
                NORMAL => &mut self.tri_normals[t][c],
                // A relative vt index means the chunk has vt, so the file has.
                _ => match tri_texcoords.as_deref_mut() {
                    Some(tt) => &mut tt[t][c],
                    None => continue,
                },
            };
            *v = v.wrapping_add(base.counts[kind as usize] as u32);
        }
    }
}

/// Appends a chunk's events and tallies (`base`: the counts and lines before it; `tri0`: its first
/// triangle) to the file's.
fn append_events(out: &mut ObjData, data: &ObjData, base: &Base, tri0: usize) {
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
            let ParseError::Line(line, LineFault::Malformed(what)) = &err else {
                panic!("{err:?}");
            };
            assert_eq!(*line, lines + 1, "{err:?}");
            assert!(what.contains("vertex 999999"), "{err:?}");
        }
    }
}
