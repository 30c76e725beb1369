//! The loader's tolerance: what mainstream OBJ loaders go on past (faces of fewer than 3 vertices,
//! `usemtl` or `mtllib` without a name, statements the loader does not use, lines that are not
//! UTF-8, read as Latin-1) is tallied, count and first line, for one warning per kind; strict
//! loading refuses each at its line instead.

/// What is wrong with a line, in the library's terms (the line's start quoted): malformed, or
/// tolerated by a default load but refused by strict loading.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum LineFault {
    Malformed(String),
    Strict(String),
}

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
    pub(super) fn add(&mut self, line: usize) {
        if self.count == 0 {
            self.first = line;
        }
        self.count += 1;
    }
    /// Adds a later chunk's tally whose lines are `offset` lines further on.
    pub(super) fn merge(&mut self, later: &Tally, offset: usize) {
        if later.count > 0 {
            if self.count == 0 {
                self.first = later.first + offset;
            }
            self.count += later.count;
        }
    }
}

/// The first 60 characters of a line, for messages.
pub(super) fn shown(line: &str) -> String {
    let line = line.trim();
    let mut s: String = line.chars().take(60).collect();
    if line.chars().count() > 60 {
        s.push('…');
    }
    s
}

/// The warnings of a tolerant parse of `file`, one per kind (each oddity, and the statements the
/// loader does not use), in the order of their first lines.
pub(super) fn warnings(
    file: &str,
    oddities: &[Tally; 4],
    statements: &[(String, Tally)],
) -> Vec<String> {
    let times = |t: &Tally| {
        if t.count == 1 {
            String::new()
        } else {
            format!(", {} lines", t.count)
        }
    };
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut unused = Tally::default();
    for (_, t) in statements {
        if unused.count == 0 || t.first < unused.first {
            unused.first = t.first;
        }
        unused.count += t.count;
    }
    if unused.count > 0 {
        let kinds: Vec<String> = statements
            .iter()
            .map(|(k, t)| match t.count {
                1 => format!("'{k}'"),
                c => format!("'{k}' ×{c}"),
            })
            .collect();
        out.push((
            unused.first,
            format!(
                "{file}:{}: statements the loader does not use ({}); ignored{}",
                unused.first,
                kinds.join(", "),
                times(&unused)
            ),
        ));
    }
    for kind in ODDITIES {
        let t = &oddities[kind as usize];
        if t.count == 0 {
            continue;
        }
        let what = match kind {
            Oddity::ShortFace => "faces with fewer than 3 vertices (points, lines); skipped",
            Oddity::BareUsemtl => {
                "'usemtl' without a name; the faces after it get the default material"
            }
            Oddity::BareMtllib => "'mtllib' without a file name; ignored",
            Oddity::NotUtf8 => "not UTF-8 text; read as Latin-1",
        };
        out.push((t.first, format!("{file}:{}: {what}{}", t.first, times(t))));
    }
    out.sort_by_key(|(line, _)| *line);
    out.into_iter().map(|(_, w)| w).collect()
}
