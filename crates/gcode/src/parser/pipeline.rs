//! Two-stage parsing of large in-memory programs. The text is cut into chunks of about
//! [`CHUNK_BYTES`], each ending just after a `\n`, so every chunk starts a line and can be
//! split into lines and lexed on its own. Lexing a plain line (letters with plain numbers
//! and comments, which are nearly all lines of real programs) needs no interpreter state.
//! A second thread lexes chunks ahead, while the calling thread interprets them in order and
//! feeds the sink; whenever the next chunk is not lexed yet, the calling thread lexes one
//! itself instead of waiting, so the two cores share the lexing and neither idles.
//!
//! The result is the one-thread parser's, line for line: any line the pre-lexer does not
//! take (parameters, expressions, O words, checksums, block delete, errors) is lexed again
//! by the full lexer on the interpreting thread, so its errors and columns are the same too.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

use super::interp::Interp;
use super::options::{ParseOptions, ParseSummary};
use super::words::{Pre, Word, find_eol, plain_code, starts_plain_number};
use crate::error::ParseError;
use crate::expr::{Cursor, plain_number};
use crate::motion::MotionSink;

/// Inputs at least this long are parsed in two stages when two cores are available.
pub(super) const MIN_BYTES: usize = 1 << 20;

/// Bytes per chunk, before it is stretched to the end of its last line.
pub(super) const CHUNK_BYTES: usize = 128 << 10;

/// Lexed chunks the second thread may hold ready before it waits for the interpreter.
const AHEAD: usize = 4;

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

/// Where the chunk boundary at or after byte `at` is: just after the first `\n` at or after
/// `at - 1`, the start or the end of `b`. Cutting only after a `\n` keeps `\r\n` together
/// and never splits a line, whatever its terminator.
fn boundary(b: &[u8], at: usize) -> usize {
    if at == 0 || at >= b.len() {
        return at.min(b.len());
    }
    b[at - 1..].iter().position(|&c| c == b'\n').map_or(b.len(), |k| at + k)
}

/// The bytes of chunk `k` of chunks of `size` bytes.
fn chunk_range(b: &[u8], k: usize, size: usize) -> std::ops::Range<usize> {
    let at = |k: usize| boundary(b, k.saturating_mul(size));
    at(k)..at(k + 1)
}

/// Number of chunks of `b`. A line longer than a chunk leaves the chunks it swallows
/// empty; they cost nothing.
fn chunk_count(b: &[u8], size: usize) -> usize {
    b.len().div_ceil(size)
}

/// Splits `b[range]` into lines (the one-thread parser's rule: `\n`, `\r\n` or a lone
/// `\r`) and pre-lexes them into `chunk`.
fn fill(b: &[u8], range: std::ops::Range<usize>, chunk: &mut Chunk) {
    chunk.lines.clear();
    chunk.words.clear();
    chunk.comments.clear();
    let (mut i, to) = (range.start, range.end);
    while i < to {
        let rest = &b[i..to];
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
        if i < to {
            if b[i] == b'\r' && b.get(i + 1) == Some(&b'\n') {
                i += 1;
            }
            i += 1;
        }
    }
}

/// Whether [`parse_two_stage`] should take an input of `len` bytes.
pub(super) fn worthwhile(len: usize) -> bool {
    len >= MIN_BYTES && std::thread::available_parallelism().is_ok_and(|n| n.get() >= 2)
}

/// [`super::parse_bytes`] in two stages (see the module docs) with chunks of `chunk_bytes`
/// (at least 1; [`CHUNK_BYTES`] for speed, far fewer to test the chunk boundaries); same
/// summary, same motions.
pub(super) fn parse_two_stage<S: MotionSink>(
    b: &[u8],
    opts: &ParseOptions,
    sink: &mut S,
    chunk_bytes: usize,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let size = chunk_bytes.max(1);
    let mut it = Interp::new(opts, None);
    let chunks = chunk_count(b, size);
    // The next chunk either thread may claim; claims go up one at a time, so the lexing
    // thread's chunks arrive in order.
    let next = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        let (full_tx, full_rx) = mpsc::sync_channel::<(usize, Chunk)>(AHEAD);
        let (empty_tx, empty_rx) = mpsc::channel::<Chunk>();
        let next = &next;
        scope.spawn(move || {
            loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                if k >= chunks {
                    return;
                }
                let mut chunk = empty_rx.try_recv().unwrap_or_default();
                fill(b, chunk_range(b, k, size), &mut chunk);
                // The interpreter hung up (program end or an error): stop.
                if full_tx.send((k, chunk)).is_err() {
                    return;
                }
            }
        });
        // Chunks lexed ahead of the one being interpreted, by either thread, and a spare
        // buffer for this thread's own lexing.
        let mut ready: BTreeMap<usize, Chunk> = BTreeMap::new();
        let mut spare: Option<Chunk> = None;
        for k in 0..chunks {
            let chunk = loop {
                if let Some(c) = ready.remove(&k) {
                    break c;
                }
                if let Ok((j, c)) = full_rx.try_recv() {
                    ready.insert(j, c);
                    continue;
                }
                // Chunk `k` is not lexed yet: lex the next unclaimed chunk here rather than
                // wait; once every chunk is claimed, `k` is in flight on the other thread.
                let j = next.fetch_add(1, Ordering::Relaxed);
                if j < chunks {
                    let mut c = spare.take().unwrap_or_default();
                    fill(b, chunk_range(b, j, size), &mut c);
                    ready.insert(j, c);
                } else if let Ok((j, c)) = full_rx.recv() {
                    ready.insert(j, c);
                } else {
                    // The other thread is gone without sending `k` (it cannot be, short of a
                    // panic there): lex it here.
                    let mut c = spare.take().unwrap_or_default();
                    fill(b, chunk_range(b, k, size), &mut c);
                    break c;
                }
            };
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
                    if it.flow_request {
                        let mut j = r.end;
                        if j < b.len() {
                            j += if b[j] == b'\r' && b.get(j + 1) == Some(&b'\n') { 2 } else { 1 };
                        }
                        return super::flow::run(&mut it, line, &b[j..], sink);
                    }
                    return Ok(());
                }
            }
            // Keep one buffer, hand the others back; the lexer may already have finished.
            if spare.is_none() {
                spare = Some(chunk);
            } else {
                let _ = empty_tx.send(chunk);
            }
        }
        Ok(())
    })?;
    it.summary.bytes = b.len() as u64;
    it.finish(sink)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parser::testing::{assert_same_parse, dialects, sample_files, splitmix};

    /// The two-stage parser against the one-thread one, on the same bytes, with the real
    /// chunks and with chunks of a few lines.
    fn agree(text: &[u8], opts: &ParseOptions, what: &str) {
        for size in [CHUNK_BYTES, 97] {
            assert_same_parse(text, opts, what, |t, o, rec| {
                parse_two_stage(t, o, rec, size).expect("infallible sink")
            });
        }
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
    fn chunks_tile_the_input_and_end_after_a_newline() {
        let long_line = format!("G1 X1 ({})", "a".repeat(2 * CHUNK_BYTES)); // longer than two chunks
        let crlf_at_cut = format!("{}\r\nG1 X1\n", "a".repeat(CHUNK_BYTES - 1));
        let cases = [
            String::new(),
            "G1 X1".into(),
            "G1 X1\rG1 X2\r".repeat(CHUNK_BYTES / 4), // only lone \r: one chunk
            format!("G0\n{long_line}\nG1 X2\n{long_line}"),
            crlf_at_cut,
            "G1 X1 Y2\n".repeat(CHUNK_BYTES / 3),
        ];
        for text in &cases {
            let b = text.as_bytes();
            let n = chunk_count(b, CHUNK_BYTES);
            let mut at = 0;
            for k in 0..n {
                let r = chunk_range(b, k, CHUNK_BYTES);
                assert_eq!(r.start, at, "chunk {k} starts where {} ended", k.wrapping_sub(1));
                if !r.is_empty() && r.end < b.len() {
                    assert_eq!(b[r.end - 1], b'\n', "chunk {k} ends after a newline");
                }
                at = r.end;
            }
            assert_eq!(at, b.len(), "the chunks cover the input");
            assert!(chunk_range(b, n, CHUNK_BYTES).is_empty(), "nothing after the last chunk");
            for opts in dialects() {
                agree(b, &opts, "chunk edge case");
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
            while text.len() < 3 * CHUNK_BYTES {
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
