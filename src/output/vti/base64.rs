//! Base64 (RFC 4648, standard alphabet, `=` padding) of the appended data: a streaming encoder
//! for the writer and a decoder for the reader.

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Base64 characters for `bytes` bytes.
pub(super) fn b64_len(bytes: u64) -> u64 {
    bytes.div_ceil(3) * 4
}

/// Streaming base64 encoder (standard alphabet, `=` padding) into a byte buffer.
#[derive(Default)]
pub(super) struct B64 {
    pending: [u8; 3],
    len: usize,
}

impl B64 {
    pub(super) fn push(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        for &b in bytes {
            self.pending[self.len] = b;
            self.len += 1;
            if self.len == 3 {
                Self::group(self.pending, 3, out);
                self.len = 0;
            }
        }
    }
    pub(super) fn finish(&mut self, out: &mut Vec<u8>) {
        if self.len > 0 {
            let mut g = [0u8; 3];
            g[..self.len].copy_from_slice(&self.pending[..self.len]);
            Self::group(g, self.len, out);
            self.len = 0;
        }
    }
    fn group(g: [u8; 3], n: usize, out: &mut Vec<u8>) {
        let v = (g[0] as u32) << 16 | (g[1] as u32) << 8 | g[2] as u32;
        for k in 0..4 {
            out.push(if k <= n {
                B64[(v >> (18 - 6 * k)) as usize & 63]
            } else {
                b'='
            });
        }
    }
}

/// Decodes standard base64 (with `=` padding); `None` on anything else.
pub(super) fn b64_decode(s: &[u8]) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(4) {
        return None;
    }
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    for (q, g) in s.chunks_exact(4).enumerate() {
        let last = q + 1 == s.len() / 4;
        let pad = g.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 || (pad > 0 && !last) {
            return None;
        }
        let mut v = 0u32;
        for &c in &g[..4 - pad] {
            v = v << 6 | val(c)?;
        }
        v <<= 6 * pad as u32;
        out.extend_from_slice(&v.to_be_bytes()[1..4 - pad]);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors_and_round_trips() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            let mut out = Vec::new();
            let mut e = B64::default();
            // Fed in pieces, as the writer does.
            for b in plain.as_bytes() {
                e.push(&[*b], &mut out);
            }
            e.finish(&mut out);
            assert_eq!(out, coded.as_bytes());
            assert_eq!(b64_len(plain.len() as u64), coded.len() as u64);
            assert_eq!(b64_decode(coded.as_bytes()).unwrap(), plain.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        let mut out = Vec::new();
        let mut e = B64::default();
        e.push(&all, &mut out);
        e.finish(&mut out);
        assert_eq!(b64_decode(&out).unwrap(), all);
        assert!(b64_decode(b"Zg=").is_none() && b64_decode(b"Z===").is_none());
    }
}
