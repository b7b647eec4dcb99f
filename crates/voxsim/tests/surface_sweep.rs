//! The height field's tiled sweep against its reference (every column of a move's box
//! visited, `use_reference_sweep`): random cutters, column spacings, pass widths and
//! programs of short surface-following feeds, long moves, plunges, rapids and arcs give the
//! same cut heights and pass marks, bit for bit, with or without the square roots the
//! column and block tests leave out (`use_exact_column_tests`), with or without the box
//! test that passes most far blocks over before their distance (`use_every_block_distance`).

use proptest::prelude::*;
use s2g_gcode::{ArcDirection, Motion, MotionSink, Plane};
use s2g_geom::{Point3, SplitMix64};
use s2g_voxsim::{Cutter, HeightField, HeightFieldOptions, ToolTable};

/// A wavy sloped surface over `[0, 20]^2`.
fn surface(x: f64, y: f64) -> f64 {
    2.0 * (x / 3.0).sin() * (y / 4.0).cos() + 0.3 * x
}

/// A program of `n` random motions: raster passes of short feeds along the surface at a
/// random angle and stepover, with rapids between them, plunges, long diagonal feeds and
/// arcs in XY.
fn program(seed: u64, n: usize) -> Vec<Motion<'static>> {
    let mut g = SplitMix64::new(seed, 36);
    let mut ms = vec![Motion::Rapid { to: Point3::new(0.0, 0.0, 10.0) }];
    let mut at = Point3::new(0.0, 0.0, 10.0);
    let lin = |to: Point3| Motion::Linear { to, feed: 1000.0, extrude: None };
    while ms.len() < n {
        match g.below(5) {
            0 | 1 => {
                // A pass of short feeds along the surface.
                let (x0, y0) = (g.uniform(0.0, 20.0), g.uniform(0.0, 20.0));
                let ang = g.uniform(0.0, std::f64::consts::TAU);
                let step = g.uniform(0.05, 0.6);
                ms.push(Motion::Rapid { to: Point3::new(x0, y0, 10.0) });
                for k in 0..g.below(40) + 2 {
                    let (x, y) = (x0 + k as f64 * step * ang.cos(), y0 + k as f64 * step * ang.sin());
                    at = Point3::new(x, y, surface(x, y));
                    ms.push(lin(at));
                }
            }
            2 => {
                at = Point3::new(g.uniform(-2.0, 22.0), g.uniform(-2.0, 22.0), g.uniform(-2.0, 6.0));
                ms.push(lin(at));
            }
            3 => {
                at = Point3::new(at.x, at.y, at.z - g.uniform(0.0, 2.0));
                ms.push(if g.below(2) == 0 { lin(at) } else { Motion::Rapid { to: at } });
            }
            _ => {
                let r = g.uniform(0.2, 4.0);
                let a = g.uniform(0.0, std::f64::consts::TAU);
                let center = Point3::new(at.x - r * a.cos(), at.y - r * a.sin(), at.z);
                let b = a + g.uniform(-3.0, 3.0);
                let to =
                    Point3::new(center.x + r * b.cos(), center.y + r * b.sin(), at.z + g.uniform(-0.5, 0.5));
                let direction =
                    if g.below(2) == 0 { ArcDirection::Clockwise } else { ArcDirection::CounterClockwise };
                ms.push(Motion::Arc {
                    to,
                    center,
                    plane: Plane::XY,
                    direction,
                    turns: 0,
                    feed: 1000.0,
                    extrude: None,
                });
                at = to;
            }
        }
    }
    ms
}

fn field(cutter: &Cutter, o: &HeightFieldOptions, ms: &[Motion<'_>], reference: bool) -> HeightField {
    let mut f = HeightField::new_opt([-1.0, -1.0], [21.0, 21.0], ToolTable::single(*cutter), o).unwrap();
    if reference {
        f.use_reference_sweep();
    }
    for m in ms {
        f.motion(m).unwrap();
    }
    f
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn the_tiled_sweep_cuts_and_marks_the_columns_as_the_reference_does(
        seed in any::<u64>(),
        kind in 0usize..3,
        r in 0.5f64..6.0,
        spacing in 0.04f64..0.4,
        width in proptest::option::of(0.0f64..2.0),
    ) {
        let cutter = match kind {
            0 => Cutter::flat(r, 30.0),
            1 => Cutter::ball(r, 30.0),
            _ => Cutter::bull(r, 0.4 * r, 30.0),
        };
        let o = HeightFieldOptions { spacing, pass_width: width, ..Default::default() };
        let ms = program(seed, 300);
        let (fast, slow) = (field(&cutter, &o, &ms, false), field(&cutter, &o, &ms, true));
        // The tiled sweep's baseline (square roots throughout) too.
        let mut roots = HeightField::new_opt([-1.0, -1.0], [21.0, 21.0], ToolTable::single(cutter), &o).unwrap();
        roots.use_exact_column_tests();
        ms.iter().for_each(|m| roots.motion(m).unwrap());
        let ((t1, p1), (t2, p2)) = (fast.columns(), slow.columns());
        prop_assert_eq!(bits(roots.columns().0), bits(t2));
        prop_assert_eq!(bits(roots.columns().1), bits(p2));
        // And its baseline before the box test (every block's distance computed).
        let mut every = HeightField::new_opt([-1.0, -1.0], [21.0, 21.0], ToolTable::single(cutter), &o).unwrap();
        every.use_every_block_distance();
        ms.iter().for_each(|m| every.motion(m).unwrap());
        prop_assert_eq!(bits(every.columns().0), bits(t2));
        prop_assert_eq!(bits(every.columns().1), bits(p2));
        // The program cuts: a field left at +inf everywhere would agree trivially.
        prop_assert!(t2.iter().filter(|t| t.is_finite()).count() > t2.len() / 10);
        prop_assert_eq!(bits(t1), bits(t2));
        prop_assert_eq!(bits(p1), bits(p2));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// The pipeline's way of feeding the field: on a thread of its own, in batches, every
    /// move swept on that thread (`set_parallel_columns(usize::MAX)`), leaves the same cut
    /// heights and pass marks, bit for bit, as the field fed directly, its long moves
    /// swept on rayon's threads (the default): the same moves in the same order, each
    /// column computed by the same expressions.
    #[test]
    fn a_field_fed_on_its_own_thread_in_batches_is_the_field_fed_directly(
        seed in any::<u64>(),
        ball in any::<bool>(),
        r in 2.0f64..6.0,
        spacing in 0.04f64..0.1,
        batch in 1usize..300,
        width in proptest::option::of(0.1f64..1.0),
    ) {
        let cutter = if ball { Cutter::ball(r, 30.0) } else { Cutter::bull(r, 0.4 * r, 30.0) };
        let o = HeightFieldOptions { spacing, pass_width: width, ..Default::default() };
        let ms = program(seed, 400);
        let direct = field(&cutter, &o, &ms, false);
        let mut serial = HeightField::new_opt([-1.0, -1.0], [21.0, 21.0], ToolTable::single(cutter), &o).unwrap();
        serial.set_parallel_columns(usize::MAX);
        let mut fed = s2g_gcode::SinkThread::spawn(serial, batch, 4);
        for m in &ms {
            let Ok(()) = fed.motion(m);
        }
        let threaded = fed.join().unwrap();
        let ((t1, p1), (t2, p2)) = (direct.columns(), threaded.columns());
        prop_assert!(t1.iter().filter(|t| t.is_finite()).count() > t1.len() / 10);
        prop_assert_eq!(bits(t1), bits(t2));
        prop_assert_eq!(bits(p1), bits(p2));
    }
}
