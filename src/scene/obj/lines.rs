//! OBJ lines, one statement each: `v`, `vt`, `vn`, `f`, `o`, `g`, `s`, `usemtl`, `mtllib`, and the
//! statements the loader does not use. The lines of real files first go through a byte-level
//! path; whatever it does not take goes through the statement parser, which gives the same result
//! for what the fast path takes and names the first bad line.

use crate::scene::obj::data::{Base, Event, Lines, Statement};
use crate::scene::obj::face::{face, fast_face};
use crate::scene::obj::token::{continued, fast_numbers, latin1, numbers};
use crate::scene::obj::tolerance::{LineFault, Oddity, Tally, shown};
use glam::{Vec2, Vec3};

/// The statements the loader uses (`#` starts a comment).
const KEYWORDS: &[&str] = &["v", "vt", "vn", "f", "o", "g", "s", "mtllib", "usemtl"];

/// Parses one chunk of whole lines. With `known`, the counts before the chunk are known and face
/// references are checked against them exactly (the slow path that names the first bad line).
pub(super) fn parse_chunk(c: &mut Lines, bytes: &[u8], strict: bool, known: Option<Base>) {
    parse_lines(c, bytes, strict, known, known.is_none());
}

/// [`parse_chunk`], with the byte-level path for the lines of real files when `fast`. Lines that
/// end in a backslash are joined with the next (the OBJ format's line continuation) first.
fn parse_lines(c: &mut Lines, bytes: &[u8], strict: bool, known: Option<Base>, fast: bool) {
    let joined;
    let bytes = if memchr::memchr(b'\\', bytes).is_some() {
        joined = join_continued(bytes);
        &joined[..]
    } else {
        bytes
    };
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
                    c.error = Some((line_no, LineFault::Strict("not UTF-8 text".into())));
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

/// `bytes` with every line that ends in a backslash joined to the next by a space, and after each
/// joined line as many empty lines as it took, so that the lines after it keep their numbers (a
/// joined line is numbered by its first).
pub(super) fn join_continued(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    let mut pending = 0usize;
    let mut start = 0;
    while start < bytes.len() {
        let end = memchr::memchr(b'\n', &bytes[start..]).map_or(bytes.len(), |i| start + i);
        let line = &bytes[start..end];
        if continued(line) && end < bytes.len() {
            let body = line.strip_suffix(b"\r").unwrap_or(line);
            out.extend_from_slice(&body[..body.len() - 1]);
            out.push(b' ');
            pending += 1;
        } else {
            out.extend_from_slice(line);
            if end < bytes.len() {
                out.push(b'\n');
            }
            out.extend(std::iter::repeat_n(b'\n', pending));
            pending = 0;
        }
        start = end + 1;
    }
    out
}

/// The statements of real files on a fast path: `v x y z`, `vn x y z`, `vt u v` and faces with
/// positive indices. `Some` when the line was one of them (and is taken), `None` to leave it to
/// [`statement`] unchanged: for what it takes, [`statement`] gives the same result.
#[inline]
fn fast_statement(b: &[u8], c: &mut Lines) -> Option<()> {
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

/// One line's statement.
fn statement(
    line: &str,
    line_no: usize,
    strict: bool,
    known: Option<Base>,
    c: &mut Lines,
) -> Result<(), LineFault> {
    let mut words = line.split_ascii_whitespace();
    let Some(kw) = words.next() else {
        return Ok(());
    };
    if kw.starts_with('#') {
        return Ok(());
    }
    match kw {
        "v" => vertex(line, words, c)?,
        "vt" => texcoord(line, words, c)?,
        "vn" => normal(line, words, c)?,
        "f" => face(line, words, line_no, strict, known, c)?,
        "o" | "g" => c.data.events.push(Event {
            line: line_no,
            tri: c.data.triangles.len(),
            what: Statement::Group,
        }),
        "usemtl" | "mtllib" => material_statement(line, kw, line_no, strict, c)?,
        "s" => {}
        other => unused_statement(line, other, line_no, strict, c)?,
    }
    debug_assert!(KEYWORDS.contains(&kw) || !strict);
    Ok(())
}

/// `v x y z`, optionally with w (divided out) or a colour (ignored).
fn vertex<'a>(
    line: &str,
    words: impl Iterator<Item = &'a str>,
    c: &mut Lines,
) -> Result<(), LineFault> {
    let mut v = [0f32; 8];
    match numbers(words, &mut v) {
        Some(3) | Some(6) => c.data.positions.push(Vec3::new(v[0], v[1], v[2])),
        Some(4) if v[3] != 0.0 => {
            let w = v[3];
            c.data
                .positions
                .push(Vec3::new(v[0] / w, v[1] / w, v[2] / w));
        }
        Some(4) => {
            return Err(LineFault::Malformed(format!(
                "vertex with w = 0 (a point at infinity): '{}'",
                shown(line)
            )));
        }
        _ => {
            return Err(LineFault::Malformed(format!(
                "malformed vertex: expected 'v x y z' (optionally w, or r g b) with numbers, got '{}'",
                shown(line)
            )));
        }
    }
    Ok(())
}

/// `vt u v`, optionally with w (dropped).
fn texcoord<'a>(
    line: &str,
    words: impl Iterator<Item = &'a str>,
    c: &mut Lines,
) -> Result<(), LineFault> {
    let mut v = [0f32; 8];
    match numbers(words, &mut v) {
        Some(2 | 3) => c.data.texcoords.push(Vec2::new(v[0], v[1])),
        _ => {
            return Err(LineFault::Malformed(format!(
                "malformed texture coordinate: expected 'vt u v' (optionally w) with numbers, got '{}'",
                shown(line)
            )));
        }
    }
    Ok(())
}

/// `vn x y z`.
fn normal<'a>(
    line: &str,
    words: impl Iterator<Item = &'a str>,
    c: &mut Lines,
) -> Result<(), LineFault> {
    let mut v = [0f32; 8];
    match numbers(words, &mut v) {
        Some(3) => c.data.normals.push(Vec3::new(v[0], v[1], v[2])),
        _ => {
            return Err(LineFault::Malformed(format!(
                "malformed normal: expected 'vn x y z' with numbers, got '{}'",
                shown(line)
            )));
        }
    }
    Ok(())
}

/// `usemtl NAME` or `mtllib FILE` (`kw`): an event for the loader; without a name, an oddity.
fn material_statement(
    line: &str,
    kw: &str,
    line_no: usize,
    strict: bool,
    c: &mut Lines,
) -> Result<(), LineFault> {
    let rest = line.trim_ascii_start()[kw.len()..].trim();
    if rest.is_empty() {
        if strict {
            return Err(LineFault::Strict(format!(
                "'{kw}' needs a name: '{}'",
                shown(line)
            )));
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
    Ok(())
}

/// A statement the loader does not use (keyword `kw`): tallied by keyword.
fn unused_statement(
    line: &str,
    kw: &str,
    line_no: usize,
    strict: bool,
    c: &mut Lines,
) -> Result<(), LineFault> {
    if strict {
        return Err(LineFault::Strict(format!(
            "'{kw}' statements are not supported: '{}'",
            shown(line)
        )));
    }
    match c.data.unused.iter_mut().find(|(k, _)| k == kw) {
        Some((_, t)) => t.add(line_no),
        None => {
            let mut t = Tally::default();
            t.add(line_no);
            c.data.unused.push((kw.to_string(), t));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numbers as exporters write them, and malformed ones.
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
    /// Face indices, absolute and relative, and malformed ones (zero, empty, too large, signed,
    /// not whole, past the vertices).
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

    /// Random choices for [`random_line`].
    struct Pick<'a>(&'a mut rand_pcg::Pcg64Mcg);

    impl Pick<'_> {
        /// Uniform in 0..n.
        fn below(&mut self, n: usize) -> usize {
            rand_core::Rng::next_u32(self.0) as usize % n
        }

        /// A piece of `good`, or for a malformed line one of `good` or `bad` with even odds.
        fn piece(
            &mut self,
            good_line: bool,
            good: &[&'static str],
            bad: &[&'static str],
        ) -> &'static str {
            if good_line || self.below(2) == 0 {
                good[self.below(good.len())]
            } else {
                bad[self.below(bad.len())]
            }
        }
    }

    /// A random statement of the kinds the byte-level path looks at (`v`, `vn`, `vt`, `f`). Most
    /// are well formed, in the spellings of real files and others (signs, exponents, long
    /// mantissas, tabs, `\r`, `v/vt/vn` corner forms, relative indices); one in eight is drawn
    /// from malformed pieces (missing, extra or bad numbers, zero and huge indices, comments,
    /// other statements, bytes that are not UTF-8), which the byte-level path must leave to
    /// [`statement`].
    fn random_line(rng: &mut rand_pcg::Pcg64Mcg) -> Vec<u8> {
        let mut p = Pick(rng);
        let good = p.below(8) != 0;
        let (keyword, count) = random_keyword(&mut p, good);
        let mut line = String::from(keyword);
        // Corner form of the whole face: v, v/vt, v//vn or v/vt/vn.
        let form = p.below(4);
        for _ in 0..count {
            line.push_str(
                SPACES[if good && p.below(2) == 0 {
                    0
                } else {
                    p.below(5)
                }],
            );
            if keyword == "f" {
                push_corner(&mut line, &mut p, good, form);
            } else {
                line.push_str(p.piece(good, &GOOD_NUMBERS, &BAD_NUMBERS));
            }
        }
        if p.below(8) == 0 {
            line.push_str(SPACES[p.below(5)]);
        }
        let mut bytes = line.into_bytes();
        match p.below(16) {
            0 => bytes.push(b'\r'),
            1 if !good => bytes.insert(p.below(bytes.len() + 1), 0xE9),
            _ => {}
        }
        bytes
    }

    /// The keyword of a random line and how many words follow it: for a malformed line also a
    /// comment, another statement and any count.
    fn random_keyword(p: &mut Pick, good: bool) -> (&'static str, usize) {
        let (keyword, count) = match p.below(if good { 5 } else { 8 }) {
            0 | 1 => ("v", 3),
            2 => ("vn", 3),
            3 => ("vt", 2),
            4 => ("f", 3 + p.below(3)),
            5 => ("#", 2),
            6 => ("usemtl", 1),
            _ => ("vp", 2),
        };
        (keyword, if good { count } else { p.below(6) })
    }

    /// One face corner in `form` (a malformed line draws each corner's own).
    fn push_corner(line: &mut String, p: &mut Pick, good: bool, form: usize) {
        line.push_str(p.piece(good, &GOOD_INDICES, &BAD_INDICES));
        let form = if good { form } else { p.below(4) };
        if form == 1 || form == 3 {
            line.push('/');
            line.push_str(p.piece(good, &GOOD_INDICES, &BAD_INDICES));
        }
        if form == 2 {
            line.push('/');
        }
        if form >= 2 {
            line.push('/');
            line.push_str(p.piece(good, &GOOD_INDICES, &BAD_INDICES));
        }
    }

    /// The byte-level path takes a line only where [`statement`] gives the same result: chunks of
    /// random lines parse to the same data, indices, needs and first error with and without it.
    #[test]
    fn byte_level_path_agrees_with_the_statement_parser() {
        use rand_core::SeedableRng;
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(13);
        let (mut fast, mut slow) = (Lines::default(), Lines::default());
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
                let state = |c: &Lines| format!("{:?}", (&c.data, &c.relative, c.need, &c.error));
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
}
