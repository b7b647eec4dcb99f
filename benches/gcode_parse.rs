//! G-code parsing throughput on a generated, deterministic 100 MiB milling program
//! (pocket-style zigzags, plunges, arcs in I/J and R form, comments, N numbers; about
//! 3.6 million lines), as the issue asks. Throughput is per byte.
//!
//! - `ours/parse_str`: `s2g_gcode::parse_str` into a counting sink: full modal
//!   interpretation (units, offsets, arcs with LinuxCNC's radius checks) and motions out.
//! - `ours/parse_reader`: the streaming `parse_reader` over the same bytes.
//! - `gcode_0_6/parse` (baseline): `gcode::parse(&str)` 0.6.1 (default features off, as
//!   pinned in the workspace), every word of every code consumed. It only tokenises: no
//!   modal state, no arc geometry.
//!
//! Run: `cargo bench --bench gcode_parse` (about a minute; check that the machine is idle).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use shape2gcode::gcode::{Motion, MotionSink, ParseOptions, parse_reader, parse_str};
use shape2gcode::geom::SplitMix64;

const TARGET_BYTES: usize = 100 << 20;

/// A realistic milling program: header, then pockets of zigzag passes, arcs and drills.
fn program() -> String {
    use std::fmt::Write;
    let mut rng = SplitMix64(0x5EED);
    let mut s = String::with_capacity(TARGET_BYTES + 4096);
    s.push_str(
        "%\n(generated pocketing program)\nG21 G17 G90 G94 G40 G49 G80\nT1 M6\nS12000 M3\nM8\nG0 Z5.000\n",
    );
    let mut n = 10u64;
    while s.len() < TARGET_BYTES {
        let (x0, y0) = (rng.unit() * 200.0, rng.unit() * 150.0);
        let depth = -(0.5 + rng.unit() * 4.0);
        let _ = writeln!(s, "(pocket at X{x0:.3} Y{y0:.3})");
        let _ = writeln!(s, "G0 X{x0:.3} Y{y0:.3}");
        let _ = writeln!(s, "G1 Z{depth:.3} F300");
        let w = 10.0 + rng.unit() * 30.0;
        for pass in 0..40 {
            let y = y0 + pass as f64 * 0.8;
            let x = if pass % 2 == 0 { x0 + w } else { x0 };
            if pass % 8 == 0 {
                let _ = writeln!(s, "N{n} G1 X{x:.3} Y{y:.3} F1200");
                n += 10;
            } else {
                let _ = writeln!(s, "G1 X{x:.3} Y{y:.3}");
            }
            let _ = writeln!(s, "Y{:.3}", y + 0.4);
        }
        // A circle of arcs, alternating I/J and R forms.
        let r = 2.0 + rng.unit() * 10.0;
        let (cx, cy) = (x0 + r, y0);
        let _ = writeln!(s, "G1 X{x0:.3} Y{y0:.3} F900");
        for k in 1..=8 {
            let a = k as f64 * std::f64::consts::FRAC_PI_4;
            let (px, py) = (cx - r * a.cos(), cy + r * a.sin());
            let prev = (k - 1) as f64 * std::f64::consts::FRAC_PI_4;
            let (sx, sy) = (cx - r * prev.cos(), cy + r * prev.sin());
            if k % 2 == 0 {
                let _ = writeln!(s, "G2 X{px:.4} Y{py:.4} R{r:.4}");
            } else {
                let _ = writeln!(s, "G2 X{px:.4} Y{py:.4} I{:.4} J{:.4}", cx - sx, cy - sy);
            }
        }
        let _ = writeln!(s, "G0 Z5.000 ; retract");
        if rng.unit() < 0.3 {
            let _ = writeln!(s, "G81 X{:.3} Y{:.3} Z-3.000 R1.000 F200\nG80", x0 + 5.0, y0 + 5.0);
        }
    }
    s.push_str("M9\nM5\nM30\n%\n");
    s
}

/// Counts motions and folds their coordinates so nothing is optimised away.
#[derive(Default)]
struct Count {
    n: u64,
    sum: f64,
}

impl MotionSink for Count {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        self.n += 1;
        if let Some(p) = m.end_point() {
            self.sum += p.x + p.y + p.z;
        }
        Ok(())
    }
}

fn bench(c: &mut Criterion) {
    let text = program();
    let opts = ParseOptions::default();
    // Sanity: the program is valid for both parsers.
    let mut check = Count::default();
    let summary = parse_str(&text, &opts, &mut check).expect("parse");
    assert!(summary.errors.is_empty(), "generated program has errors: {:?}", &summary.errors[..1]);
    let codes = gcode::parse(&text).count();
    assert!(codes as u64 > summary.lines / 2, "gcode 0.6 read only {codes} codes");

    let mut g = c.benchmark_group("gcode_parse_100MiB");
    g.throughput(Throughput::Bytes(text.len() as u64));
    g.sample_size(10);
    g.warm_up_time(std::time::Duration::from_secs(2));
    g.measurement_time(std::time::Duration::from_secs(15));
    g.bench_function("ours/parse_str", |b| {
        b.iter(|| {
            let mut sink = Count::default();
            parse_str(black_box(&text), &opts, &mut sink).expect("parse");
            black_box((sink.n, sink.sum))
        })
    });
    g.bench_function("ours/parse_reader", |b| {
        b.iter(|| {
            let mut sink = Count::default();
            parse_reader(black_box(text.as_bytes()), &opts, &mut sink).expect("parse");
            black_box((sink.n, sink.sum))
        })
    });
    g.bench_function("gcode_0_6/parse", |b| {
        b.iter(|| {
            let mut words = 0u64;
            let mut sum = 0.0f32;
            for code in gcode::parse(black_box(&text)) {
                sum += code.major_number() as f32;
                for w in code.arguments() {
                    words += 1;
                    sum += w.value;
                }
            }
            black_box((words, sum))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
