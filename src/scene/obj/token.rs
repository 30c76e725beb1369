//! The tokens of OBJ lines: words, real numbers (bit for bit what the standard parser gives, with
//! a fast path for the short decimals of real files) and whole numbers.

/// Whether `b` separates words (what `split_ascii_whitespace` splits at).
#[inline]
pub(super) fn is_space(b: u8) -> bool {
    b.is_ascii_whitespace()
}

/// The next word of `b` (after leading white space) and what follows it.
#[inline]
pub(super) fn next_word(b: &[u8]) -> Option<(&[u8], &[u8])> {
    let s = b.iter().position(|&c| !is_space(c))?;
    let b = &b[s..];
    let e = b.iter().position(|&c| is_space(c)).unwrap_or(b.len());
    Some((&b[..e], &b[e..]))
}

/// Exactly `N` numbers and nothing else after them.
#[inline]
pub(super) fn fast_numbers<const N: usize>(mut b: &[u8]) -> Option<[f32; N]> {
    let mut v = [0f32; N];
    for x in &mut v {
        let (w, rest) = next_word(b)?;
        *x = real_number(w)?;
        b = rest;
    }
    next_word(b).is_none().then_some(v)
}

/// The numbers of `words`, the first 8 in `out`; `None` when one is not a number.
pub(super) fn numbers<'a>(
    words: impl Iterator<Item = &'a str>,
    out: &mut [f32; 8],
) -> Option<usize> {
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

/// Powers of ten that are exact in f32.
const POW10: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// `s` as an f32, bit for bit what `str::parse::<f32>` gives, with a fast path for the short
/// decimals of real files (`-0.123456`): with at most 2^24 as the digits' integer and at most 10
/// of them after the point, both that integer and the power of ten are exact in f32, so one
/// correctly rounded division gives the correctly rounded value (the classic exact fast path of
/// decimal conversion, which the standard library's parser takes for them too). Everything else goes to the standard parser.
#[inline]
pub(super) fn real_number(b: &[u8]) -> Option<f32> {
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
pub(super) fn whole_number(s: &str) -> Option<i64> {
    let b = s.as_bytes();
    if !b.is_empty() && b.len() <= 18 && b.iter().all(u8::is_ascii_digit) {
        return Some(b.iter().fold(0i64, |a, &d| a * 10 + (d - b'0') as i64));
    }
    s.parse::<i64>().ok()
}

/// Latin-1 text of bytes that are not UTF-8 (every byte is the code point of the same value).
pub(super) fn latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|&b| b as char).collect()
}

/// Whether the line that ends where `before` ends (just before its `\n`) ends in a backslash, the
/// OBJ format's line continuation (`\` or `\` CR).
pub(super) fn continued(before: &[u8]) -> bool {
    matches!(before, [.., b'\\'] | [.., b'\\', b'\r'])
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
