//! Fuzz target: the G-code parser must never panic, whatever the bytes.
//!
//! Seeds: `fuzz/seeds/parse` (O-word subroutines, loops, if/else, do/while, nested
//! calls, polar coordinates, `G10 L2 R` rotation, tapping, probing, splines, inverse
//! time, cutter radius compensation). Run, from the repository root, one niced job:
//! `cargo +nightly fuzz run -O -s none parse fuzz/corpus/parse fuzz/seeds/parse --
//! -runs=10000000 -max_len=256` (no sanitizer: the code is safe Rust, and without one
//! the run is several times faster).
#![no_main]

use libfuzzer_sys::fuzz_target;
use s2g_gcode::{
    Motion, MotionSink, ParseDialect, ParseOptions, RotaryAxes, parse_reader, parse_str, parse_str_two_stage,
};

/// Counts motions and checks that move end points are finite.
struct Count(u64);

impl MotionSink for Count {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        if let Some(p) = m.end_point() {
            assert!(p.iter().all(|v| v.is_finite()), "non-finite end point {m:?}");
        }
        if let Motion::Setup { frame, .. } = m {
            let q = frame.rotation.coords.iter().chain(frame.translation.vector.iter());
            assert!(q.into_iter().all(|v| v.is_finite()), "non-finite setup {m:?}");
        }
        self.0 += 1;
        Ok(())
    }
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let dialect = match data.first().map(|b| b % 3) {
        Some(0) => ParseDialect::Cnc,
        Some(1) => ParseDialect::Fdm,
        _ => ParseDialect::Auto,
    };
    let rotary = match data.get(1).map(|b| b % 3) {
        Some(0) => Some(RotaryAxes::AC),
        Some(1) => Some(RotaryAxes::BC),
        _ => None,
    };
    // O-word loops may run long: a small step limit keeps each execution quick.
    let opts = ParseOptions {
        dialect,
        rotary,
        stop_at_program_end: false,
        max_steps: 500,
        // `G41 D1`..`D9` compensate with a real radius, as `G41.1` does.
        tool_diameters: (1..10).map(|t| (t, t as f64 * 0.5)).collect(),
        ..ParseOptions::default()
    };
    let mut a = Count(0);
    let sa = parse_str(&text, &opts, &mut a).expect("infallible sink");
    // The streaming reader over the raw bytes must see the same number of lines.
    let mut b = Count(0);
    let sb =
        parse_reader(std::io::BufReader::with_capacity(16, data), &opts, &mut b).expect("infallible sink");
    if text.as_bytes() == data {
        assert_eq!(sa.lines, sb.lines);
        assert_eq!(a.0, b.0);
    }
    // The two-stage parser (taken for inputs of 1 MiB and more) must agree exactly, with
    // chunks small enough (set by the third byte) that the input spans many of them. It
    // hands every chunk to a second thread, which costs a context switch each: checked
    // for one input in eight (third byte under 32: chunks of 1 to 32 bytes), so that a
    // run on a busy machine still reaches 10^7 executions.
    let Some(&b2) = data.get(2).filter(|&&b| b < 32) else { return };
    let chunk = 1 + b2 as usize;
    let (mut one, mut two) = (Fold::default(), Fold::default());
    let s1 = parse_str(&text, &opts, &mut one).expect("infallible sink");
    let s2 = parse_str_two_stage(&text, &opts, &mut two, chunk).expect("infallible sink");
    assert_eq!(s1, s2);
    assert_eq!(one, two);
});

/// Folds every motion (kind, source line, end point) into a count and a hash: the two
/// parsers' streams compared in bounded memory (a loop of canned cycles with large `L`
/// emits tens of millions of motions, which a recorder would hold: out of memory).
#[derive(Debug, Default, PartialEq)]
struct Fold {
    n: u64,
    h: u64,
    line: u64,
}

impl MotionSink for Fold {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        (self.h, self.line, std::mem::discriminant(m)).hash(&mut hasher);
        if let Some(p) = m.end_point() {
            p.iter().for_each(|v| v.to_bits().hash(&mut hasher));
        }
        self.h = hasher.finish();
        self.n += 1;
        Ok(())
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.line = line;
        Ok(())
    }
}
