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
    if let Some(m) = quantize(v, decimals) {
        // Fast path: an integer count of 10^-decimals.
        if m < 0 {
            out.push('-');
        }
        let p = POW10[decimals] as u64;
        let a = m.unsigned_abs();
        let (int, mut frac) = (a / p, a % p);
        let _ = write!(out, "{int}");
        if frac != 0 {
            let mut digits = decimals;
            while frac % 10 == 0 {
                frac /= 10;
                digits -= 1;
            }
            let _ = write!(out, ".{frac:0digits$}");
        } else if keep_point {
            out.push('.');
        }
        return;
    }
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

const POW10: [f64; 16] =
    [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// `v` as a whole number of `10^-decimals` when that is exact in integers
/// (at most 15 decimals, magnitude below 2^53 units); `None` otherwise.
fn quantize(v: f64, decimals: usize) -> Option<i64> {
    let p = *POW10.get(decimals)?;
    let m = (v * p).round();
    (m.abs() < 9.0e15).then_some(m as i64)
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
    if let Some(m) = quantize(v, decimals) {
        // Both operands are exact, so the quotient is the double nearest the
        // printed decimal: what a parser reads back.
        return m as f64 / POW10[decimals];
    }
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
            (0.5, 0, false, "1"),
            (2.5, 0, true, "3."),
            (123.0, 0, false, "123"),
        ];
        for &(v, d, k, want) in cases {
            assert_eq!(f(v, d, k), want, "value {v} decimals {d} keep_point {k}");
        }
        assert_eq!(rounded(1.23456, 4), 1.2346);
        assert_eq!(rounded(-0.00001, 4), 0.0);
        assert_eq!(rounded(1e100, 2), 1e100);
        assert_eq!(rounded(0.1, 80), 0.1);
        // The fast path prints what it rounds to.
        for &(v, d) in
            &[(123.456789, 4), (-0.00049, 3), (1e12 + 0.5, 2), (7.0, 6), (-2.5e-5, 5), (0.1 + 0.2, 15)]
        {
            let mut t = String::new();
            push_num(&mut t, v, d, false);
            assert_eq!(t.parse::<f64>().ok(), Some(rounded(v, d)), "{v} with {d} decimals printed {t}");
        }
    }
}
