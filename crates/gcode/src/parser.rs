//! The streaming G-code parser: bytes in, [`Motion`](crate::Motion)s out into any [`MotionSink`].
//!
//! One line at a time, zero-copy over the line's bytes, no allocation per line (only
//! error messages and O-word labels allocate). Lines are split eight bytes at a time;
//! a word followed by a plain number is read without the expression machinery (G and M
//! codes as integers); a block of only `G0`/`G1`, `X Y Z E F N` in G0/G1 mode takes a
//! short path with the general interpreter's semantics (a unit test runs both on every
//! sample file and on random blocks). The semantics follow LinuxCNC's RS274NGC
//! interpreter (`rs274`), which the integration tests use as the reference, with FDM
//! (Marlin / RepRap) extensions.
//!
//! # Dialects and leniency
//! [`ParseDialect::Cnc`] is strict LinuxCNC: what `rs274` rejects is an error (a `G1` without
//! feed rate, an arc without centre, `G53` without `G0`/`G1`, unknown codes, ...).
//! [`ParseDialect::Auto`] (the default) accepts the same programs and also the usual
//! dialect drift of real files: those cases become *warnings* in
//! [`ParseSummary::warnings`] with a documented fallback (feed 0, `G70`/`G71` as inch/mm,
//! unknown codes skipped with their line). An arc without centre or radius is an error, as
//! in `rs274`, until the program shows FDM evidence (then a straight move and a warning);
//! so is an `E` word glued to a number (`X1e999`: exponent notation) before any.
//! Auto switches to FDM semantics (`G4 P` in milliseconds, `G10`/`G11` firmware retract,
//! `G28` homing, `G91` making `E` relative) once the program shows FDM evidence (`M82`,
//! `M83`, `M104`, `M109`, `M140`, `M190` or an `E` word). [`ParseDialect::Fdm`] has those from
//! the start.
//!
//! # Documented choices
//! - Numbers are decimals without exponent (`1E5` is `1` then an `E` word); blanks inside
//!   words are skipped as LinuxCNC does (`X - 5`, `G 1`).
//! - `N` numbers are read and ignored; fractional ones are accepted, as LinuxCNC does.
//! - Block delete `/` skips the line only when [`ParseOptions::block_delete`] is set
//!   (`rs274`'s default is off: the line runs).
//! - Firmware retract `G10`/`G11` is reported as a zero-length [`Motion::Linear`](crate::Motion::Linear) with
//!   `extrude = -firmware_retract_mm` / `+firmware_retract_mm` (`M207 S` sets the length).
//! - Parameters: numbered `#1`..`#5601` and named `#<name>` (case and blanks ignored);
//!   all assignments of a line take effect after the line's reads. Coordinate-system
//!   parameters (`#5221`.., `#5211`.., `#5161`..) are stored in mm.
//! - Cutter radius compensation runs as in LinuxCNC: `G41.1`/`G42.1` with the diameter
//!   `D` (and under `G18` a lathe tool orientation `L`), `G41`/`G42` with the diameter of
//!   tool `D` in [`ParseOptions::tool_diameters`] (0 when not listed: the programmed path);
//!   entry move, arcs about convex corners, concave corners cut back to where the offset
//!   paths meet, one move held back until its corner is known (`G40`, `M0`-`M2`, `M30`
//!   send it; a program that ends without them loses it, as `rs274` does), and LinuxCNC's
//!   errors ([`GcodeErrorKind::CutterComp`](crate::GcodeErrorKind::CutterComp)): gouging
//!   corners, entry moves within the tool radius, `G28`, `G92`, `G53`, canned cycles,
//!   plane, tool offset or coordinate system changes while on. `G43` reads no tool table (lengths 0);
//!   `G43.1 Z` sets a tool length offset, which shifts the program's Z as in LinuxCNC.
//! - Coordinate systems follow LinuxCNC: machine = rot(work + `G92` offset) + `G5x`
//!   offset (+ tool length on Z), where rot turns X and Y by the system's `G10 L2 R`
//!   angle (parameter `#5230` for `G54`, 20 apart for the others). Motions are reported
//!   in work (program) coordinates, as `rs274` prints them; `G53`, `G28`/`G30`, `G92`
//!   and `G10 L20` (no R, as in `rs274`) go through the rotation.
//! - Beyond `G0`-`G3` and drilling: `G5`/`G5.1` splines become straight feeds within
//!   [`ParseOptions::spline_tolerance_mm`]; `G33` is a feed to its target and `G33.1`
//!   (rigid tapping) a feed in and one back out to the start; `G38.2`-`G38.5` probe
//!   moves are feeds to the target (the probe never trips, as in `rs274`'s simulation),
//!   after which the position backs off 0.254 mm and `#5061`-`#5063` hold the target;
//!   `G76` threading is expanded into its passes as `rs274` makes them; under `G93` a
//!   feed move's F is moves per minute (the reported feed is F times the length) and
//!   is required on every feed block. `G95` is not supported.
//! - LinuxCNC's lathe cycles `G70` (finishing), `G71`/`G71.1`/`G71.2` and
//!   `G72`/`G72.1`/`G72.2` (roughing along Z and X) run with their profile subroutine
//!   `o<Q>` as the `rs274` of LinuxCNC 2.9.0~pre1 runs them (`G70` under cutter
//!   compensation too); an expansion it would loop on for ever, or one of more than a
//!   million moves, is an error ([`GcodeErrorKind::CannedCycle`](crate::GcodeErrorKind::CannedCycle)).
//!   Lenient `G70`/`G71` without `Q` stay old Fanuc inch/mm.
//! - Rotary axis words are accepted and ignored, unless
//!   [`ParseOptions::rotary`] names a kinematics: then A/B/C words become
//!   [`Motion::Setup`](crate::Motion::Setup) (see [`crate::rotary_frame`]). U, V and W
//!   words are ignored too, and an error under [`ParseDialect::Cnc`] (`rs274` has no
//!   such axes configured).
//! - A Fanuc program number (`O1234` alone on a line, optionally with a comment) is a
//!   label: nothing runs, [`ParseSummary::program_number`] keeps the first one. Under
//!   [`ParseDialect::Cnc`] it is an error, as in `rs274`.
//! - `G4 X<seconds>` without `P` is Fanuc's dwell (a warning, once; an error under
//!   [`ParseDialect::Cnc`]); the X word is the time, not a move.
//! - Polar coordinates (`@` radius, `^` angle in degrees) give X and Y about the XY origin
//!   of the work coordinates, as in LinuxCNC; under `G91` they add to the current point's
//!   radius and angle, and each `L` repeat of a canned cycle in the XY plane adds them again
//!   (a bolt circle: `G91 G81 R.1 Z-.5 ^60 L6`).
//! - LinuxCNC O-word control flow runs: `sub`/`endsub`/`call` (arguments in `#1`..`#30`,
//!   local to the call with the named parameters not starting with `_`), `return [v]`
//!   and `endsub [v]` (into `#<_value>`, `#<_value_returned>`), `if`/`elseif`/`else`/`endif`,
//!   `while`/`endwhile`, `do`/`while`, `repeat`/`endrepeat`, `break`, `continue`, with
//!   numbered (`o100`, leading zeros ignored), named (`o<name>`) and computed (`o[..]`,
//!   matched as written) labels. From the first O-word line on, the rest of the program is
//!   read whole and run with a program counter (plain programs keep the streaming path);
//!   an unmatched O-word (before anything of the rest runs), a failed condition or call
//!   (where it is reached) stop the program with a
//!   [`GcodeErrorKind::ControlFlow`](crate::GcodeErrorKind::ControlFlow) error at its line, as do
//!   more than [`ParseOptions::max_steps`] executed blocks
//!   ([`GcodeErrorKind::StepLimit`](crate::GcodeErrorKind::StepLimit)). Calling a subroutine
//!   the program does not define is an error at the call (subroutines in other files are
//!   not searched for).

use std::io::BufRead;
use std::path::{Path, PathBuf};

use crate::error::ParseError;
use crate::motion::MotionSink;
use interp::{Interp, parse_bytes};
use words::find_eol;

mod comp;
mod cycle;
mod execute;
mod flow;
mod interp;
mod lathe_cycle;
mod lathe_geom;
mod lathe_path;
mod lex;
mod mcodes;
mod moves;
mod offsets;
mod options;
mod pipeline;
mod special;
#[cfg(test)]
mod testing;
mod threading;
mod words;

pub use options::{ParseDialect, ParseOptions, ParseSummary};

/// Lines longer than this are reported as an error instead of being buffered whole.
const MAX_LINE: usize = 16 << 20;

/// Parses G-code text into `sink`.
///
/// Inputs of 1 MiB and more, on a machine with two or more cores, are parsed in two
/// stages: a scoped second thread splits and lexes lines while this thread interprets
/// them and calls `sink` (which therefore need not be `Send`). Summary, motions, errors
/// and their columns are the same as in one stage; only the speed differs.
///
/// ```
/// use s2g_gcode::{parse_str, Motion, MotionRecorder, ParseOptions};
/// let mut rec = MotionRecorder::default();
/// let summary = parse_str("G21 G90\nG0 X1 Y2\nG1 Z-1 F100\n", &ParseOptions::default(), &mut rec).unwrap();
/// assert!(summary.errors.is_empty());
/// assert_eq!(rec.motions.len(), 2);
/// assert_eq!(rec.motions[1].1.end_point().unwrap().z, -1.0);
/// ```
pub fn parse_str<S: MotionSink>(
    text: &str,
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let b = text.as_bytes();
    if pipeline::worthwhile(b.len()) {
        return pipeline::parse_two_stage(b, opts, sink, pipeline::CHUNK_BYTES);
    }
    parse_bytes(b, opts, sink, true)
}

/// [`parse_str`] always in two stages (a lexing thread beside the interpreter), whatever
/// the input's size, with chunks of `chunk_bytes` (at least 1) instead of 128 KiB, so that
/// small inputs cross chunk boundaries too. For the fuzz target, which checks it against
/// [`parse_str`]; not part of the stable API.
#[doc(hidden)]
pub fn parse_str_two_stage<S: MotionSink>(
    text: &str,
    opts: &ParseOptions,
    sink: &mut S,
    chunk_bytes: usize,
) -> Result<ParseSummary, ParseError<S::Error>> {
    pipeline::parse_two_stage(text.as_bytes(), opts, sink, chunk_bytes)
}

/// Parses G-code from a reader, streaming: one line buffer is reused, so memory stays
/// bounded by the longest line whatever the input size.
pub fn parse_reader<R: BufRead, S: MotionSink>(
    reader: R,
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    parse_reader_path(reader, opts, sink, None)
}

/// Parses a G-code file; errors carry its path.
pub fn parse_file<S: MotionSink>(
    path: impl AsRef<Path>,
    opts: &ParseOptions,
    sink: &mut S,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let path = path.as_ref();
    let f = std::fs::File::open(path)
        .map_err(|source| ParseError::Io { path: path.display().to_string(), source })?;
    parse_reader_path(std::io::BufReader::with_capacity(1 << 16, f), opts, sink, Some(path.to_path_buf()))
}

fn parse_reader_path<R: BufRead, S: MotionSink>(
    mut reader: R,
    opts: &ParseOptions,
    sink: &mut S,
    path: Option<PathBuf>,
) -> Result<ParseSummary, ParseError<S::Error>> {
    let io_path = path.as_ref().map_or_else(|| "<input>".to_string(), |p| p.display().to_string());
    let mut it = Interp::new(opts, path);
    let mut line: Vec<u8> = Vec::new();
    let mut skip_lf = false;
    let mut too_long = false;
    let mut bytes = 0u64;
    let mut pending = false;
    loop {
        let buf = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(source) => return Err(ParseError::Io { path: io_path, source }),
        };
        if buf.is_empty() {
            if pending {
                it.line_checked(&line, too_long, sink)?;
                if it.flow_request {
                    flow::run(&mut it, &line, &[], sink)?;
                }
            }
            break;
        }
        let mut start = 0;
        if skip_lf {
            skip_lf = false;
            if buf[0] == b'\n' {
                start = 1;
            }
        }
        let consumed = match find_eol(&buf[start..]) {
            Some(k) => {
                let end = start + k;
                if line.is_empty() && !too_long {
                    it.line(&buf[start..end], sink)?;
                    if it.done && it.flow_request {
                        line.extend_from_slice(&buf[start..end]);
                    }
                } else {
                    if !too_long {
                        line.extend_from_slice(&buf[start..end]);
                    }
                    it.line_checked(&line, too_long, sink)?;
                    if !(it.done && it.flow_request) {
                        line.clear();
                    }
                    too_long = false;
                }
                pending = false;
                skip_lf = buf[end] == b'\r';
                end + 1
            }
            None => {
                if start == buf.len() {
                    reader.consume(start);
                    bytes += start as u64;
                    continue;
                }
                if !too_long {
                    line.extend_from_slice(&buf[start..]);
                    if line.len() > MAX_LINE {
                        too_long = true;
                        line.clear();
                    }
                }
                pending = true;
                buf.len()
            }
        };
        bytes += consumed as u64;
        reader.consume(consumed);
        if it.done && it.flow_request {
            // O-word control flow: the rest of the program is read whole and run from here.
            let mut rest = Vec::new();
            loop {
                match reader.read_to_end(&mut rest) {
                    Ok(_) => break,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(source) => return Err(ParseError::Io { path: io_path, source }),
                }
            }
            bytes += rest.len() as u64;
            let from = usize::from(skip_lf && rest.first() == Some(&b'\n'));
            flow::run(&mut it, &line, &rest[from..], sink)?;
            break;
        }
        if it.done {
            break;
        }
    }
    it.summary.bytes = bytes;
    it.finish(sink)
}

#[cfg(test)]
mod tests {
    use super::interp::parse_bytes;
    use super::testing::{assert_same_parse, dialects, sample_files, splitmix};
    use super::words::plain_code;
    use super::*;
    use crate::expr::Cursor;

    /// The fast path against the general interpreter.
    fn both(text: &[u8], opts: &ParseOptions, what: &str) {
        assert_same_parse(text, opts, what, |t, o, rec| {
            parse_bytes(t, o, rec, false).expect("infallible sink")
        });
    }

    #[test]
    fn plain_codes_agree_with_the_number_reader() {
        let mut next = crate::xorshift(0x9E37_u64);
        let alphabet = b"0123456789.  X-";
        let mut taken = 0;
        for case in 0..100_000 {
            let len = 1 + (next() % 8) as usize;
            let mut t: Vec<u8> =
                (0..len).map(|_| alphabet[(next() % alphabet.len() as u64) as usize]).collect();
            if case % 2 == 0 {
                t[0] = b'0' + (next() % 10) as u8;
            }
            for g in [true, false] {
                let Some((code, end)) = plain_code(&t, 0, g) else { continue };
                taken += 1;
                let mut c = Cursor { b: &t, i: 0 };
                let v = c.number().unwrap_or_else(|e| panic!("{:?}: {e:?}", String::from_utf8_lossy(&t)));
                let want = if g { v * 10.0 } else { v };
                let shown = String::from_utf8_lossy(&t);
                assert!((want - code as f64).abs() < 1e-6, "{shown:?} (g {g}): {code} vs {v}");
                assert_eq!(c.i, end, "{shown:?} (g {g}): end");
            }
        }
        assert!(taken > 20_000, "only {taken} plain codes");
    }

    #[test]
    fn fast_path_agrees_with_the_general_interpreter_on_samples() {
        for (name, text) in sample_files() {
            for opts in dialects() {
                both(&text, &opts, &name);
            }
        }
    }

    #[test]
    fn fast_path_agrees_with_the_general_interpreter_on_random_blocks() {
        // Random blocks of the words the fast path takes and of their neighbours.
        let mut next = splitmix(0x5EED);
        let words = [
            "G0", "G1", "G2", "G3", "G20", "G21", "G90", "G91", "G80", "G53", "G4", "G92", "G10", "G11",
            "M3", "M82", "M83", "X", "Y", "Z", "E", "F", "N", "S", "T", "R", "I", "J", "P", "A", "(c)", ";t",
        ];
        for case in 0..400 {
            let mut text = String::new();
            for _ in 0..(next() % 30) {
                for _ in 0..(1 + next() % 4) {
                    let w = words[(next() % words.len() as u64) as usize];
                    text.push_str(w);
                    if w.len() == 1 {
                        let v = (next() % 4000) as f64 / 8.0 - 100.0;
                        text.push_str(&format!("{v}"));
                    }
                    text.push(' ');
                }
                text.push('\n');
            }
            for opts in dialects() {
                both(text.as_bytes(), &opts, &format!("random case {case}"));
            }
        }
    }
}
