//! The decoder of EXT_meshopt_compression (and of KHR_meshopt_compression where its bitstream is
//! the same: attribute codec version 0, the filters below): buffer views stored with
//! meshoptimizer's codecs (Appendix A of the extension's specification: attributes, triangles
//! and indices; Appendix B: the octahedral, quaternion and exponential filters). Safe code
//! throughout: every read is checked, so a malformed stream gives an error, never a panic. Only
//! attribute codec 0 and triangle codec 1 are read; KHR's attribute codec 1 (control and channel
//! modes) and COLOR filter are refused by name.

/// The compression mode of a buffer view (the extension's `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Mode {
    Attributes,
    Triangles,
    Indices,
}

/// The filter applied after the attribute codec (the extension's `filter`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
}

impl Mode {
    pub(super) fn parse(s: &str) -> Option<Mode> {
        Some(match s {
            "ATTRIBUTES" => Mode::Attributes,
            "TRIANGLES" => Mode::Triangles,
            "INDICES" => Mode::Indices,
            _ => return None,
        })
    }
}

impl Filter {
    pub(super) fn parse(s: &str) -> Option<Filter> {
        Some(match s {
            "NONE" => Filter::None,
            "OCTAHEDRAL" => Filter::Octahedral,
            "QUATERNION" => Filter::Quaternion,
            "EXPONENTIAL" => Filter::Exponential,
            _ => return None,
        })
    }
}

/// Decodes `count` elements of `stride` bytes from `data` in `mode`, then applies `filter`; the
/// combinations the specification forbids are refused.
pub(super) fn decode(
    data: &[u8],
    count: usize,
    stride: usize,
    mode: Mode,
    filter: Filter,
) -> Result<Vec<u8>, String> {
    let size = count
        .checked_mul(stride)
        .ok_or_else(|| format!("{count} elements of {stride} bytes are too many"))?;
    match mode {
        Mode::Attributes if stride == 0 || stride > 256 || !stride.is_multiple_of(4) => {
            return Err(format!(
                "byteStride {stride} of ATTRIBUTES is not a multiple of 4 up to 256"
            ));
        }
        Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
            return Err(format!("byteStride {stride} of indices is not 2 or 4"));
        }
        Mode::Triangles if !count.is_multiple_of(3) => {
            return Err(format!("TRIANGLES count {count} is not a multiple of 3"));
        }
        Mode::Triangles | Mode::Indices if filter != Filter::None => {
            return Err("a filter on index data".into());
        }
        _ => {}
    }
    let ok = match filter {
        Filter::None => true,
        Filter::Octahedral => stride == 4 || stride == 8,
        Filter::Quaternion => stride == 8,
        Filter::Exponential => stride.is_multiple_of(4),
    };
    if !ok {
        return Err(format!(
            "filter {filter:?} does not take byteStride {stride}"
        ));
    }
    // The output is allocated from the declared size: refuse what the input could never hold
    // (a triangle takes at least one byte, an attribute element at least 1/8 byte per byte of
    // stride after the headers), so a tiny file cannot ask for gigabytes.
    let plausible = match mode {
        Mode::Attributes => data.len().saturating_mul(64),
        Mode::Triangles => data.len().saturating_mul(3),
        Mode::Indices => data.len(),
    };
    if count > plausible {
        return Err(format!(
            "{count} elements cannot come from {} compressed bytes",
            data.len()
        ));
    }
    let mut out = vec![0u8; size];
    match mode {
        Mode::Attributes => decode_attributes(&mut out, count, stride, data)?,
        Mode::Triangles => write_indices(&mut out, stride, &decode_triangles(count, data)?),
        Mode::Indices => write_indices(&mut out, stride, &decode_index_sequence(count, data)?),
    }
    match filter {
        Filter::None => {}
        Filter::Octahedral if stride == 4 => octahedral::<1>(&mut out),
        Filter::Octahedral => octahedral::<2>(&mut out),
        Filter::Quaternion => quaternion(&mut out),
        Filter::Exponential => exponential(&mut out),
    }
    Ok(out)
}

/// Reads checked bytes from a stream that ends where its tail block begins.
struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    end: usize,
}

impl Reader<'_> {
    fn bytes(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.pos + n;
        if end > self.end {
            return Err("the compressed data ends early".into());
        }
        let b = &self.data[self.pos..end];
        self.pos = end;
        Ok(b)
    }

    fn byte(&mut self) -> Result<u8, String> {
        Ok(self.bytes(1)?[0])
    }

    /// An unsigned LEB128 number of at most 5 bytes (32 bits).
    fn varint(&mut self) -> Result<u32, String> {
        let mut v = 0u32;
        for k in 0..5 {
            let b = self.byte()?;
            v |= ((b & 0x7f) as u32) << (7 * k);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err("an index varint longer than 5 bytes".into())
    }

    fn finished(&self) -> Result<(), String> {
        if self.pos == self.end {
            Ok(())
        } else {
            Err(format!(
                "{} bytes of compressed data are left over",
                self.end - self.pos
            ))
        }
    }
}

/// Undoes the zigzag coding of an 8-bit delta.
#[inline]
fn unzigzag8(v: u8) -> u8 {
    if v & 1 != 0 { !(v >> 1) } else { v >> 1 }
}

/// Mode 0: blocks of deltas per byte of the element, in groups of 16 elements, against the
/// previous element (the first against the baseline element stored in the tail block).
fn decode_attributes(
    out: &mut [u8],
    count: usize,
    stride: usize,
    data: &[u8],
) -> Result<(), String> {
    const HEADER: u8 = 0xa0;
    let tail = stride.max(32);
    match data.first() {
        Some(&HEADER) => {}
        Some(h) if h & 0xf0 == HEADER => {
            return Err(format!(
                "attribute codec version {}: only version 0 is decoded (EXT_meshopt_compression's, \
                 which KHR_meshopt_compression also allows; its version 1 is not decoded yet)",
                h & 0x0f
            ));
        }
        _ => return Err("no attribute codec header (0xa0)".into()),
    }
    if data.len() < 1 + tail {
        return Err(format!(
            "{} bytes are too few for the attribute codec",
            data.len()
        ));
    }
    let mut last = [0u8; 256];
    last[..stride].copy_from_slice(&data[data.len() - stride..]);
    let mut r = Reader {
        data,
        pos: 1,
        end: data.len() - tail,
    };
    let max_block = ((8192 / stride) & !15).min(256);
    let mut deltas = [0u8; 256];
    let mut first = 0;
    while first < count {
        let n = (count - first).min(max_block);
        let groups = n.div_ceil(16);
        for k in 0..stride {
            let header = r.bytes(groups.div_ceil(4))?.to_vec();
            for g in 0..groups {
                let bits = (header[g / 4] >> (2 * (g % 4))) & 3;
                let d = &mut deltas[16 * g..16 * g + 16];
                match bits {
                    0 => d.fill(0),
                    1 => sentinel_group::<2>(&mut r, d)?,
                    2 => sentinel_group::<4>(&mut r, d)?,
                    _ => d.copy_from_slice(r.bytes(16)?),
                }
            }
            let mut v = last[k];
            for i in 0..n {
                v = v.wrapping_add(unzigzag8(deltas[i]));
                out[(first + i) * stride + k] = v;
            }
            last[k] = v;
        }
        first += n;
    }
    r.finished()
}

/// 16 deltas of `BITS` bits each (most significant first within a byte); a delta of all ones is
/// a sentinel whose value follows as a whole byte, in order, after the packed ones.
fn sentinel_group<const BITS: usize>(r: &mut Reader, d: &mut [u8]) -> Result<(), String> {
    let packed = r.bytes(2 * BITS)?.to_vec();
    let per_byte = 8 / BITS;
    let mask = (1u8 << BITS) - 1;
    for (i, v) in d.iter_mut().enumerate() {
        let shift = 8 - BITS * (i % per_byte + 1);
        let x = (packed[i / per_byte] >> shift) & mask;
        *v = if x == mask { r.byte()? } else { x };
    }
    Ok(())
}

/// Mode 1: triangle lists, mostly one byte per triangle, from FIFOs of recent edges and
/// vertices; `count` indices.
fn decode_triangles(count: usize, data: &[u8]) -> Result<Vec<u32>, String> {
    const HEADER: u8 = 0xe1;
    let triangles = count / 3;
    match data.first() {
        Some(&HEADER) => {}
        Some(h) if h & 0xf0 == 0xe0 => {
            return Err(format!(
                "triangle codec version {} (EXT_meshopt_compression defines version 1)",
                h & 0x0f
            ));
        }
        _ => return Err("no triangle codec header (0xe1)".into()),
    }
    if data.len() < 1 + triangles + 16 {
        return Err(format!(
            "{} bytes are too few for {triangles} triangles",
            data.len()
        ));
    }
    let aux_at = data.len() - 16;
    let codeaux = &data[aux_at..];
    let codes = &data[1..1 + triangles];
    let mut r = Reader {
        data,
        pos: 1 + triangles,
        end: aux_at,
    };
    let mut s = TriangleState::default();
    let mut out = Vec::with_capacity(count);
    for &code in codes {
        let [a, b, c] = s.triangle(code, codeaux, &mut r)?;
        out.extend([a, b, c]);
    }
    r.finished()?;
    Ok(out)
}

/// The decoder's state for mode 1 (FIFO reads wrap around 16 entries; their initial contents are
/// undefined by the specification, zero here).
#[derive(Default)]
struct TriangleState {
    edges: [[u32; 2]; 16],
    edge_at: usize,
    vertices: [u32; 16],
    vertex_at: usize,
    next: u32,
    last: u32,
}

impl TriangleState {
    fn push_edge(&mut self, a: u32, b: u32) {
        self.edges[self.edge_at & 15] = [a, b];
        self.edge_at += 1;
    }

    fn push_vertex(&mut self, v: u32) {
        self.vertices[self.vertex_at & 15] = v;
        self.vertex_at += 1;
    }

    /// The vertex `k` places back in the FIFO (0: the most recent).
    fn vertex(&self, k: usize) -> u32 {
        self.vertices[self.vertex_at.wrapping_sub(1 + k) & 15]
    }

    fn next(&mut self) -> u32 {
        let v = self.next;
        self.next = self.next.wrapping_add(1);
        v
    }

    /// An index coded explicitly, as a zigzag delta from `last`.
    fn explicit(&mut self, r: &mut Reader) -> Result<u32, String> {
        let v = r.varint()?;
        let delta = if v & 1 != 0 { !(v >> 1) } else { v >> 1 };
        self.last = self.last.wrapping_add(delta);
        Ok(self.last)
    }

    fn triangle(&mut self, code: u8, codeaux: &[u8], r: &mut Reader) -> Result<[u32; 3], String> {
        let (hi, lo) = ((code >> 4) as usize, (code & 15) as usize);
        if hi < 15 {
            // A recent edge and a third vertex.
            let [a, b] = self.edges[self.edge_at.wrapping_sub(1 + hi) & 15];
            let c = match lo {
                0 => {
                    let c = self.next();
                    self.push_vertex(c);
                    c
                }
                1..=12 => self.vertex(lo),
                13 | 14 => {
                    let c = if lo == 13 {
                        self.last.wrapping_sub(1)
                    } else {
                        self.last.wrapping_add(1)
                    };
                    self.last = c;
                    self.push_vertex(c);
                    c
                }
                _ => {
                    let c = self.explicit(r)?;
                    self.push_vertex(c);
                    c
                }
            };
            self.push_edge(c, b);
            self.push_edge(a, c);
            return Ok([a, b, c]);
        }
        // Three vertices: from the table, or explicitly (0xfe, 0xff).
        let (explicit_a, aux) = if lo < 14 {
            (false, codeaux[lo])
        } else {
            let aux = r.byte()?;
            if aux == 0 {
                self.next = 0;
            }
            (lo == 15, aux)
        };
        let (zb, zc) = ((aux >> 4) as usize, (aux & 15) as usize);
        let a = if explicit_a { 0 } else { self.next() };
        let pick = |z: usize, s: &mut Self| match z {
            0 => s.next(),
            15 if lo >= 14 => 0,
            _ => s.vertex(z - 1),
        };
        let mut b = pick(zb, self);
        let mut c = pick(zc, self);
        let a = if explicit_a { self.explicit(r)? } else { a };
        if lo >= 14 && zb == 15 {
            b = self.explicit(r)?;
        }
        if lo >= 14 && zc == 15 {
            c = self.explicit(r)?;
        }
        self.push_vertex(a);
        if zb == 0 || (lo >= 14 && zb == 15) {
            self.push_vertex(b);
        }
        if zc == 0 || (lo >= 14 && zc == 15) {
            self.push_vertex(c);
        }
        self.push_edge(b, a);
        self.push_edge(c, b);
        self.push_edge(a, c);
        Ok([a, b, c])
    }
}

/// Mode 2: index sequences, each a varint delta against one of two baselines.
fn decode_index_sequence(count: usize, data: &[u8]) -> Result<Vec<u32>, String> {
    const HEADER: u8 = 0xd1;
    match data.first() {
        Some(&HEADER) => {}
        Some(h) if h & 0xf0 == 0xd0 => {
            return Err(format!(
                "index sequence codec version {} (EXT_meshopt_compression defines version 1)",
                h & 0x0f
            ));
        }
        _ => return Err("no index sequence codec header (0xd1)".into()),
    }
    if data.len() < 1 + count + 4 {
        return Err(format!(
            "{} bytes are too few for {count} indices",
            data.len()
        ));
    }
    let mut r = Reader {
        data,
        pos: 1,
        end: data.len() - 4,
    };
    let mut last = [0u32; 2];
    let mut out = Vec::with_capacity(count);
    for _ in 0..count {
        let v = r.varint()?;
        let base = (v & 1) as usize;
        let delta = if v & 2 != 0 { !(v >> 2) } else { v >> 2 };
        last[base] = last[base].wrapping_add(delta);
        out.push(last[base]);
    }
    r.finished()?;
    Ok(out)
}

/// Stores indices as little-endian integers of `stride` bytes (2: the low 16 bits).
fn write_indices(out: &mut [u8], stride: usize, indices: &[u32]) {
    for (chunk, &i) in out.chunks_exact_mut(stride).zip(indices) {
        if stride == 2 {
            chunk.copy_from_slice(&(i as u16).to_le_bytes());
        } else {
            chunk.copy_from_slice(&i.to_le_bytes());
        }
    }
}

/// Reads signed component `k` of `N` bytes from `e`.
fn get<const N: usize>(e: &[u8], k: usize) -> f32 {
    if N == 1 {
        e[k] as i8 as f32
    } else {
        i16::from_le_bytes([e[2 * k], e[2 * k + 1]]) as f32
    }
}

fn set<const N: usize>(e: &mut [u8], k: usize, v: i32) {
    if N == 1 {
        e[k] = v as i8 as u8;
    } else {
        e[2 * k..2 * k + 2].copy_from_slice(&(v as i16).to_le_bytes());
    }
}

/// Rounds half away from zero, as the reference decoder does.
#[inline]
fn round_away(x: f32) -> i32 {
    (x + if x >= 0.0 { 0.5 } else { -0.5 }) as i32
}

/// Filter 1: unit vectors in octahedral coordinates (x, y, and 1.0 at their bit count in the
/// third component) back to signed normalised x, y, z; the fourth component passes through.
fn octahedral<const N: usize>(out: &mut [u8]) {
    let max = ((1u32 << (8 * N - 1)) - 1) as f32;
    for e in out.chunks_exact_mut(4 * N) {
        let (mut x, mut y) = (get::<N>(e, 0), get::<N>(e, 1));
        let z = get::<N>(e, 2) - x.abs() - y.abs();
        let t = z.min(0.0);
        x += if x >= 0.0 { t } else { -t };
        y += if y >= 0.0 { t } else { -t };
        let l = (x * x + y * y + z * z).sqrt();
        let s = if l > 0.0 { max / l } else { 0.0 };
        set::<N>(e, 0, round_away(x * s));
        set::<N>(e, 1, round_away(y * s));
        set::<N>(e, 2, round_away(z * s));
    }
}

/// Filter 2: unit quaternions from their three smallest components (scaled by √2) and the index
/// of the largest, to four signed normalised 16-bit components.
fn quaternion(out: &mut [u8]) {
    let scale = std::f32::consts::FRAC_1_SQRT_2;
    for e in out.chunks_exact_mut(8) {
        let c3 = i16::from_le_bytes([e[6], e[7]]);
        let one = (c3 | 3) as f32;
        let ss = scale / one;
        let (x, y, z) = (
            get::<2>(e, 0) * ss,
            get::<2>(e, 1) * ss,
            get::<2>(e, 2) * ss,
        );
        let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
        let qc = (c3 & 3) as usize;
        set::<2>(e, (qc + 1) & 3, round_away(x * 32767.0));
        set::<2>(e, (qc + 2) & 3, round_away(y * 32767.0));
        set::<2>(e, (qc + 3) & 3, round_away(z * 32767.0));
        set::<2>(e, qc, round_away(w * 32767.0));
    }
}

/// Filter 3: 32-bit values of an 8-bit exponent and a 24-bit mantissa (both signed) to floats.
fn exponential(out: &mut [u8]) {
    for e in out.chunks_exact_mut(4) {
        let v = i32::from_le_bytes([e[0], e[1], e[2], e[3]]);
        let (exp, mantissa) = (v >> 24, (v << 8) >> 8);
        // The specification bounds the exponent to [-100, 100]; outside, the result is
        // unspecified, and clamping keeps the power of two a normal float.
        let pow = f32::from_bits(((exp + 127).clamp(1, 254) as u32) << 23);
        e.copy_from_slice(&(mantissa as f32 * pow).to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshopt_sentinel_group_matches_the_specification_example() {
        // Appendix A's 4-bit example: 16 deltas, the 4th and 5th explicit.
        let data = [0x17, 0x5f, 0xf0, 0xbc, 0x77, 0xa9, 0x21, 0x00, 0x34, 0xb5];
        let mut r = Reader {
            data: &data,
            pos: 0,
            end: data.len(),
        };
        let mut d = [0u8; 16];
        sentinel_group::<4>(&mut r, &mut d).unwrap();
        let decoded: Vec<i8> = d.iter().map(|&v| unzigzag8(v) as i8).collect();
        assert_eq!(
            decoded,
            [-1, -4, -3, 26, -91, 0, -6, 6, -4, -4, 5, -5, 1, -1, 0, 0]
        );
        assert!(r.finished().is_ok());
    }

    #[test]
    fn meshopt_index_sequence_uses_two_baselines() {
        // 5 (baseline 0: +5), 100 (baseline 1: +100), 6 (baseline 0: +1), 99 (baseline 1: -1).
        let enc = |base: u32, delta: i32| {
            let z = if delta < 0 {
                (!(delta as u32)) << 1 | 1
            } else {
                (delta as u32) << 1
            };
            (z << 1) | base
        };
        let mut data = vec![0xd1];
        for (b, d) in [(0, 5), (1, 100), (0, 1), (1, -1)] {
            let mut v = enc(b, d);
            loop {
                let byte = (v & 0x7f) as u8;
                v >>= 7;
                if v == 0 {
                    data.push(byte);
                    break;
                }
                data.push(byte | 0x80);
            }
        }
        data.extend([0; 4]);
        assert_eq!(decode_index_sequence(4, &data).unwrap(), [5, 100, 6, 99]);
        assert!(decode_index_sequence(5, &data).is_err());
    }

    #[test]
    fn meshopt_bad_streams_are_errors() {
        for data in [&[][..], &[0xa1; 40], &[0xa0; 10], &[0x00; 40]] {
            assert!(decode(data, 3, 12, Mode::Attributes, Filter::None).is_err());
        }
        assert!(decode(&[0xe1; 20], 6, 2, Mode::Triangles, Filter::None).is_err());
        assert!(decode(&[0xe1; 40], 4, 2, Mode::Triangles, Filter::None).is_err());
        assert!(decode(&[0xa0; 40], 3, 6, Mode::Attributes, Filter::None).is_err());
        assert!(decode(&[0xa0; 40], 3, 12, Mode::Attributes, Filter::Quaternion).is_err());
        // A count no stream of that size could hold.
        assert!(decode(&[0xa0; 40], 1 << 40, 4, Mode::Attributes, Filter::None).is_err());
    }

    /// Every single-byte change and every truncation of streams made by the reference encoder
    /// decodes or gives an error, never a panic (the decoder reads untrusted files).
    #[test]
    fn meshopt_corrupted_reference_streams_never_panic() {
        let vertices: Vec<[f32; 3]> = (0..300)
            .map(|i| {
                let t = i as f32 * 0.1;
                [t.sin(), t.cos(), t * 0.01]
            })
            .collect();
        let indices: Vec<u32> = (0..298u32).flat_map(|i| [i, i + 1, i + 2]).collect();
        let attributes = ::meshopt::encode_vertex_buffer_level(&vertices, 2, Some(0)).unwrap();
        let triangles = ::meshopt::encode_index_buffer(&indices, 300).unwrap();
        let sequence = ::meshopt::encode_index_sequence(&indices, 300).unwrap();
        let cases = [
            (attributes, 300, 12, Mode::Attributes, Filter::None),
            (triangles, indices.len(), 4, Mode::Triangles, Filter::None),
            (sequence, indices.len(), 4, Mode::Indices, Filter::None),
        ];
        for (stream, count, stride, mode, filter) in cases {
            let good = decode(&stream, count, stride, mode, filter).unwrap();
            assert_eq!(good.len(), count * stride);
            for at in 0..stream.len() {
                for flip in [0x01u8, 0x80, 0xff] {
                    let mut bad = stream.clone();
                    bad[at] ^= flip;
                    let _ = decode(&bad, count, stride, mode, filter);
                }
                let _ = decode(&stream[..at], count, stride, mode, filter);
            }
        }
    }

    /// The filters give the reference decoder's bytes on the reference encoder's output.
    #[test]
    fn meshopt_filters_match_the_reference_decoder() {
        let unit: Vec<[f32; 4]> = (0..64)
            .map(|i| {
                let (a, b) = (i as f32 * 0.7, i as f32 * 0.31 - 1.0);
                let v = glam::Vec4::new(a.sin() * b.cos(), a.cos(), b.sin(), 0.3 * a.sin());
                (v / v.length()).to_array()
            })
            .collect();
        let as_bytes = |v: &[i8]| v.iter().map(|&x| x as u8).collect::<Vec<u8>>();
        let i16_bytes = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        // Octahedral, 8 and 16 bits.
        let mut reference: Vec<[i8; 4]> = ::meshopt::encode_filter_oct::<i8>(&unit, 8);
        let mut ours = as_bytes(reference.as_flattened());
        ::meshopt::decode_filter_oct(&mut reference);
        octahedral::<1>(&mut ours);
        assert_eq!(ours, as_bytes(reference.as_flattened()));
        let mut reference: Vec<[i16; 4]> = ::meshopt::encode_filter_oct::<i16>(&unit, 12);
        let mut ours = i16_bytes(reference.as_flattened());
        ::meshopt::decode_filter_oct(&mut reference);
        octahedral::<2>(&mut ours);
        assert_eq!(ours, i16_bytes(reference.as_flattened()));
        // Quaternions.
        let mut reference = ::meshopt::encode_filter_quat(&unit, 12);
        let mut ours = i16_bytes(reference.as_flattened());
        ::meshopt::decode_filter_quat(&mut reference);
        quaternion(&mut ours);
        assert_eq!(ours, i16_bytes(reference.as_flattened()));
        // Exponential.
        let values: Vec<[f32; 3]> = unit
            .iter()
            .map(|v| [v[0] * 1e3, v[1] * 1e-3, v[2]])
            .collect();
        let mut reference =
            ::meshopt::encode_filter_exp::<3>(&values, 15, ::meshopt::EncodeExpMode::Separate);
        let u32_bytes = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let mut ours = u32_bytes(reference.as_flattened());
        ::meshopt::decode_filter_exp(&mut reference);
        exponential(&mut ours);
        assert_eq!(ours, u32_bytes(reference.as_flattened()));
    }

    #[test]
    fn meshopt_exponential_filter_scales_the_mantissa() {
        let mut e = (((-3i32) << 24) | 12).to_le_bytes().to_vec();
        exponential(&mut e);
        assert_eq!(f32::from_le_bytes([e[0], e[1], e[2], e[3]]), 1.5);
        let mut e = ((2i32 << 24) | (-5i32 & 0xff_ffff)).to_le_bytes().to_vec();
        exponential(&mut e);
        assert_eq!(f32::from_le_bytes([e[0], e[1], e[2], e[3]]), -20.0);
    }
}
