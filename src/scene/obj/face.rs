//! Faces: each corner's references checked and resolved (against the counts before the chunk when
//! they are known, else noted as what the chunk needs), and polygons fanned from their first
//! vertex, (a, b, c), (a, c, d), ..., in file order.

use crate::scene::obj::data::{Base, Corner, Lines, MISSING, NORMAL, POSITION, TEXCOORD};
use crate::scene::obj::token::{next_word, whole_number};
use crate::scene::obj::tolerance::{LineFault, Oddity, shown};

/// An `f` statement: checks every vertex reference, then fans the polygon into triangles.
pub(super) fn face<'a>(
    line: &str,
    words: impl Iterator<Item = &'a str> + Clone,
    line_no: usize,
    strict: bool,
    known: Option<Base>,
    c: &mut Lines,
) -> Result<(), LineFault> {
    if strict {
        let n = words.clone().count();
        if n < 3 {
            return Err(LineFault::Strict(format!(
                "a face needs at least 3 vertices, this one has {n}: '{}'",
                shown(line)
            )));
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
fn fan(c: &mut Lines, corners: &[Corner]) {
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

/// A face whose corners are `v`, `v/vt`, `v//vn` or `v/vt/vn` with positive indices of at most
/// 18 digits (see `fast_statement`).
#[inline]
pub(super) fn fast_face(mut b: &[u8], c: &mut Lines) -> Option<()> {
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

/// Checks one vertex of a face (`v`, `v/vt`, `v//vn`, `v/vt/vn`) and resolves its indices: against
/// the counts before the chunk when they are `known`, else recording in `need` what the chunk
/// must be preceded by.
fn face_vertex(
    r: &str,
    local: [usize; 3],
    known: Option<Base>,
    need: &mut [i64; 3],
) -> Result<Corner, LineFault> {
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
        return Err(LineFault::Malformed(format!(
            "malformed face vertex '{r}': expected v, v/vt, v//vn or v/vt/vn"
        )));
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
            return Err(LineFault::Malformed(format!(
                "malformed face vertex '{r}': '{part}' is not a whole number"
            )));
        };
        if i == 0 {
            return Err(LineFault::Malformed(format!(
                "face {} index 0 in '{r}': OBJ indices start at 1 (or count back from -1)",
                WHAT[k]
            )));
        }
        let needs = i.unsigned_abs().min(i64::MAX as u64) as i64 - local[k] as i64;
        match known {
            Some(base) if needs > base.counts[k] as i64 => {
                return Err(LineFault::Malformed(format!(
                    "face refers to {} {i} (in '{r}'), but only {} {} are defined before this line",
                    WHAT[k],
                    base.counts[k] + local[k],
                    WHATS[k]
                )));
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
