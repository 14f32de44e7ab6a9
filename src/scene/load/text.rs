//! Lines, tokens and numbers of the text mesh formats (OBJ, MTL, ASCII PLY), read straight from
//! bytes: no UTF-8 validation of whole lines, no allocation per token, and a correctly rounded
//! `f32` parser whose fast path covers the short decimals mesh files are made of; and the
//! tally of statements a parser skips.

/// The lines of `data` with their 1-based numbers, without the `\n` or `\r\n` that ends them.
/// A final line without a newline is still a line.
pub(crate) fn lines(data: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    let mut rest = data;
    let mut number = 0;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        number += 1;
        let (line, next) = match memchr(b'\n', rest) {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        rest = next;
        Some((number, line.strip_suffix(b"\r").unwrap_or(line)))
    })
}

fn memchr(byte: u8, haystack: &[u8]) -> Option<usize> {
    haystack.iter().position(|&b| b == byte)
}

/// The whitespace-separated tokens of a line (spaces, tabs, `\r`, form feeds).
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty())
}

/// `line` without leading and trailing whitespace.
pub(crate) fn trim(line: &[u8]) -> &[u8] {
    line.trim_ascii()
}

/// A token for an error message: at most 40 characters, invalid UTF-8 replaced.
pub(crate) fn show(token: &[u8]) -> String {
    let s = String::from_utf8_lossy(token);
    if s.chars().count() > 40 { format!("{}…", s.chars().take(40).collect::<String>()) } else { s.into_owned() }
}

/// Powers of ten that `f32` holds exactly (10¹⁰ = 2¹⁰·5¹⁰ and 5¹⁰ < 2²⁴).
const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// Parses a decimal number (`-1`, `2.`, `.5`, `+3.1e-2`, `inf`, `nan`, ...) as the nearest `f32`.
///
/// Fast path (Clinger): a mantissa below 2²⁴ and a decimal exponent within ±10 make both
/// operands exact `f32`s, so one multiplication or division rounds correctly. Everything else
/// goes to the standard library's parser, which is also correctly rounded.
pub(crate) fn parse_f32(token: &[u8]) -> Option<f32> {
    let (negative, digits) = match token.first()? {
        b'-' => (true, &token[1..]),
        b'+' => (false, &token[1..]),
        _ => (false, token),
    };
    let mut mantissa: u64 = 0;
    let mut n_digits = 0usize;
    let mut frac_digits = 0i32;
    let mut seen_point = false;
    let mut i = 0;
    while i < digits.len() {
        match digits[i] {
            d @ b'0'..=b'9' => {
                if n_digits == 18 {
                    return parse_std(token);
                }
                mantissa = mantissa * 10 + (d - b'0') as u64;
                n_digits += 1;
                frac_digits += seen_point as i32;
            }
            b'.' if !seen_point => seen_point = true,
            _ => break,
        }
        i += 1;
    }
    if n_digits == 0 {
        return parse_std(token);
    }
    let mut exponent = -frac_digits;
    if i < digits.len() {
        if !matches!(digits[i], b'e' | b'E') {
            return None;
        }
        let e = parse_i64(&digits[i + 1..])?;
        if e.abs() > 100 {
            return parse_std(token);
        }
        exponent += e as i32;
    }
    if mantissa >= 1 << 24 || !(-10..=10).contains(&exponent) {
        return parse_std(token);
    }
    let m = mantissa as f32;
    let value = if exponent >= 0 { m * POW10_F32[exponent as usize] } else { m / POW10_F32[(-exponent) as usize] };
    Some(if negative { -value } else { value })
}

fn parse_std(token: &[u8]) -> Option<f32> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// Parses an optionally signed decimal integer; `None` on anything else or on overflow.
#[inline]
pub(crate) fn parse_i64(token: &[u8]) -> Option<i64> {
    let (negative, digits) = match token.first()? {
        b'-' => (true, &token[1..]),
        b'+' => (false, &token[1..]),
        _ => (false, token),
    };
    // Up to 18 digits cannot overflow an i64: no checks inside the loop.
    if digits.is_empty() || digits.len() > 18 {
        return if digits.len() > 18 { std::str::from_utf8(token).ok()?.parse().ok() } else { None };
    }
    let mut value: i64 = 0;
    for &d in digits {
        let digit = d.wrapping_sub(b'0');
        if digit > 9 {
            return None;
        }
        value = value * 10 + digit as i64;
    }
    Some(if negative { -value } else { value })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_round_like_the_standard_parser() {
        let cases = [
            "0",
            "-0",
            "1",
            "2.",
            ".5",
            "+3.0",
            "-7e-2",
            "5e2",
            "1e10",
            "1E2",
            "2.e+1",
            "0.0378297",
            "-0.0503644",
            "3.14159265358979",
            "1e-45",
            "3.4028236e38",
            "123456789",
            "16777217",
            "0.000000",
            "1.000001e-8",
            "-1.146",
            "2.63214",
            "9999999999",
            "7.941797",
            "0.1",
            "0.3",
        ];
        for c in cases {
            assert_eq!(parse_f32(c.as_bytes()).map(f32::to_bits), c.parse::<f32>().ok().map(f32::to_bits), "{c}");
        }
        // A sweep of 7-digit decimals, the bulk of every scanned mesh.
        for k in (0..10_000_000u32).step_by(997) {
            let s = format!("{}.{:07}", k % 7, k);
            assert_eq!(parse_f32(s.as_bytes()), s.parse::<f32>().ok(), "{s}");
        }
        assert!(parse_f32(b"inf").unwrap().is_infinite());
        assert!(parse_f32(b"nan").unwrap().is_nan());
        for bad in ["3.1+e2", "1..2", "-", "", "e5", "1e", "0x10", "1,5", "5-"] {
            assert_eq!(parse_f32(bad.as_bytes()), None, "{bad}");
        }
    }

    #[test]
    fn integers_and_overflow() {
        assert_eq!(parse_i64(b"-12"), Some(-12));
        assert_eq!(parse_i64(b"+7"), Some(7));
        assert_eq!(parse_i64(b"1.0"), None);
        assert_eq!(parse_i64(b"99999999999999999999"), None);
        assert_eq!(parse_i64(b"-9223372036854775808"), Some(i64::MIN));
        assert_eq!(parse_i64(b"0000000000000000000000007"), Some(7));
        assert_eq!(parse_i64(b"12a"), None);
        assert_eq!(parse_i64(b"-"), None);
    }

    #[test]
    fn lines_strip_crlf_and_keep_a_last_line_without_newline() {
        let v: Vec<_> = lines(b"a\r\nb\n\nc").collect();
        assert_eq!(v, vec![(1, &b"a"[..]), (2, &b"b"[..]), (3, &b""[..]), (4, &b"c"[..])]);
        assert_eq!(tokens(b" \tf  1\t2 3 ").collect::<Vec<_>>(), vec![&b"f"[..], b"1", b"2", b"3"]);
    }
}

/// Statements a parser skips, by keyword: each keyword once, in first-seen order, with how
/// often it occurred and the line it first did. A hash finds a keyword again, so a file of
/// many distinct unknown statements stays linear.
#[derive(Clone, Debug, Default)]
pub(crate) struct Tally {
    /// (keyword, count, first line)
    entries: Vec<(String, usize, usize)>,
    index: std::collections::HashMap<String, usize>,
}

impl Tally {
    /// Counts one occurrence of `keyword` on line `line`.
    pub(crate) fn add(&mut self, keyword: String, line: usize) {
        match self.index.get(&keyword) {
            Some(&i) => self.entries[i].1 += 1,
            None => {
                self.index.insert(keyword.clone(), self.entries.len());
                self.entries.push((keyword, 1, line));
            }
        }
    }

    /// (keyword, count, first line), in first-seen order.
    pub(crate) fn entries(&self) -> &[(String, usize, usize)] {
        &self.entries
    }
}
