//! `SinkThread`: a sink fed on its own thread in batches sees the calls it would see fed
//! directly, in order; its first error comes back from `join`, the motions after it
//! dropped.

use nalgebra::Point3;
use s2g_gcode::{Motion, MotionRecorder, MotionSink, SinkThread};

/// `n` feeds and rapids with source lines between them, and a comment (owned text).
fn calls(n: usize) -> Vec<(u64, Motion<'static>)> {
    (0..n)
        .map(|k| {
            let p = Point3::new(k as f64 * 0.5, (k % 7) as f64, -(k as f64) * 0.01);
            let m = match k % 5 {
                0 => Motion::Rapid { to: p },
                3 => Motion::Comment(format!("pass {k}").into()),
                _ => Motion::Linear { to: p, feed: 100.0 + k as f64, extrude: None },
            };
            (k as u64 + 1, m)
        })
        .collect()
}

fn feed<S: MotionSink>(sink: &mut S, calls: &[(u64, Motion<'static>)]) -> Result<(), S::Error> {
    for (line, m) in calls {
        sink.source_line(*line)?;
        sink.motion(m)?;
    }
    sink.finish()
}

/// Every batch size, including one that does not divide the calls and one larger than
/// them all, and a channel of one batch (the feeder waiting on the thread) give the
/// recorder the same motions with the same source lines as feeding it directly.
#[test]
fn a_sink_on_its_own_thread_sees_every_call_in_order() {
    let cs = calls(2_345);
    let mut direct = MotionRecorder::default();
    feed(&mut direct, &cs).unwrap();
    for (size, depth) in [(1, 1), (7, 1), (64, 4), (1_000, 2), (10_000, 8)] {
        let mut t = SinkThread::spawn(MotionRecorder::default(), size, depth);
        let Ok(()) = feed(&mut t, &cs);
        let got = t.join().unwrap();
        assert_eq!(got.motions.len(), direct.motions.len(), "batch {size}");
        assert!(got.motions == direct.motions, "batch {size}: motions differ");
    }
    let mut here = SinkThread::here(MotionRecorder::default());
    let Ok(()) = feed(&mut here, &cs);
    assert!(here.join().unwrap().motions == direct.motions);
}

/// A sink that fails at its `fail`th motion and counts those it took.
struct FailsAt {
    fail: usize,
    took: usize,
}

impl MotionSink for FailsAt {
    type Error = String;
    fn motion(&mut self, _: &Motion<'_>) -> Result<(), String> {
        if self.took == self.fail {
            return Err(format!("failed at motion {}", self.took));
        }
        self.took += 1;
        Ok(())
    }
}

/// The first error, not a later one, comes back from `join`, on the thread or here, and
/// feeding on after it neither fails nor blocks (the thread is gone, its batches dropped).
#[test]
fn a_sink_threads_first_error_comes_back_from_join() {
    let cs = calls(5_000);
    for size in [1, 3, 256] {
        let mut t = SinkThread::spawn(FailsAt { fail: 1_234, took: 0 }, size, 1);
        let Ok(()) = feed(&mut t, &cs);
        assert_eq!(t.join().err().as_deref(), Some("failed at motion 1234"), "batch {size}");
    }
    let mut here = SinkThread::here(FailsAt { fail: 10, took: 0 });
    let Ok(()) = feed(&mut here, &cs);
    assert_eq!(here.join().err().as_deref(), Some("failed at motion 10"));
    // Dropped without a join, the thread is stopped and waited for.
    let mut t = SinkThread::spawn(FailsAt { fail: usize::MAX, took: 0 }, 16, 1);
    let Ok(()) = feed(&mut t, &cs[..100]);
    drop(t);
}
