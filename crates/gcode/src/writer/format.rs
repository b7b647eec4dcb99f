//! Number formatting for G-code words: fixed decimals, trailing zeros trimmed,
//! never `-0`, never exponent notation.

use std::fmt::Write as _;

/// Appends `v` with at most `decimals` digits after the point to `out`.
///
/// Trailing zeros (and a bare trailing point) are removed unless `keep_point`
/// is set, in which case a whole number keeps its point (`1.`): Fanuc controls
/// read a number without a point as a count of least increments. A value that
/// rounds to zero is written `0` (`0.` with `keep_point`), never `-0`. The caller
/// guarantees that `v` is finite.
pub(crate) fn push_num(out: &mut String, v: f64, decimals: usize, keep_point: bool) {
    let start = out.len();
    // `{:.N}` never uses exponent notation for f64.
    let _ = write!(out, "{v:.decimals$}");
    if out[start..].contains('.') {
        while out.ends_with('0') {
            out.pop();
        }
        if out.ends_with('.') && !keep_point {
            out.pop();
        }
    } else if keep_point {
        out.push('.');
    }
    let s = &out[start..];
    if s == "-0" || s == "-0." || s == "-" {
        out.truncate(start);
        out.push_str(if keep_point { "0." } else { "0" });
    }
}

/// A fixed buffer for formatting without allocating; fails when full.
struct Stack {
    buf: [u8; 64],
    len: usize,
}

impl std::fmt::Write for Stack {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        let end = self.len + s.len();
        if end > self.buf.len() {
            return Err(std::fmt::Error);
        }
        self.buf[self.len..end].copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// `v` as the machine will read it back after [`push_num`] (a rounded zero may be `-0.0`,
/// which compares equal to `0.0`).
pub(crate) fn rounded(v: f64, decimals: usize) -> f64 {
    let mut st = Stack { buf: [0; 64], len: 0 };
    if write!(st, "{v:.decimals$}").is_ok()
        && let Ok(s) = std::str::from_utf8(&st.buf[..st.len])
    {
        return s.parse().unwrap_or(v);
    }
    // Very long numbers (huge values or many decimals): allocate.
    let mut s = String::with_capacity(80);
    push_num(&mut s, v, decimals, false);
    s.parse().unwrap_or(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(v: f64, d: usize, k: bool) -> String {
        let mut s = String::new();
        push_num(&mut s, v, d, k);
        s
    }

    #[test]
    fn formats() {
        let cases: &[(f64, usize, bool, &str)] = &[
            (1.5, 4, false, "1.5"),
            (1.0, 4, false, "1"),
            (1.0, 4, true, "1."),
            (-0.00001, 4, false, "0"),
            (-0.00001, 4, true, "0."),
            (-0.0, 3, false, "0"),
            (1e-7, 4, false, "0"),
            (1e20, 2, false, "100000000000000000000"),
            (-12.34567, 3, false, "-12.346"),
            (0.5, 0, false, "0"),
            (2.5, 0, true, "2."),
            (123.0, 0, false, "123"),
        ];
        for &(v, d, k, want) in cases {
            assert_eq!(f(v, d, k), want, "value {v} decimals {d} keep_point {k}");
        }
        assert_eq!(rounded(1.23456, 4), 1.2346);
        assert_eq!(rounded(-0.00001, 4), 0.0);
        assert_eq!(rounded(1e100, 2), 1e100);
        assert_eq!(rounded(0.1, 80), 0.1);
    }
}
