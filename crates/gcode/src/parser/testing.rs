//! Test helpers shared by the parser's unit tests (one stage, two stages, fast path).

use super::interp::parse_bytes;
use super::options::{ParseDialect, ParseOptions, ParseSummary};
use crate::motion::MotionRecorder;

/// Asserts that `other` parses `text` exactly as the one-stage fast path does.
pub(crate) fn assert_same_parse(
    text: &[u8],
    opts: &ParseOptions,
    what: &str,
    other: impl Fn(&[u8], &ParseOptions, &mut MotionRecorder) -> ParseSummary,
) {
    let mut a = MotionRecorder::default();
    let mut b = MotionRecorder::default();
    let sa = parse_bytes(text, opts, &mut a, true).expect("infallible sink");
    let sb = other(text, opts, &mut b);
    assert_eq!(sa, sb, "{what}: summaries differ\n{}", String::from_utf8_lossy(text));
    assert_eq!(a.motions, b.motions, "{what}: motions differ\n{}", String::from_utf8_lossy(text));
}

pub(crate) fn dialects() -> [ParseOptions; 3] {
    [ParseDialect::Auto, ParseDialect::Cnc, ParseDialect::Fdm]
        .map(|dialect| ParseOptions { dialect, ..ParseOptions::default() })
}

/// Every program of tests/data (CNC programs, FDM G-code, odd files): name and bytes.
pub(crate) fn sample_files() -> Vec<(String, Vec<u8>)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let mut out = Vec::new();
    for dir in ["cnc/programs", "fdm/gcode", "cnc/odd"] {
        let entries = std::fs::read_dir(root.join(dir)).unwrap_or_else(|e| panic!("{dir}: {e}"));
        for e in entries {
            let path = e.expect("dir entry").path();
            out.push((path.display().to_string(), std::fs::read(&path).expect("read")));
        }
    }
    assert!(out.len() >= 8, "only {} sample files", out.len());
    out
}

/// A SplitMix64 stream from `seed`.
pub(crate) fn splitmix(mut state: u64) -> impl FnMut() -> u64 {
    move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}
