//! LinuxCNC O-word control flow: the slow path a program takes from its first O-word
//! line on. The rest of the program is split into lines, its O-word lines matched up
//! (`sub`/`endsub`, `if`/`elseif`/`else`/`endif`, `while`/`endwhile`, `do`/`while`,
//! `repeat`/`endrepeat`, `break`, `continue`, `return`), then run with a program counter;
//! every other line goes through the ordinary line interpreter.

use std::collections::{BTreeMap, HashMap};

use super::interp::{Fail, Interp};
use super::lex::read_o_word;
use super::words::find_eol;
use crate::error::{GcodeErrorKind, ParseError};
use crate::expr::Cursor;
use crate::motion::MotionSink;

/// An O-word keyword.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kw {
    Sub,
    EndSub,
    Call,
    Return,
    If,
    ElseIf,
    Else,
    EndIf,
    While,
    EndWhile,
    Do,
    /// The `while` that closes a `do`.
    DoWhile,
    Break,
    Continue,
    Repeat,
    EndRepeat,
}

/// One O-word line.
struct OLine {
    /// Column of the `O`.
    col: usize,
    /// The normalised label.
    label: Vec<u8>,
    kw: Kw,
    /// Where the keyword's expressions start.
    args: usize,
}

/// A program's lines and how its O-word lines pair up (indices into `lines`).
struct Program<'b> {
    lines: Vec<&'b [u8]>,
    o: Vec<Option<OLine>>,
    /// For a closing, middle, `break`, `continue` or `return` line: its opener.
    opener: Vec<usize>,
    /// For an opener: its closing line.
    closer: Vec<usize>,
    /// For `if` and `elseif`: the next `elseif`, `else` or `endif` of the same `if`.
    next_branch: Vec<usize>,
    subs: HashMap<Vec<u8>, usize>,
}

const NONE: usize = usize::MAX;

/// A subroutine call being run (the first is the main program).
struct Frame {
    ret: usize,
    saved: [f64; 30],
    named: BTreeMap<String, f64>,
    /// Counts left of the `repeat` loops being run: (opener, count).
    repeats: Vec<(usize, f64)>,
}

fn keyword(kw: &str) -> Option<Kw> {
    Some(match kw {
        "sub" => Kw::Sub,
        "endsub" => Kw::EndSub,
        "call" => Kw::Call,
        "return" => Kw::Return,
        "if" => Kw::If,
        "elseif" => Kw::ElseIf,
        "else" => Kw::Else,
        "endif" => Kw::EndIf,
        "while" => Kw::While,
        "endwhile" => Kw::EndWhile,
        "do" => Kw::Do,
        "break" => Kw::Break,
        "continue" => Kw::Continue,
        "repeat" => Kw::Repeat,
        "endrepeat" => Kw::EndRepeat,
        _ => return None,
    })
}

/// The O-word of a line that starts with one (after blanks, `/` and an `N` number).
fn o_line(line: &[u8]) -> Option<OLine> {
    let blank = |c: u8| c == b' ' || c == b'\t';
    let mut i = 0;
    while i < line.len() && (blank(line[i]) || line[i] == b'/') {
        i += 1;
    }
    if matches!(line.get(i), Some(b'n' | b'N')) {
        i += 1;
        while i < line.len() && (blank(line[i]) || line[i].is_ascii_digit() || line[i] == b'.') {
            i += 1;
        }
    }
    if !matches!(line.get(i), Some(b'o' | b'O')) {
        return None;
    }
    let o = read_o_word(line, i).ok()?;
    let kw = keyword(&o.keyword)?;
    Some(OLine { col: i, label: o.norm, kw, args: o.end })
}

/// Splits `text` into lines (LF, CR LF or CR) onto `lines`.
fn split_lines<'b>(text: &'b [u8], lines: &mut Vec<&'b [u8]>) {
    let mut i = 0;
    while i < text.len() {
        let r = &text[i..];
        let end = find_eol(r).unwrap_or(r.len());
        lines.push(&r[..end]);
        i += end;
        if i < text.len() {
            if text[i] == b'\r' && text.get(i + 1) == Some(&b'\n') {
                i += 1;
            }
            i += 1;
        }
    }
}

/// Splits `first` and the lines of `texts` and pairs the O-word lines up; the error is
/// at a line index and column.
fn scan<'b>(first: &'b [u8], texts: &[&'b [u8]]) -> Result<Program<'b>, (usize, usize, GcodeErrorKind)> {
    let mut lines = vec![first];
    for t in texts {
        split_lines(t, &mut lines);
    }
    let n = lines.len();
    let mut o: Vec<Option<OLine>> = lines.iter().map(|l| o_line(l)).collect();
    let mut p = Program {
        lines,
        o: Vec::new(),
        opener: vec![NONE; n],
        closer: vec![NONE; n],
        next_branch: vec![NONE; n],
        subs: HashMap::new(),
    };
    // Open blocks: (line, kind, last branch of an `if`).
    let mut stack: Vec<(usize, Kw, usize)> = Vec::new();
    let err = |k: usize, col: usize, m: String| Err((k, col, GcodeErrorKind::ControlFlow(m)));
    for k in 0..n {
        let (col, label, kw) = match &o[k] {
            Some(x) => (x.col, x.label.clone(), x.kw),
            None => continue,
        };
        let shown = String::from_utf8_lossy(&label).into_owned();
        let find = |stack: &[(usize, Kw, usize)], o: &[Option<OLine>], kinds: &[Kw]| {
            stack.iter().rposition(|&(j, kind, _)| {
                kinds.contains(&kind) && o[j].as_ref().is_some_and(|x| x.label == label)
            })
        };
        match kw {
            Kw::Sub => {
                if stack.iter().any(|&(_, kind, _)| kind == Kw::Sub) {
                    return err(k, col, format!("o{shown} sub inside another subroutine"));
                }
                p.subs.insert(label.clone(), k);
                stack.push((k, Kw::Sub, NONE));
            }
            Kw::If | Kw::Do | Kw::Repeat => stack.push((k, kw, k)),
            Kw::While => {
                // The `while` of an open `do` with the same label closes it.
                let top_do = find(&stack, &o, &[Kw::Do, Kw::While, Kw::Repeat, Kw::If, Kw::Sub]);
                if let Some(s) = top_do.filter(|&s| stack[s].1 == Kw::Do) {
                    let (j, _, _) = stack.remove(s);
                    if s != stack.len() {
                        return err(k, col, format!("o{shown} while closes a 'do' around an open block"));
                    }
                    if let Some(x) = o[k].as_mut() {
                        x.kw = Kw::DoWhile;
                    }
                    p.opener[k] = j;
                    p.closer[j] = k;
                } else {
                    stack.push((k, Kw::While, k));
                }
            }
            Kw::EndSub | Kw::EndIf | Kw::EndWhile | Kw::EndRepeat => {
                let want = match kw {
                    Kw::EndSub => Kw::Sub,
                    Kw::EndIf => Kw::If,
                    Kw::EndWhile => Kw::While,
                    _ => Kw::Repeat,
                };
                match stack.last() {
                    Some(&(j, kind, last))
                        if kind == want && o[j].as_ref().is_some_and(|x| x.label == label) =>
                    {
                        stack.pop();
                        p.opener[k] = j;
                        p.closer[j] = k;
                        if kind == Kw::If {
                            p.next_branch[last] = k;
                        }
                    }
                    _ => return err(k, col, format!("o{shown} {kw:?} without its opening line")),
                }
            }
            Kw::ElseIf | Kw::Else => match stack.last_mut() {
                Some((j, Kw::If, last)) if o[*j].as_ref().is_some_and(|x| x.label == label) => {
                    if o[*last].as_ref().is_some_and(|x| x.kw == Kw::Else) {
                        return err(k, col, format!("o{shown}: a branch after 'else'"));
                    }
                    p.next_branch[*last] = k;
                    *last = k;
                    p.opener[k] = *j;
                }
                _ => return err(k, col, format!("o{shown} {kw:?} without its 'if'")),
            },
            Kw::Break | Kw::Continue => match find(&stack, &o, &[Kw::While, Kw::Do, Kw::Repeat]) {
                Some(s) => p.opener[k] = stack[s].0,
                None => return err(k, col, format!("o{shown} {kw:?} outside a loop o{shown}")),
            },
            Kw::Return => match stack.iter().find(|&&(_, kind, _)| kind == Kw::Sub) {
                Some(&(j, _, _)) => p.opener[k] = j,
                None => return err(k, col, format!("o{shown} return outside a subroutine")),
            },
            Kw::Call | Kw::DoWhile => {}
        }
    }
    if let Some(&(j, kind, _)) = stack.last() {
        let ol =
            o[j].as_ref().map_or((0, String::new()), |x| (x.col, String::from_utf8_lossy(&x.label).into()));
        return err(j, ol.0, format!("o{} {kind:?} not closed", ol.1));
    }
    p.o = o;
    Ok(p)
}

/// The text of the files, in [`ParseOptions::subroutine_path`](super::ParseOptions::subroutine_path),
/// of the subroutines the program calls by name (`o<name> call`) without defining them,
/// and of those these call in turn (at most 100 files).
fn load_subroutines(it: &Interp<'_>, first: &[u8], rest: &[u8]) -> Vec<Vec<u8>> {
    let mut loaded: Vec<Vec<u8>> = Vec::new();
    if it.opts.subroutine_path.is_empty() {
        return loaded;
    }
    let mut tried: Vec<Vec<u8>> = Vec::new();
    while loaded.len() < 100 {
        let mut texts = vec![rest];
        texts.extend(loaded.iter().map(Vec::as_slice));
        let Ok(p) = scan(first, &texts) else { break };
        let missing = p.o.iter().flatten().find(|ol| {
            ol.kw == Kw::Call
                && ol.label.first() == Some(&b'<')
                && !p.subs.contains_key(&ol.label)
                && !tried.contains(&ol.label)
        });
        let Some(label) = missing.map(|ol| ol.label.clone()) else { break };
        let name = String::from_utf8_lossy(&label[1..label.len() - 1]).into_owned();
        tried.push(label);
        let found =
            it.opts.subroutine_path.iter().find_map(|d| std::fs::read(d.join(format!("{name}.ngc"))).ok());
        if let Some(text) = found {
            loaded.push(text);
        }
    }
    loaded
}

/// Reads the expressions `[..]` after an O-word keyword (none when the line ends).
fn exprs(it: &mut Interp<'_>, line: &[u8], from: usize) -> Result<Vec<f64>, (usize, GcodeErrorKind)> {
    // An O-word line is not counted in the lines run: always read the state afresh.
    it.synced_line = u64::MAX;
    it.sync_params();
    let mut c = Cursor { b: line, i: from };
    let mut out = Vec::new();
    loop {
        c.skip_ws();
        match c.peek() {
            None | Some(b'(' | b';') => return Ok(out),
            _ => out.push(c.real_value(&mut it.params, 0)?),
        }
    }
}

/// Runs `first` (the line that asked for control flow, already counted as line
/// `it.lineno`) and the lines of `rest` with O-word control flow.
pub(super) fn run<S: MotionSink>(
    it: &mut Interp<'_>,
    first: &[u8],
    rest: &[u8],
    sink: &mut S,
) -> Result<(), ParseError<S::Error>> {
    it.flow_request = false;
    it.done = false;
    it.in_flow = true;
    let base = it.lineno;
    let lines_before = it.summary.lines - 1;
    let loaded = load_subroutines(it, first, rest);
    let mut texts = vec![rest];
    texts.extend(loaded.iter().map(Vec::as_slice));
    let p = match scan(first, &texts) {
        Ok(p) => p,
        Err((k, col, kind)) => {
            it.lineno = base + k as u64;
            it.summary.lines = lines_before + k as u64 + 1;
            it.record(col, kind)?;
            it.done = true;
            return Ok(());
        }
    };
    // The program's own lines (subroutine files come after them).
    let mut own = Vec::new();
    split_lines(rest, &mut own);
    let n = 1 + own.len();
    let r = execute(it, &p, base, sink);
    it.summary.lines = lines_before + n as u64;
    r
}

/// The program counter loop of [`run`].
fn execute<S: MotionSink>(
    it: &mut Interp<'_>,
    p: &Program<'_>,
    base: u64,
    sink: &mut S,
) -> Result<(), ParseError<S::Error>> {
    let mut frames = vec![Frame { ret: NONE, saved: [0.0; 30], named: BTreeMap::new(), repeats: Vec::new() }];
    let mut pc = 0;
    let mut steps = 0u64;
    while pc < p.lines.len() && !it.done {
        steps += 1;
        let line = p.lines[pc];
        if steps > it.opts.max_steps {
            it.lineno = base + pc as u64;
            let col = p.o[pc].as_ref().map_or(0, |o| o.col);
            it.record(col, GcodeErrorKind::StepLimit(it.opts.max_steps))?;
            it.done = true;
            break;
        }
        let Some(ol) = &p.o[pc] else {
            it.lineno = base + pc as u64 - 1;
            it.line(line, sink)?;
            if it.lathe.is_some() {
                lathe_cycle(it, p, base, pc, sink)?;
            }
            pc += 1;
            continue;
        };
        it.lineno = base + pc as u64;
        match step(it, p, pc, ol, &mut frames) {
            Ok(next) => pc = next,
            Err((col, kind)) => {
                // As in `rs274`, a control-flow error ends the program (going on would run
                // a body whose condition failed, or loop on the error).
                it.record(col, kind)?;
                it.done = true;
            }
        }
    }
    Ok(())
}

/// Runs the O-word line `pc`; returns the next line to run.
fn step(
    it: &mut Interp<'_>,
    p: &Program<'_>,
    pc: usize,
    ol: &OLine,
    frames: &mut Vec<Frame>,
) -> Result<usize, (usize, GcodeErrorKind)> {
    let line = p.lines[pc];
    let cond = |it: &mut Interp<'_>| -> Result<bool, (usize, GcodeErrorKind)> {
        let v = exprs(it, line, ol.args)?;
        match v[..] {
            [c] => Ok(c != 0.0),
            _ => Err((ol.col, GcodeErrorKind::ControlFlow(format!("{:?} needs one [condition]", ol.kw)))),
        }
    };
    Ok(match ol.kw {
        Kw::Sub => p.closer[pc] + 1,
        Kw::Call => return call(it, p, pc, ol, frames),
        Kw::EndSub | Kw::Return => {
            let v = exprs(it, line, ol.args)?;
            it.params.set_named(b"_value_returned", if v.is_empty() { 0.0 } else { 1.0 });
            if let Some(&x) = v.first() {
                it.params.set_named(b"_value", x);
            }
            if frames.len() == 1 {
                return Err((ol.col, GcodeErrorKind::ControlFlow("return outside a call".into())));
            }
            let Some(f) = frames.pop() else { return Ok(pc + 1) };
            it.params.numbered[1..=30].copy_from_slice(&f.saved);
            let globals: Vec<(String, f64)> = it
                .params
                .named
                .iter()
                .filter(|(k, _)| k.starts_with('_'))
                .map(|(k, &v)| (k.clone(), v))
                .collect();
            it.params.named = f.named;
            it.params.named.extend(globals);
            f.ret
        }
        Kw::ElseIf | Kw::Else => p.closer[p.opener[pc]] + 1,
        Kw::If => {
            let mut j = pc;
            loop {
                let c = if j == pc { cond(it)? } else { branch_cond(it, p, j)? };
                if c {
                    break j + 1;
                }
                j = p.next_branch[j];
                match p.o[j].as_ref().map(|x| x.kw) {
                    Some(Kw::ElseIf) => {}
                    _ => break j + 1,
                }
            }
        }
        Kw::EndIf | Kw::Do => pc + 1,
        Kw::While => {
            if cond(it)? {
                pc + 1
            } else {
                p.closer[pc] + 1
            }
        }
        Kw::EndWhile => p.opener[pc],
        Kw::DoWhile => {
            if cond(it)? {
                p.opener[pc] + 1
            } else {
                pc + 1
            }
        }
        Kw::Repeat => {
            let v = exprs(it, line, ol.args)?;
            let [count] = v[..] else {
                return Err((ol.col, GcodeErrorKind::ControlFlow("repeat needs one [count]".into())));
            };
            let Some(top) = frames.last_mut() else { return Ok(pc + 1) };
            top.repeats.retain(|&(j, _)| j != pc);
            if count.round() >= 1.0 {
                top.repeats.push((pc, count.round()));
                pc + 1
            } else {
                p.closer[pc] + 1
            }
        }
        Kw::EndRepeat => end_repeat(frames, p.opener[pc], pc),
        Kw::Break => {
            let opener = p.opener[pc];
            if let Some(f) = frames.last_mut() {
                f.repeats.retain(|&(j, _)| j != opener);
            }
            p.closer[opener] + 1
        }
        Kw::Continue => {
            let opener = p.opener[pc];
            match p.o[opener].as_ref().map(|x| x.kw) {
                Some(Kw::While) => opener,
                Some(Kw::Repeat) => end_repeat(frames, opener, p.closer[opener]),
                _ => p.closer[opener],
            }
        }
    })
}

/// The condition of the `elseif` at line `j`.
fn branch_cond(it: &mut Interp<'_>, p: &Program<'_>, j: usize) -> Result<bool, (usize, GcodeErrorKind)> {
    let Some(ol) = p.o[j].as_ref() else { return Ok(false) };
    let v = exprs(it, p.lines[j], ol.args)?;
    match v[..] {
        [c] => Ok(c != 0.0),
        _ => Err((ol.col, GcodeErrorKind::ControlFlow("elseif needs one [condition]".into()))),
    }
}

/// One more round of the `repeat` at `opener` whose `endrepeat` is `end`, or past it.
fn end_repeat(frames: &mut [Frame], opener: usize, end: usize) -> usize {
    let Some(top) = frames.last_mut() else { return end + 1 };
    match top.repeats.iter_mut().find(|(j, _)| *j == opener) {
        Some((_, left)) if *left > 1.0 => {
            *left -= 1.0;
            opener + 1
        }
        _ => {
            top.repeats.retain(|&(j, _)| j != opener);
            end + 1
        }
    }
}

/// `o<label> call [args]` at line `pc`.
fn call(
    it: &mut Interp<'_>,
    p: &Program<'_>,
    pc: usize,
    ol: &OLine,
    frames: &mut Vec<Frame>,
) -> Result<usize, (usize, GcodeErrorKind)> {
    let shown = String::from_utf8_lossy(&ol.label).into_owned();
    let Some(&sub) = p.subs.get(&ol.label) else {
        return Err((ol.col, GcodeErrorKind::ControlFlow(format!("call of undefined subroutine o{shown}"))));
    };
    if frames.len() > it.opts.max_call_depth {
        return Err((
            ol.col,
            GcodeErrorKind::ControlFlow(format!(
                "o{shown} call: more than {} nested calls",
                it.opts.max_call_depth
            )),
        ));
    }
    let args = exprs(it, p.lines[pc], ol.args)?;
    if args.len() > 30 {
        return Err((
            ol.col,
            GcodeErrorKind::ControlFlow(format!("o{shown} call with more than 30 arguments")),
        ));
    }
    enter(it, frames, pc + 1, &args);
    Ok(sub + 1)
}

/// Enters a subroutine with arguments `args`, to return to line `ret`: the caller's
/// `#1`-`#30` and local named parameters are kept aside.
fn enter(it: &mut Interp<'_>, frames: &mut Vec<Frame>, ret: usize, args: &[f64]) {
    let mut saved = [0.0; 30];
    saved.copy_from_slice(&it.params.numbered[1..=30]);
    let named = it.params.named.clone();
    it.params.named.retain(|k, _| k.starts_with('_'));
    for (k, slot) in it.params.numbered[1..=30].iter_mut().enumerate() {
        *slot = args.get(k).copied().unwrap_or(0.0);
    }
    frames.push(Frame { ret, saved, named, repeats: Vec::new() });
}

/// Runs the lathe cycle that line `pc` asked for ([`Interp::lathe`]): its profile
/// subroutine `o<Q>` is called, its lines read as the profile (O-word lines run as
/// usual), then the cycle runs. An error of the profile is at its line; one of the
/// cycle at the line that ended the subroutine, as in `rs274`.
fn lathe_cycle<S: MotionSink>(
    it: &mut Interp<'_>,
    p: &Program<'_>,
    base: u64,
    pc: usize,
    sink: &mut S,
) -> Result<(), ParseError<S::Error>> {
    let Some(req) = it.lathe.take() else { return Ok(()) };
    let line_of = |k: usize| base + k as u64;
    let Some(&sub) = p.subs.get(req.q.to_string().as_bytes()) else {
        it.lineno = line_of(pc);
        let what = format!("G7x: Q routine o{} not found", req.q);
        return it.record(0, GcodeErrorKind::ControlFlow(what));
    };
    let mut prof = it.profile_start(&req);
    let mut frames = vec![Frame { ret: NONE, saved: [0.0; 30], named: BTreeMap::new(), repeats: Vec::new() }];
    enter(it, &mut frames, NONE, &[]);
    let mut k = sub + 1;
    let mut steps = 0u64;
    while frames.len() > 1 {
        steps += 1;
        it.lineno = line_of(k);
        let r = match (&p.o.get(k), steps > it.opts.max_steps) {
            (None, _) => Err((0, GcodeErrorKind::ControlFlow("profile subroutine not closed".into()))),
            (_, true) => Err((0, GcodeErrorKind::StepLimit(it.opts.max_steps))),
            (Some(Some(ol)), _) => step(it, p, k, ol, &mut frames).map(|next| {
                if frames.len() > 1 {
                    k = next;
                }
            }),
            (Some(None), _) => it.profile_line(p.lines[k], &mut prof).map(|()| k += 1),
        };
        if let Err((col, kind)) = r {
            // Back in the caller's parameters.
            if let Some(f) = frames.get(1) {
                it.params.numbered[1..=30].copy_from_slice(&f.saved);
                it.params.named = f.named.clone();
            }
            // As in `execute`, a control-flow error or the step limit ends the program.
            it.done = matches!(kind, GcodeErrorKind::ControlFlow(_) | GcodeErrorKind::StepLimit(_));
            return it.record(col, kind);
        }
    }
    let end_line = it.lineno;
    it.lineno = line_of(pc);
    match it.lathe_run(&req, prof, sink) {
        Ok(()) => {}
        Err(Fail::Sink(e)) => return Err(ParseError::Sink(e)),
        Err(Fail::Line(col, kind)) => {
            it.lineno = end_line;
            return it.record(col, kind);
        }
    }
    match it.end_of_block(req.m_stop, sink) {
        Ok(()) => Ok(()),
        Err(Fail::Sink(e)) => Err(ParseError::Sink(e)),
        Err(Fail::Line(col, kind)) => it.record(col, kind),
    }
}
