//! Lexing: a line into words, comments and parameter assignments; O words.

use super::interp::{Fail, Interp, POLAR_A, POLAR_R, Res, bad_code, bit, repeated, too_many};
use super::words::{Pre, plain_code, starts_plain_number};
use crate::error::GcodeErrorKind;
use crate::expr::Cursor;

impl Interp<'_> {
    /// Forgets the previous line's words, comments and assignments.
    #[inline]
    pub(super) fn clear_line(&mut self) {
        let blk = &mut self.block;
        blk.mask = 0;
        blk.novalue = 0;
        blk.ng = 0;
        blk.nm = 0;
        blk.polar = None;
        self.comments.clear();
        self.assigns.clear();
    }

    /// Splits a line into words, comments and parameter assignments. Returns `false` for
    /// a line with nothing to execute.
    pub(super) fn lex(&mut self, b: &[u8]) -> Res<bool, ()> {
        self.clear_line();
        let mut c = Cursor { b, i: 0 };
        c.skip_ws();
        if c.i >= b.len() {
            return Ok(false);
        }
        if b[c.i] == b'/' {
            if self.opts.block_delete {
                return Ok(false);
            }
            c.i += 1;
            c.skip_ws();
            if c.i >= b.len() {
                return Ok(false);
            }
        }
        if b[c.i] == b'%' {
            c.i += 1;
            c.skip_ws();
            if c.i < b.len() && b[c.i] != b';' && b[c.i] != b'(' {
                return Err(Fail::Line(c.i, GcodeErrorKind::NotGcode("text after '%'".into())));
            }
            if self.seen_percent {
                self.summary.program_end = Some(self.lineno);
                if self.opts.stop_at_program_end {
                    self.done = true;
                }
            }
            self.seen_percent = true;
            return Ok(false);
        }
        // The end of the last run of letters scanned for a function call, and whether a '['
        // follows it.
        let mut letter_run = (0usize, false);
        loop {
            c.skip_ws();
            let Some(&ch) = b.get(c.i) else { break };
            let at = c.i;
            match ch {
                b'(' => {
                    let Some(k) = b[at + 1..].iter().position(|&x| x == b')') else {
                        return Err(Fail::Line(at, GcodeErrorKind::UnclosedComment));
                    };
                    self.comments.push((at + 1, at + 1 + k));
                    c.i = at + k + 2;
                }
                b';' => {
                    self.comments.push((at + 1, b.len()));
                    break;
                }
                b'*' => {
                    self.lex_checksum(b, &mut c, at)?;
                    break;
                }
                b'#' => self.lex_assignment(&mut c, at)?,
                b'@' | b'^' => {
                    // Polar coordinates: `@` radius, `^` angle (degrees).
                    c.i += 1;
                    if matches!(c.peek(), None | Some(b';' | b'(')) {
                        let what = format!("expected a number after '{}'", ch as char);
                        return Err(Fail::Line(at, GcodeErrorKind::NotGcode(what)));
                    }
                    let v = c.real_value(&mut self.params, 0)?;
                    let l = if ch == b'@' { POLAR_R } else { POLAR_A };
                    if self.block.mask & bit(l) != 0 {
                        return Err(Fail::Line(at, GcodeErrorKind::RepeatedWord(ch as char)));
                    }
                    self.store_word(l, v, at)?;
                }
                _ if ch.is_ascii_alphabetic() => {
                    if !self.lex_word(b, &mut c, at, ch, &mut letter_run)? {
                        return Ok(false);
                    }
                }
                _ => {
                    let shown = if ch.is_ascii_graphic() {
                        format!("'{}'", ch as char)
                    } else {
                        format!("byte 0x{ch:02X}")
                    };
                    return Err(Fail::Line(at, GcodeErrorKind::NotGcode(format!("unexpected {shown}"))));
                }
            }
        }
        Ok(true)
    }

    /// A RepRap checksum `*<n>` at `at`: checked against the bytes before it; only a `;`
    /// comment may follow.
    fn lex_checksum(&mut self, b: &[u8], c: &mut Cursor<'_>, at: usize) -> Res<(), ()> {
        // RepRap checksum: XOR of every byte before '*'.
        c.i += 1;
        let ds = c.i;
        while c.i < b.len() && b[c.i].is_ascii_digit() {
            c.i += 1;
        }
        if ds == c.i || c.i - ds > 5 {
            return Err(Fail::Line(at, GcodeErrorKind::NotGcode("'*' without a checksum".into())));
        }
        let stated: u32 = b[ds..c.i].iter().fold(0, |a, &d| a * 10 + (d - b'0') as u32);
        let computed = b[..at].iter().fold(0u8, |a, &x| a ^ x);
        if stated != computed as u32 {
            return Err(Fail::Line(at, GcodeErrorKind::BadChecksum { stated, computed }));
        }
        c.skip_ws();
        match b.get(c.i) {
            None => Ok(()),
            Some(b';') => {
                self.comments.push((c.i + 1, b.len()));
                Ok(())
            }
            Some(_) => Err(Fail::Line(c.i, GcodeErrorKind::NotGcode("text after the checksum".into()))),
        }
    }

    /// A parameter assignment `#<key> = <value>` at `at`.
    fn lex_assignment(&mut self, c: &mut Cursor<'_>, at: usize) -> Res<(), ()> {
        self.sync_params();
        let key = c.param_key(&mut self.params, 0)?;
        if c.peek() != Some(b'=') {
            return Err(Fail::Line(
                at,
                GcodeErrorKind::Expression("parameter reference without '=' outside a word".into()),
            ));
        }
        c.i += 1;
        let v = c.real_value(&mut self.params, 0)?;
        if self.assigns.len() >= 50 {
            return Err(Fail::Line(at, GcodeErrorKind::Expression("more than 50 assignments".into())));
        }
        self.assigns.push((key, v));
        Ok(())
    }

    /// The word whose letter `ch` is at `at` (a number, an expression, a value-less word,
    /// an O word or a template placeholder). Returns `false` to skip the rest of the line.
    /// `letter_run`: the end of the last run of letters scanned, and whether `[` follows it.
    #[inline(always)]
    fn lex_word(
        &mut self,
        b: &[u8],
        c: &mut Cursor<'_>,
        at: usize,
        ch: u8,
        letter_run: &mut (usize, bool),
    ) -> Res<bool, ()> {
        let l = ch.to_ascii_lowercase();
        c.i += 1;
        // Fast path: a plain number right after the letter (`X12.5`, `Y-3`, `F.5`).
        if starts_plain_number(b, c.i) && l != b'o' {
            if (l == b'g' || l == b'm')
                && let Some((code, next)) = plain_code(b, c.i, l == b'g')
            {
                self.store_code(l, code, at)?;
                c.i = next;
                return Ok(true);
            }
            let v = c.number()?;
            self.store_word(l, v, at)?;
            return Ok(true);
        }
        if l == b'o' {
            let blk = &self.block;
            let alone = blk.mask & !bit(b'n') == 0 && blk.ng == 0 && blk.nm == 0 && self.assigns.is_empty();
            match self.o_word(b, at, alone)? {
                Some(next) => {
                    c.i = next;
                    return Ok(true);
                }
                None => return Ok(false),
            }
        }
        if !self.strict && c.peek() == Some(b'{') {
            // A slicer template placeholder left unexpanded (`Y{machine_depth}`).
            let close = b[c.i..].iter().position(|&x| x == b'}');
            let Some(k) = close else {
                return Err(Fail::Line(at, GcodeErrorKind::NotGcode("'{' without '}'".into())));
            };
            c.i += k + 1;
            self.warn(
                at,
                GcodeErrorKind::NotGcode(format!(
                    "unexpanded template in word {}: word ignored",
                    l.to_ascii_uppercase() as char
                )),
            );
            return Ok(true);
        }
        self.sync_params();
        let blk = &mut self.block;
        // A letter followed by another letter: a value-less word, unless a function call follows.
        let nx = c.peek();
        let value = match nx {
            None | Some(b';' | b'(' | b'*') => None,
            Some(n) if n.is_ascii_alphabetic() => {
                // Every letter of one run of letters and blanks ends at the same
                // place, so the run is scanned once, not once per letter.
                if c.i >= letter_run.0 {
                    let mut j = c.i;
                    while j < b.len() && (b[j].is_ascii_alphabetic() || b[j] == b' ' || b[j] == b'\t') {
                        j += 1;
                    }
                    *letter_run = (j, b.get(j) == Some(&b'['));
                }
                if letter_run.1 { Some(c.real_value(&mut self.params, 0)?) } else { None }
            }
            Some(_) => Some(c.real_value(&mut self.params, 0)?),
        };
        let Some(v) = value else {
            if !self.strict && !matches!(l, b'g' | b'm' | b'n') {
                blk.novalue |= bit(l);
                blk.mask |= bit(l);
                blk.vals[(l - b'a') as usize] = 0.0;
                blk.cols[(l - b'a') as usize] = at as u32;
                return Ok(true);
            }
            return Err(Fail::Line(
                at,
                GcodeErrorKind::NotGcode(format!(
                    "expected a number after '{}'",
                    l.to_ascii_uppercase() as char
                )),
            ));
        };
        self.store_word(l, v, at)?;
        Ok(true)
    }

    /// Takes a line the pre-lexer took, as [`Self::lex`] would have left it.
    #[inline]
    pub(super) fn load_pre(&mut self, pre: Pre<'_>) -> bool {
        self.clear_line();
        let blk = &mut self.block;
        let Pre::Lexed { words, comments } = pre else { return false };
        for w in words {
            match w.letter {
                b'g' => {
                    blk.g[blk.ng] = (w.code, w.col);
                    blk.ng += 1;
                }
                b'm' => {
                    blk.m[blk.nm] = (w.code, w.col);
                    blk.nm += 1;
                }
                l => {
                    let k = (l - b'a') as usize;
                    blk.mask |= bit(l);
                    blk.vals[k] = w.value;
                    blk.cols[k] = w.col;
                }
            }
        }
        self.comments.extend(comments.iter().map(|&(s, e)| (s as usize, e as usize)));
        true
    }

    /// Stores one word of the line being lexed (`l` lowercase, `at` its column).
    #[inline(always)]
    pub(super) fn store_word(&mut self, l: u8, v: f64, at: usize) -> Res<(), ()> {
        let blk = &mut self.block;
        match l {
            b'g' | b'm' => {
                // Codes are stored × 10 for G (`G91.1` = 911), as is for M. Round half up
                // without libm (the range check comes first).
                let t = if l == b'g' { v * 10.0 } else { v };
                let code = if (0.0..=9999.0).contains(&t) { (t + 0.5) as u32 } else { u32::MAX };
                if code == u32::MAX || (t - code as f64).abs() > 1e-6 {
                    return Err(bad_code(l, v, at));
                }
                return self.store_code(l, code as u16, at);
            }
            _ => {
                let k = (l - b'a') as usize;
                if blk.mask & bit(l) != 0 {
                    return Err(repeated(l, at));
                }
                blk.mask |= bit(l);
                blk.vals[k] = v;
                blk.cols[k] = at as u32;
            }
        }
        Ok(())
    }

    /// Stores a G code (× 10) or M code.
    #[inline(always)]
    pub(super) fn store_code(&mut self, l: u8, code: u16, at: usize) -> Res<(), ()> {
        let blk = &mut self.block;
        let (list, n) = if l == b'g' { (&mut blk.g[..], &mut blk.ng) } else { (&mut blk.m[..], &mut blk.nm) };
        let Some(slot) = list.get_mut(*n) else { return Err(too_many(l, at)) };
        *slot = (code, at as u32);
        *n += 1;
        Ok(())
    }

    /// Handles an O word at `at` (LinuxCNC control flow or a Fanuc program number).
    /// `alone`: no other word precedes it on the line. Returns where lexing goes on
    /// (a program number), `None` to skip the line, or the line's error.
    pub(super) fn o_word(&mut self, b: &[u8], at: usize, alone: bool) -> Res<Option<usize>, ()> {
        let o = read_o_word(b, at).map_err(|k| Fail::Line(at, k))?;
        let shown = String::from_utf8_lossy(&b[at..o.end]).trim().to_string();
        let rest_empty =
            matches!(b[o.end..].iter().find(|c| !matches!(c, b' ' | b'\t')), None | Some(b'(' | b';'));
        if o.keyword.is_empty() {
            return match o.number {
                Some(n) if alone && rest_empty && !self.strict => {
                    // Fanuc program number `O1234`: a label, nothing to execute.
                    self.summary.program_number.get_or_insert(n);
                    Ok(Some(o.end))
                }
                Some(_) if alone && rest_empty => Err(Fail::Line(
                    at,
                    GcodeErrorKind::Unsupported(format!(
                        "program number {shown} (Fanuc): LinuxCNC needs an O-word keyword"
                    )),
                )),
                _ => Err(Fail::Line(
                    at,
                    GcodeErrorKind::Unsupported(format!("O-word {shown} without a control-flow keyword")),
                )),
            };
        }
        if !alone || !rest_empty && !flow_keyword_takes_args(&o.keyword) {
            return Err(Fail::Line(
                at,
                GcodeErrorKind::ControlFlow(format!("{shown}: an O-word must begin its line, alone")),
            ));
        }
        if self.in_flow || !is_flow_keyword(&o.keyword) {
            // Under control flow every O-word line is taken by the flow driver first.
            return Err(Fail::Line(
                at,
                GcodeErrorKind::ControlFlow(format!("{shown}: unknown O-word keyword '{}'", o.keyword)),
            ));
        }
        // The driver runs the program from this line on with control flow.
        self.flow_request = true;
        self.done = true;
        Ok(None)
    }
}

/// Whether `kw` is a LinuxCNC O-word keyword.
pub(super) fn is_flow_keyword(kw: &str) -> bool {
    matches!(
        kw,
        "sub"
            | "endsub"
            | "call"
            | "return"
            | "if"
            | "elseif"
            | "else"
            | "endif"
            | "while"
            | "endwhile"
            | "do"
            | "break"
            | "continue"
            | "repeat"
            | "endrepeat"
    )
}

/// Whether an O-word keyword may be followed by expressions on its line.
fn flow_keyword_takes_args(kw: &str) -> bool {
    matches!(kw, "call" | "return" | "endsub" | "if" | "elseif" | "while" | "repeat")
}

/// An O word as read by [`read_o_word`].
pub(super) struct OWord {
    /// The label lowercased, without blanks and leading zeros: what closing lines must repeat.
    pub(super) norm: Vec<u8>,
    /// The value of an all-digit label.
    number: Option<u32>,
    /// The keyword (`sub`, `if`, ...), lowercased; empty when none.
    pub(super) keyword: String,
    /// Where the line goes on after the keyword.
    pub(super) end: usize,
}

/// Reads the O word whose letter is at `at`: its label and keyword.
pub(super) fn read_o_word(b: &[u8], at: usize) -> Result<OWord, GcodeErrorKind> {
    let blank = |c: u8| c == b' ' || c == b'\t';
    let mut i = at + 1;
    while i < b.len() && blank(b[i]) {
        i += 1;
    }
    let start = i;
    match b.get(i) {
        Some(b'<') => match b[i..].iter().position(|&c| c == b'>') {
            Some(k) => i += k + 1,
            None => return Err(GcodeErrorKind::NotGcode("O-word name without '>'".into())),
        },
        Some(b'[') => {
            let mut depth = 0u32;
            while i < b.len() {
                match b[i] {
                    b'[' => depth += 1,
                    b']' => depth -= 1,
                    _ => {}
                }
                i += 1;
                if depth == 0 {
                    break;
                }
            }
            if depth != 0 {
                return Err(GcodeErrorKind::Expression("O-word label without ']'".into()));
            }
        }
        _ => {
            while i < b.len()
                && (b[i].is_ascii_digit()
                    || (blank(b[i]) && b[i + 1..].first().is_some_and(u8::is_ascii_digit)))
            {
                i += 1;
            }
        }
    }
    if i == start {
        return Err(GcodeErrorKind::NotGcode("expected a number or <name> after 'O'".into()));
    }
    let mut norm: Vec<u8> = b[start..i].iter().filter(|&&c| !blank(c)).map(u8::to_ascii_lowercase).collect();
    let digits = norm.iter().all(u8::is_ascii_digit);
    if digits {
        let z = norm.iter().take_while(|&&c| c == b'0').count().min(norm.len().saturating_sub(1));
        norm.drain(..z);
    }
    let number = if digits && norm.len() <= 9 {
        Some(norm.iter().fold(0u32, |a, &d| a * 10 + (d - b'0') as u32))
    } else {
        None
    };
    while i < b.len() && blank(b[i]) {
        i += 1;
    }
    let ks = i;
    while i < b.len() && b[i].is_ascii_alphabetic() && i - ks < 16 {
        i += 1;
    }
    let keyword = String::from_utf8_lossy(&b[ks..i]).to_ascii_lowercase();
    Ok(OWord { norm, number, keyword, end: i })
}
