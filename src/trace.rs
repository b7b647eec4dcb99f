//! [`PathTrace`]: the part of a toolpath a run keeps for drawing, bounded in memory.

use crate::geom::Point3;

/// A polyline of the toolpath to draw: points in the part frame and whether it cuts.
///
/// Filled with [`push`](Self::push), it keeps only what [`render_machining`](crate::render_machining) draws (moves
/// along one level of the tool axis) and at most [`PathTrace::CAPACITY`] segments: when
/// full, it keeps every other level it has seen and from then on only those, so a program
/// of tens of millions of moves leaves a trace of a few tens of megabytes.
#[derive(Debug, Clone, Default)]
pub struct PathTrace {
    /// Segments `(from, to, cutting)`; rapids are drawn lighter.
    pub segments: Vec<(Point3, Point3, bool)>,
    /// Levels seen so far (each run of moves at one height is one level) and the current
    /// level's height.
    levels: usize,
    level: Option<f64>,
    /// Keep the levels whose number is a multiple of `2^stride_log`.
    stride_log: u32,
    /// The level number of each kept segment.
    level_of: Vec<u32>,
}

impl PathTrace {
    /// Most segments kept (about 56 MiB).
    pub const CAPACITY: usize = 1 << 20;

    /// Records the move `from -> to` whose heights along the tool axis are `heights`:
    /// moves that change height by more than `tol` (plunges, ramps, retracts) are not drawn
    /// and not kept.
    pub fn push(&mut self, from: Point3, to: Point3, cutting: bool, heights: [f64; 2], tol: f64) {
        let [h0, h1] = heights;
        if (h0 - h1).abs() > tol {
            return;
        }
        if self.level.is_none_or(|h| (h - h0).abs() > tol) {
            self.levels += 1;
            self.level = Some(h0);
        }
        let n = self.levels - 1;
        let kept = |stride_log: u32, level: usize| level.is_multiple_of(1 << stride_log);
        if !kept(self.stride_log, n) {
            return;
        }
        if self.segments.len() == Self::CAPACITY {
            self.stride_log += 1;
            let mut keep = self.level_of.iter().map(|&l| kept(self.stride_log, l as usize));
            self.segments.retain(|_| keep.next() == Some(true));
            self.level_of.retain(|&l| kept(self.stride_log, l as usize));
            if !kept(self.stride_log, n) {
                return;
            }
        }
        self.segments.push((from, to, cutting));
        self.level_of.push(n as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_trace_keeps_every_other_level_within_its_capacity() {
        let mut trace = PathTrace::default();
        let per_level = 10_000;
        let levels = 3 * PathTrace::CAPACITY / per_level;
        for l in 0..levels {
            let z = -(l as f64);
            // A plunge to the level (not kept), then moves along it.
            trace.push(Point3::new(0.0, 0.0, z + 1.0), Point3::new(0.0, 0.0, z), true, [z + 1.0, z], 1e-9);
            for i in 0..per_level {
                let (a, b) = (Point3::new(i as f64, 0.0, z), Point3::new(i as f64 + 1.0, 0.0, z));
                trace.push(a, b, i % 2 == 0, [z, z], 1e-9);
            }
        }
        assert!(trace.segments.len() <= PathTrace::CAPACITY, "{} segments", trace.segments.len());
        assert!(trace.segments.iter().all(|(a, b, _)| a.z == b.z), "only moves along a level");
        let mut kept: Vec<i64> = trace.segments.iter().map(|(a, _, _)| -a.z as i64).collect();
        kept.dedup();
        assert!(kept.len() > 1 && kept.iter().all(|l| l % 4 == 0), "every fourth level: {kept:?}");
        assert!(*kept.last().unwrap() as usize >= levels - 4, "levels to the end: {kept:?}");
        assert!(
            kept.iter().all(|&l| trace.segments.iter().filter(|s| -s.0.z as i64 == l).count() == per_level)
        );
    }
}
