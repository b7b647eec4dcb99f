//! Byte-level word scanning shared by the lexer ([`super::lex`]) and the pre-lexer of
//! [`super::pipeline`]: line ends, plain numbers and codes, and the pre-lexed form of a line.

/// One pre-lexed word: a G or M code (`code`, G × 10) or a letter with its value.
#[derive(Clone, Copy)]
pub(super) struct Word {
    pub letter: u8,
    pub code: u16,
    pub col: u32,
    pub value: f64,
}

/// The pre-lexed form of one line, as the interpreter takes it.
pub(super) enum Pre<'c> {
    Blank,
    Lexed { words: &'c [Word], comments: &'c [(u32, u32)] },
}

/// Index of the first `\n` or `\r` in `b`, eight bytes at a time.
#[inline]
pub(super) fn find_eol(b: &[u8]) -> Option<usize> {
    const LO: u64 = 0x0101_0101_0101_0101;
    const HI: u64 = 0x8080_8080_8080_8080;
    let mut chunks = b.chunks_exact(8);
    let mut i = 0;
    for ch in chunks.by_ref() {
        let mut w = [0u8; 8];
        w.copy_from_slice(ch);
        let w = u64::from_le_bytes(w);
        let x = w ^ (LO * b'\n' as u64);
        let y = w ^ (LO * b'\r' as u64);
        // A zero byte of x or y marks a match; the lowest flagged byte is always exact.
        let t = (x.wrapping_sub(LO) & !x | y.wrapping_sub(LO) & !y) & HI;
        if t != 0 {
            return Some(i + (t.trailing_zeros() / 8) as usize);
        }
        i += 8;
    }
    chunks.remainder().iter().position(|&c| c == b'\n' || c == b'\r').map(|k| i + k)
}

/// Whether a plain number (digit or dot, after at most a sign) starts at `b[i]`.
#[inline(always)]
pub(super) fn starts_plain_number(b: &[u8], i: usize) -> bool {
    match b.get(i) {
        Some(b'0'..=b'9' | b'.') => true,
        Some(b'-' | b'+') => matches!(b.get(i + 1), Some(b'0'..=b'9' | b'.')),
        _ => false,
    }
}

/// A G code (× 10: `G91.1` is 911) or M code written as plain digits at `b[i..]`
/// (`1`, `01`, `91.1`), and where it ends; `None` for anything else (signs, blanks inside,
/// more decimals, out of range), which the general number reader then handles.
#[inline(always)]
pub(super) fn plain_code(b: &[u8], i: usize, g: bool) -> Option<(u16, usize)> {
    let mut j = i;
    let mut v = 0u32;
    while let Some(&c) = b.get(j)
        && c.is_ascii_digit()
        && j - i < 5
    {
        v = v * 10 + (c - b'0') as u32;
        j += 1;
    }
    if j == i {
        return None;
    }
    let mut code = v;
    if g {
        code *= 10;
        if b.get(j) == Some(&b'.') {
            j += 1;
            if let Some(&c) = b.get(j)
                && c.is_ascii_digit()
            {
                code += (c - b'0') as u32;
                j += 1;
            }
        }
    }
    match b.get(j) {
        Some(c) if c.is_ascii_digit() || *c == b'.' => return None,
        Some(b' ' | b'\t') => {
            // `G 1 2` continues the number: leave it to the general reader.
            let k = b[j..].iter().position(|&c| c != b' ' && c != b'\t').map_or(b.len(), |k| j + k);
            if b.get(k).is_some_and(|&c| c.is_ascii_digit() || c == b'.') {
                return None;
            }
        }
        _ => {}
    }
    if code > 9999 {
        return None;
    }
    Some((code as u16, j))
}
