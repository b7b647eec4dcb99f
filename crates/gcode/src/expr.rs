//! Numbers, parameters and LinuxCNC `[ ]` expressions, read straight from a line's bytes.
//!
//! Whitespace is skipped everywhere outside comments, as LinuxCNC does (it removes all
//! spaces before parsing), so `X 1 2.5` is `X12.5`. Numbers are plain decimals: there is
//! no exponent notation in G-code (`1E5` is the word `1` followed by an `E` word).

use std::collections::BTreeMap;

use crate::error::GcodeErrorKind;

/// Highest numbered parameter, as in LinuxCNC (`RS274NGC_MAX_PARAMETERS - 1`).
pub(crate) const MAX_PARAM: usize = 5601;

/// Deepest bracket nesting accepted (guards the recursion against hostile input).
const MAX_DEPTH: u32 = 64;

/// Numbered and named parameters.
#[derive(Debug, Clone)]
pub(crate) struct Params {
    pub numbered: Vec<f64>,
    pub named: BTreeMap<String, f64>,
    scratch: String,
}

impl Default for Params {
    fn default() -> Self {
        Self { numbered: vec![0.0; MAX_PARAM + 1], named: BTreeMap::new(), scratch: String::new() }
    }
}

impl Params {
    /// Normalises a name (lowercase, no blanks) into the scratch buffer and returns it.
    fn norm<'s>(scratch: &'s mut String, raw: &[u8]) -> &'s str {
        scratch.clear();
        for &c in raw {
            if !c.is_ascii_whitespace() {
                scratch.push(c.to_ascii_lowercase() as char);
            }
        }
        scratch.as_str()
    }

    pub fn get_named(&mut self, raw: &[u8]) -> Option<f64> {
        let key = Self::norm(&mut self.scratch, raw);
        self.named.get(key).copied()
    }

    pub fn set_named(&mut self, raw: &[u8], v: f64) {
        let key = Self::norm(&mut self.scratch, raw);
        if let Some(slot) = self.named.get_mut(key) {
            *slot = v;
        } else {
            self.named.insert(key.to_owned(), v);
        }
    }
}

/// Where a parameter assignment goes.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ParamKey {
    Num(usize),
    /// Byte range of the name inside the line.
    Named(usize, usize),
}

/// A read position inside one line.
pub(crate) struct Cursor<'a> {
    pub b: &'a [u8],
    pub i: usize,
}

type R<T> = Result<T, (usize, GcodeErrorKind)>;

const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18,
    1e19, 1e20, 1e21, 1e22,
];

/// Reads the digits at `b[i..]` into `mant` (wrapping: the caller checks the count).
/// Returns how many there were and where they end.
#[inline(always)]
fn digits(b: &[u8], mut i: usize, mant: &mut u64) -> (u32, usize) {
    let mut nd = 0;
    while let Some(&c) = b.get(i) {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        *mant = mant.wrapping_mul(10).wrapping_add(d as u64);
        nd += 1;
        i += 1;
    }
    (nd, i)
}

/// A number `[sign]digits[.digits]` at `b[i..]` (no leading blanks) read exactly by
/// Clinger's fast path, and where it ends: at most 19 digits, mantissa below 2^53, one
/// correctly rounded division by an exact power of ten (none for integers: codes, feeds
/// and line numbers are mostly whole). `None` for anything else, including blanks inside
/// the number (`X1 2`), which the general reader handles.
#[inline(always)]
pub(crate) fn plain_number(b: &[u8], mut i: usize) -> Option<(f64, usize)> {
    let neg = match b.get(i) {
        Some(&c @ (b'-' | b'+')) => {
            i += 1;
            c == b'-'
        }
        _ => false,
    };
    let mut mant = 0u64;
    let (mut nd, end) = digits(b, i, &mut mant);
    i = end;
    let mut frac = 0;
    if b.get(i) == Some(&b'.') {
        (frac, i) = digits(b, i + 1, &mut mant);
        nd += frac;
    }
    let mut j = i;
    while let Some(b' ' | b'\t') = b.get(j) {
        j += 1;
    }
    let blank_continues = j > i && matches!(b.get(j), Some(b'0'..=b'9' | b'.'));
    if nd == 0 || nd > 19 || mant >= (1 << 53) || frac as usize >= POW10.len() || blank_continues {
        return None;
    }
    // `mant < 2^53`: the signed conversion is exact and one instruction.
    let m = mant as i64 as f64;
    let v = if frac == 0 { m } else { m / POW10[frac as usize] };
    Some((if neg { -v } else { v }, i))
}

impl<'a> Cursor<'a> {
    #[inline]
    pub fn skip_ws(&mut self) {
        while self.i < self.b.len() && matches!(self.b[self.i], b' ' | b'\t') {
            self.i += 1;
        }
    }

    /// The next non-blank byte, lowercased, without consuming it.
    #[inline]
    pub fn peek(&mut self) -> Option<u8> {
        self.skip_ws();
        self.b.get(self.i).map(|c| c.to_ascii_lowercase())
    }

    fn err<T>(&self, kind: GcodeErrorKind) -> R<T> {
        Err((self.i, kind))
    }

    /// A plain decimal number with optional sign; blanks between its characters are skipped.
    ///
    /// Fast path: [`plain_number`] after leading blanks; anything else goes through
    /// [`Self::number_general`].
    #[inline]
    pub fn number(&mut self) -> R<f64> {
        let mut i = self.i;
        while let Some(b' ' | b'\t') = self.b.get(i) {
            i += 1;
        }
        match plain_number(self.b, i) {
            Some((v, end)) => {
                self.i = end;
                Ok(v)
            }
            None => self.number_general(),
        }
    }

    /// The general number reader: blanks inside the number, many digits.
    #[cold]
    fn number_general(&mut self) -> R<f64> {
        let start = self.i;
        self.skip_ws();
        let mut neg = false;
        if let Some(&c) = self.b.get(self.i)
            && (c == b'-' || c == b'+')
        {
            neg = c == b'-';
            self.i += 1;
        }
        let mut mant: u64 = 0;
        let mut digits = 0u32;
        let mut frac = 0u32;
        let mut dot = false;
        let mut exact = true;
        let num_start = self.i;
        while self.i < self.b.len() {
            let c = self.b[self.i];
            match c {
                b'0'..=b'9' => {
                    if mant < 1_000_000_000_000_000_000 {
                        mant = mant * 10 + (c - b'0') as u64;
                        if mant != 0 || dot {
                            digits += 1;
                        }
                        if dot {
                            frac += 1;
                        }
                    } else {
                        exact = false;
                    }
                    self.i += 1;
                }
                b'.' if !dot => {
                    dot = true;
                    self.i += 1;
                }
                b' ' | b'\t' => {
                    // Blanks inside a number are skipped only when a digit or dot follows.
                    let mut j = self.i;
                    while j < self.b.len() && matches!(self.b[j], b' ' | b'\t') {
                        j += 1;
                    }
                    if j < self.b.len() && (self.b[j].is_ascii_digit() || (self.b[j] == b'.' && !dot)) {
                        self.i = j;
                    } else {
                        break;
                    }
                }
                _ => break,
            }
        }
        let text = &self.b[num_start..self.i];
        if !text.iter().any(u8::is_ascii_digit) {
            self.i = start.max(num_start);
            return self.err(GcodeErrorKind::BadNumber(if text.is_empty() {
                "expected a number".into()
            } else {
                format!("'{}' has no digits", String::from_utf8_lossy(text))
            }));
        }
        let _ = digits;
        let v = if exact && mant < (1u64 << 53) && (frac as usize) < POW10.len() {
            // Clinger's fast path: both operands exact, one correctly rounded division.
            mant as f64 / POW10[frac as usize]
        } else {
            slow_parse(text).ok_or((num_start, GcodeErrorKind::BadNumber("unreadable number".into())))?
        };
        Ok(if neg { -v } else { v })
    }

    /// A word's value: a number, `#param`, `[expression]` or a unary function, with an optional sign.
    pub fn real_value(&mut self, p: &mut Params, depth: u32) -> R<f64> {
        if depth > MAX_DEPTH {
            return self.err(GcodeErrorKind::Expression("nested too deeply".into()));
        }
        self.skip_ws();
        match self.b.get(self.i).copied() {
            Some(b'0'..=b'9' | b'.') => self.number(),
            Some(s @ (b'-' | b'+')) => {
                let save = self.i;
                self.i += 1;
                match self.peek() {
                    Some(b'0'..=b'9' | b'.') => {
                        self.i = save;
                        self.number()
                    }
                    Some(b'[' | b'#' | b'a'..=b'z') => {
                        let v = self.real_value(p, depth + 1)?;
                        Ok(if s == b'-' { -v } else { v })
                    }
                    _ => self.err(GcodeErrorKind::BadNumber("sign without a number".into())),
                }
            }
            Some(b'[') => {
                self.i += 1;
                let v = self.expr(p, 0, depth + 1)?;
                match self.peek() {
                    Some(b']') => {
                        self.i += 1;
                        Ok(v)
                    }
                    _ => self.err(GcodeErrorKind::Expression("expected ']'".into())),
                }
            }
            Some(b'#') => self.param_value(p, depth + 1),
            Some(c) if c.is_ascii_alphabetic() => self.function(p, depth + 1),
            _ => self.err(GcodeErrorKind::BadNumber("expected a number".into())),
        }
    }

    /// Reads `#n`, `##n`, `#[expr]` or `#<name>` (the `#` not yet consumed).
    pub fn param_key(&mut self, p: &mut Params, depth: u32) -> R<ParamKey> {
        let at = self.i;
        self.i += 1; // '#'
        match self.peek() {
            Some(b'<') => {
                self.i += 1;
                let s = self.i;
                while self.i < self.b.len() && self.b[self.i] != b'>' {
                    self.i += 1;
                }
                if self.i >= self.b.len() {
                    return Err((at, GcodeErrorKind::Expression("named parameter without '>'".into())));
                }
                let e = self.i;
                self.i += 1;
                if self.b[s..e].iter().all(u8::is_ascii_whitespace) {
                    return Err((at, GcodeErrorKind::Expression("empty parameter name".into())));
                }
                Ok(ParamKey::Named(s, e))
            }
            _ => {
                let v = self.real_value(p, depth + 1)?;
                let n = v.round();
                if (v - n).abs() > 1e-4 || !(1.0..=MAX_PARAM as f64).contains(&n) {
                    return Err((at, GcodeErrorKind::ParameterOutOfRange(n as i64)));
                }
                Ok(ParamKey::Num(n as usize))
            }
        }
    }

    fn param_value(&mut self, p: &mut Params, depth: u32) -> R<f64> {
        let at = self.i;
        match self.param_key(p, depth)? {
            ParamKey::Num(n) => Ok(p.numbered[n]),
            ParamKey::Named(s, e) => p.get_named(&self.b[s..e]).ok_or_else(|| {
                (
                    at,
                    GcodeErrorKind::UndefinedParameter(
                        String::from_utf8_lossy(&self.b[s..e]).trim().to_lowercase(),
                    ),
                )
            }),
        }
    }

    fn function(&mut self, p: &mut Params, depth: u32) -> R<f64> {
        let at = self.i;
        let mut name = [0u8; 8];
        let mut n = 0;
        while let Some(c) = self.peek() {
            if !c.is_ascii_alphabetic() {
                break;
            }
            if n == name.len() {
                return Err((at, GcodeErrorKind::Expression("unknown function".into())));
            }
            name[n] = c;
            n += 1;
            self.i += 1;
        }
        let name = &name[..n];
        if self.peek() != Some(b'[') {
            return Err((at, GcodeErrorKind::NotGcode("expected a number".into())));
        }
        if name == b"exists" {
            self.i += 1;
            let ok = if self.peek() == Some(b'#') {
                match self.param_key(p, depth)? {
                    ParamKey::Named(s, e) => p.get_named(&self.b[s..e]).is_some(),
                    ParamKey::Num(_) => true,
                }
            } else {
                return self.err(GcodeErrorKind::Expression("EXISTS needs a #<name>".into()));
            };
            if self.peek() != Some(b']') {
                return self.err(GcodeErrorKind::Expression("expected ']'".into()));
            }
            self.i += 1;
            return Ok(if ok { 1.0 } else { 0.0 });
        }
        let a = self.real_value(p, depth)?;
        let dom = |what: &str| Err((at, GcodeErrorKind::Expression(format!("{what} outside its domain"))));
        let v = match name {
            b"abs" => a.abs(),
            b"acos" => {
                if !(-1.0..=1.0).contains(&a) {
                    return dom("ACOS argument");
                }
                a.acos().to_degrees()
            }
            b"asin" => {
                if !(-1.0..=1.0).contains(&a) {
                    return dom("ASIN argument");
                }
                a.asin().to_degrees()
            }
            b"atan" => {
                // ATAN[y]/[x], always two-argument in LinuxCNC.
                if self.peek() != Some(b'/') {
                    return self.err(GcodeErrorKind::Expression("ATAN needs [y]/[x]".into()));
                }
                self.i += 1;
                if self.peek() != Some(b'[') {
                    return self.err(GcodeErrorKind::Expression("ATAN needs [y]/[x]".into()));
                }
                let b = self.real_value(p, depth)?;
                a.atan2(b).to_degrees()
            }
            b"cos" => a.to_radians().cos(),
            b"sin" => a.to_radians().sin(),
            b"tan" => a.to_radians().tan(),
            b"exp" => a.exp(),
            b"fix" => a.floor(),
            b"fup" => a.ceil(),
            b"round" => a.round(),
            b"ln" => {
                if a <= 0.0 {
                    return dom("LN argument");
                }
                a.ln()
            }
            b"sqrt" => {
                if a < 0.0 {
                    return dom("SQRT argument");
                }
                a.sqrt()
            }
            _ => {
                return Err((
                    at,
                    GcodeErrorKind::Expression(format!("unknown function {}", String::from_utf8_lossy(name))),
                ));
            }
        };
        finite(v, at)
    }

    /// Reads a binary operator if one follows (does not consume it): returns (op, length).
    fn peek_op(&mut self) -> R<Option<(Op, usize)>> {
        self.skip_ws();
        let rest = &self.b[self.i..];
        let lower = |k: usize| rest.get(k).map(|c| c.to_ascii_lowercase());
        let c0 = match lower(0) {
            Some(c) => c,
            None => return self.err(GcodeErrorKind::Expression("expected ']'".into())),
        };
        let two = (lower(0), lower(1));
        let three = (lower(0), lower(1), lower(2));
        Ok(Some(match c0 {
            b']' => return Ok(None),
            b'+' => (Op::Add, 1),
            b'-' => (Op::Sub, 1),
            b'*' if lower(1) == Some(b'*') => (Op::Pow, 2),
            b'*' => (Op::Mul, 1),
            b'/' => (Op::Div, 1),
            _ => match three {
                (Some(b'm'), Some(b'o'), Some(b'd')) => (Op::Mod, 3),
                (Some(b'a'), Some(b'n'), Some(b'd')) => (Op::And, 3),
                (Some(b'x'), Some(b'o'), Some(b'r')) => (Op::Xor, 3),
                _ => match two {
                    (Some(b'o'), Some(b'r')) => (Op::Or, 2),
                    (Some(b'e'), Some(b'q')) => (Op::Eq, 2),
                    (Some(b'n'), Some(b'e')) => (Op::Ne, 2),
                    (Some(b'g'), Some(b't')) => (Op::Gt, 2),
                    (Some(b'g'), Some(b'e')) => (Op::Ge, 2),
                    (Some(b'l'), Some(b't')) => (Op::Lt, 2),
                    (Some(b'l'), Some(b'e')) => (Op::Le, 2),
                    _ => return self.err(GcodeErrorKind::Expression("expected an operator or ']'".into())),
                },
            },
        }))
    }

    /// Precedence climbing over LinuxCNC's levels (all binary operators left-associative).
    fn expr(&mut self, p: &mut Params, min_prec: u8, depth: u32) -> R<f64> {
        let mut lhs = self.real_value(p, depth)?;
        loop {
            let at = self.i;
            let Some((op, len)) = self.peek_op()? else { return Ok(lhs) };
            let prec = op.prec();
            if prec < min_prec {
                return Ok(lhs);
            }
            self.i += len;
            let rhs = self.expr(p, prec + 1, depth + 1)?;
            lhs = op.apply(lhs, rhs).map_err(|m| (at, GcodeErrorKind::Expression(m.into())))?;
            lhs = finite(lhs, at)?;
        }
    }
}

fn finite(v: f64, at: usize) -> R<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err((at, GcodeErrorKind::Expression("result is not a finite number".into())))
    }
}

fn slow_parse(text: &[u8]) -> Option<f64> {
    let mut buf = [0u8; 128];
    let mut n = 0;
    for &c in text {
        if c != b' ' && c != b'\t' {
            if n == buf.len() {
                return None;
            }
            buf[n] = c;
            n += 1;
        }
    }
    std::str::from_utf8(&buf[..n]).ok()?.parse().ok()
}

#[derive(Debug, Clone, Copy)]
enum Op {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Pow,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl Op {
    fn prec(self) -> u8 {
        match self {
            Op::And | Op::Or | Op::Xor => 1,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 2,
            Op::Add | Op::Sub => 3,
            Op::Mul | Op::Div | Op::Mod => 4,
            Op::Pow => 5,
        }
    }

    fn apply(self, a: f64, b: f64) -> Result<f64, &'static str> {
        let t = |c: bool| if c { 1.0 } else { 0.0 };
        // LinuxCNC compares with TOLERANCE_EQUAL = 0.0001.
        const EQ: f64 = 1e-4;
        Ok(match self {
            Op::Add => a + b,
            Op::Sub => a - b,
            Op::Mul => a * b,
            Op::Div => {
                if b == 0.0 {
                    return Err("division by zero");
                }
                a / b
            }
            Op::Mod => {
                if b == 0.0 {
                    return Err("MOD by zero");
                }
                let r = a % b;
                if r < 0.0 { r + b.abs() } else { r }
            }
            Op::Pow => {
                if a < 0.0 && b.fract() != 0.0 {
                    return Err("negative base to a non-integer power");
                }
                a.powf(b)
            }
            Op::Eq => t((a - b).abs() < EQ),
            Op::Ne => t((a - b).abs() >= EQ),
            Op::Gt => t(a > b),
            Op::Ge => t(a >= b),
            Op::Lt => t(a < b),
            Op::Le => t(a <= b),
            Op::And => t(a != 0.0 && b != 0.0),
            Op::Or => t(a != 0.0 || b != 0.0),
            Op::Xor => t((a != 0.0) != (b != 0.0)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference: strip blanks, parse with the standard library.
    fn reference(text: &str) -> Option<f64> {
        let t: String = text.chars().filter(|c| !c.is_ascii_whitespace()).collect();
        t.parse::<f64>().ok()
    }

    #[test]
    fn numbers_match_the_standard_library() {
        let mut next = crate::xorshift(0x1234_5678_u64);
        let mut p = Params::default();
        for case in 0..200_000 {
            let int_digits = (next() % 14) as usize;
            let frac_digits = (next() % 14) as usize;
            let mut t = String::new();
            match next() % 4 {
                0 => t.push('-'),
                1 => t.push('+'),
                _ => {}
            }
            for _ in 0..int_digits {
                t.push((b'0' + (next() % 10) as u8) as char);
            }
            if frac_digits > 0 || next().is_multiple_of(3) {
                t.push('.');
            }
            for _ in 0..frac_digits {
                t.push((b'0' + (next() % 10) as u8) as char);
            }
            let tail = [" X1", "", "Y", " ", ";", "(c)"][(next() % 6) as usize];
            let line = format!("{t}{tail}");
            let mut c = Cursor { b: line.as_bytes(), i: 0 };
            let got = c.real_value(&mut p, 0);
            match reference(&t) {
                Some(want) if int_digits + frac_digits > 0 => {
                    assert_eq!(got, Ok(want), "case {case}: {line:?}");
                    assert_eq!(c.i, t.len(), "case {case}: {line:?} consumed");
                }
                _ => assert!(got.is_err(), "case {case}: {line:?} gave {got:?}"),
            }
        }
    }
}
