//! Two-stage parsing of large in-memory programs: a second thread splits the text into
//! lines and lexes the plain ones (letters with plain numbers and comments, which are
//! nearly all lines of real programs), while the calling thread interprets them and
//! feeds the sink. Lexing a plain line needs no interpreter state, so the result is the
//! same as the one-thread parser's, line for line; any line the pre-lexer does not take
//! (parameters, expressions, O words, checksums, block delete, errors) is lexed again by
//! the full lexer on the interpreting thread, so its errors and columns are the same too.

use std::sync::mpsc;

use super::{
    Interp, MotionSink, ParseError, ParseOptions, ParseSummary, find_eol, plain_code, starts_plain_number,
};
use crate::expr::{Cursor, plain_number};

/// Inputs at least this long are parsed in two stages when two cores are available.
pub(super) const MIN_BYTES: usize = 1 << 20;

/// Lines per chunk handed from the lexing thread to the interpreter.
const CHUNK_LINES: usize = 4096;

/// One pre-lexed word: a G or M code (`code`, G × 10) or a letter with its value.
#[derive(Clone, Copy)]
pub(super) struct Word {
    pub letter: u8,
    pub code: u16,
    pub col: u32,
    pub value: f64,
}

/// Where a line is and what the pre-lexer made of it.
#[derive(Clone, Copy)]
struct LineRec {
    start: usize,
    end: usize,
    /// Index of the first word and comment in the chunk's lists.
    words: u32,
    comments: u32,
    nwords: u8,
    ncomments: u8,
    kind: Kind,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Nothing but blanks.
    Blank,
    /// Words and comments in the chunk's lists.
    Lexed,
    /// Left to the full lexer.
    Full,
}

/// The pre-lexed form of one line, as the interpreter takes it.
pub(super) enum Pre<'c> {
    Blank,
    Lexed { words: &'c [Word], comments: &'c [(u32, u32)] },
}

#[derive(Default)]
struct Chunk {
    lines: Vec<LineRec>,
    words: Vec<Word>,
    comments: Vec<(u32, u32)>,
}

/// Most words and comments a line may have to be pre-lexed (more go to the full lexer).
const MAX_WORDS: usize = 16;
const MAX_COMMENTS: usize = 4;

/// Lexes a plain line into `words` and `comments`, or returns `None` (nothing pushed that
/// counts) for any line the full lexer must see. The accepted language is a subset of
/// [`Interp::lex`]'s, with the same words, codes, values and columns.
fn quick_lex(b: &[u8], words: &mut Vec<Word>, comments: &mut Vec<(u32, u32)>) -> Option<Kind> {
    let mut c = Cursor { b, i: 0 };
    c.skip_ws();
    match b.get(c.i) {
        None => return Some(Kind::Blank),
        Some(b'/' | b'%') => return None,
        _ => {}
    }
    let (w0, c0) = (words.len(), comments.len());
    let (mut ng, mut nm, mut mask) = (0usize, 0usize, 0u32);
    loop {
        c.skip_ws();
        let Some(&ch) = b.get(c.i) else { break };
        let at = c.i;
        match ch {
            b'(' => {
                let k = b[at + 1..].iter().position(|&x| x == b')')?;
                comments.push(((at + 1) as u32, (at + 1 + k) as u32));
                c.i = at + k + 2;
            }
            b';' => {
                comments.push(((at + 1) as u32, b.len() as u32));
                break;
            }
            _ if ch.is_ascii_alphabetic() => {
                let l = ch.to_ascii_lowercase();
                c.i += 1;
                if !starts_plain_number(b, c.i) || l == b'o' {
                    return None;
                }
                if l == b'g' || l == b'm' {
                    let (code, next) = plain_code(b, c.i, l == b'g')?;
                    let n = if l == b'g' { &mut ng } else { &mut nm };
                    *n += 1;
                    if *n > if l == b'g' { 16 } else { 8 } {
                        return None;
                    }
                    words.push(Word { letter: l, code, col: at as u32, value: 0.0 });
                    c.i = next;
                } else {
                    let (value, next) = plain_number(b, c.i)?;
                    c.i = next;
                    let bit = 1u32 << (l - b'a');
                    if mask & bit != 0 {
                        return None;
                    }
                    mask |= bit;
                    words.push(Word { letter: l, code: 0, col: at as u32, value });
                }
            }
            _ => return None,
        }
        if words.len() - w0 > MAX_WORDS || comments.len() - c0 > MAX_COMMENTS {
            return None;
        }
    }
    Some(Kind::Lexed)
}

/// Splits `b[from..]` into lines (the one-thread parser's rule: `\n`, `\r\n` or a lone
/// `\r`) and pre-lexes up to [`CHUNK_LINES`] of them into `chunk`. Returns where the
/// next chunk starts.
fn fill(b: &[u8], from: usize, chunk: &mut Chunk) -> usize {
    chunk.lines.clear();
    chunk.words.clear();
    chunk.comments.clear();
    let mut i = from;
    while i < b.len() && chunk.lines.len() < CHUNK_LINES {
        let rest = &b[i..];
        let end = i + find_eol(rest).unwrap_or(rest.len());
        let (w0, c0) = (chunk.words.len(), chunk.comments.len());
        let kind = quick_lex(&b[i..end], &mut chunk.words, &mut chunk.comments).unwrap_or(Kind::Full);
        if kind != Kind::Lexed {
            chunk.words.truncate(w0);
            chunk.comments.truncate(c0);
        }
        chunk.lines.push(LineRec {
            start: i,
            end,
            words: w0 as u32,
            comments: c0 as u32,
            nwords: (chunk.words.len() - w0) as u8,
            ncomments: (chunk.comments.len() - c0) as u8,
            kind,
        });
        i = end;
        if i < b.len() {
            if b[i] == b'\r' && b.get(i + 1) == Some(&b'\n') {
                i += 1;
            }
            i += 1;
        }
    }
    i
}

/// Whether [`parse_two_stage`] should take an input of `len` bytes.
pub(super) fn worthwhile(len: usize) -> bool {
    len >= MIN_BYTES && std::thread::available_parallelism().is_ok_and(|n| n.get() >= 2)
}

/// [`super::parse_bytes`] in two stages (see the module docs); same summary, same motions.
pub(super) fn parse_two_stage<S: MotionSink>(
    b: &[u8],
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let mut it = Interp::new(opts, None);
    std::thread::scope(|scope| {
        // Two chunks in flight each way: the lexer stays one chunk ahead.
        let (full_tx, full_rx) = mpsc::sync_channel::<Chunk>(2);
        let (empty_tx, empty_rx) = mpsc::sync_channel::<Chunk>(4);
        for _ in 0..3 {
            let _ = empty_tx.send(Chunk::default());
        }
        scope.spawn(move || {
            let mut at = 0;
            while at < b.len() {
                // The interpreter hung up (program end or an error): stop.
                let Ok(mut chunk) = empty_rx.recv() else { return };
                at = fill(b, at, &mut chunk);
                if full_tx.send(chunk).is_err() {
                    return;
                }
            }
        });
        for chunk in full_rx.iter() {
            for r in &chunk.lines {
                let line = &b[r.start..r.end];
                let pre = match r.kind {
                    Kind::Blank => Some(Pre::Blank),
                    Kind::Lexed => Some(Pre::Lexed {
                        words: &chunk.words[r.words as usize..][..r.nwords as usize],
                        comments: &chunk.comments[r.comments as usize..][..r.ncomments as usize],
                    }),
                    Kind::Full => None,
                };
                it.line_pre(line, pre, sink)?;
                if it.done {
                    return Ok(());
                }
            }
            // Hand the buffers back; the lexer may already have finished.
            let _ = empty_tx.send(chunk);
        }
        Ok(())
    })?;
    it.summary.bytes = b.len() as u64;
    it.finish(sink)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parser::tests::{assert_same_parse, dialects, sample_files, splitmix};

    /// The two-stage parser against the one-thread one, on the same bytes.
    fn agree(text: &[u8], opts: &ParseOptions, what: &str) {
        assert_same_parse(text, opts, what, |t, o, rec| parse_two_stage(t, o, rec).expect("infallible sink"));
    }

    #[test]
    fn two_stages_agree_with_one_on_every_sample_file() {
        for (name, text) in sample_files() {
            for opts in dialects() {
                agree(&text, &opts, &name);
                let stop = ParseOptions { stop_at_program_end: false, ..opts.clone() };
                agree(&text, &stop, &name);
            }
        }
    }

    #[test]
    fn two_stages_agree_with_one_on_random_text_across_chunks() {
        // SplitMix64 over a vocabulary that mixes lines the pre-lexer takes with lines it
        // leaves to the full lexer, long enough to span several chunks.
        let mut next = splitmix(0xC0FFEE);
        let words = [
            "G0",
            "G1",
            "G2",
            "G3",
            "G21",
            "G20",
            "G90",
            "G91",
            "G1.5",
            "M3",
            "M30",
            "M2",
            "X",
            "Y",
            "Z",
            "E",
            "F",
            "N",
            "R",
            "I",
            "J",
            "X-",
            "Y+",
            "x",
            "(c)",
            ";LAYER:3",
            "(unclosed",
            "#1=2",
            "X#1",
            "o100 if [1]",
            "o100 endif",
            "%",
            "/",
            "*12",
            "Z[1+2]",
            "G 1",
            "X 1 2",
            "\r",
            "\t",
            "  ",
        ];
        for case in 0..40 {
            let mut text = String::new();
            while text.len() < 3 * CHUNK_LINES * 12 {
                for _ in 0..(next() % 5) {
                    let w = words[(next() % words.len() as u64) as usize];
                    text.push_str(w);
                    if w.len() == 1 || w.ends_with(['-', '+']) {
                        text.push_str(&format!("{}", (next() % 4000) as f64 / 8.0));
                    }
                    if !next().is_multiple_of(3) {
                        text.push(' ');
                    }
                }
                text.push_str(["\n", "\r\n", "\r", "\n\n"][(next() % 4) as usize]);
            }
            for opts in dialects() {
                agree(text.as_bytes(), &opts, &format!("random case {case}"));
            }
        }
    }
}
