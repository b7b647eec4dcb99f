//! The paper's Monte-Carlo carver (Shape2Gcode, Appendix A.2, Algorithm A1), kept as a
//! named baseline for comparison.
//!
//! As printed: for a cutting segment `L = end - start` with `n = floor(|L| / sweep_step)`
//! (here `sweep_step = 1 / samples_per_unit`), draw `n` tuples
//! `(l, d, n', r, theta, phi)` with `l ~ U(0,1)`, `d, n' ~ U(-1,1)`, `r ~ U(0, R)`,
//! `theta ~ U(0, pi)`, `phi ~ U(0, 2 pi)` and erase the voxels containing
//! - `p_s = start + r (sin theta cos phi, sin theta sin phi, cos theta)` (ball at the start),
//! - `p_c = start + l L + r cos theta D_u + r sin theta N_u` (half disc swept along L),
//! - `p_r = start + l L + d R D_u + n' R N_u` (square section swept along L),
//!
//! with `D_u = (L x axis) / |L x axis|` and `N_u` the tool axis. Only feed (G1/G2/G3) moves
//! cut; rapids are skipped, as in the paper. The paper's point is the tool centre, so the
//! tip we are given is moved up by `R` along the axis (the ball centre of a ball end mill).
//!
//! **Plunges.** When `L` is parallel to the tool axis, `L x axis` vanishes and `D_u` is
//! undefined; we then take `D_u = normalize(axis x X)`, or `normalize(axis x Y)` when the
//! axis is within 1e-6 of X, a deterministic choice (the sampled square section then has a
//! fixed orientation about the axis).

use s2g_geom::{Point3, SplitMix64, Vector3};

use crate::engine::{Stats, Store};

/// State of the Monte-Carlo carver.
#[derive(Debug, Clone)]
pub(crate) struct Paper {
    /// Its own generator rather than rand's `StdRng`, so that the simulator can be cloned.
    rng: SplitMix64,
    samples_per_unit: f64,
}

impl Paper {
    pub fn new(samples_per_unit: f64, seed: u64) -> Self {
        Self { rng: SplitMix64(seed), samples_per_unit }
    }

    /// Carves one cutting segment between tool tips `tip0` and `tip1`.
    #[allow(clippy::too_many_arguments)] // The algorithm's own inputs.
    pub fn segment(
        &mut self,
        store: &mut Store,
        target: Option<&Store>,
        tip0: Point3,
        tip1: Point3,
        axis: Vector3,
        radius: f64,
        seq_line: (u64, u64),
    ) -> Stats {
        let mut st = Stats::default();
        let start = tip0 + axis * radius;
        let l = tip1 - tip0;
        let len = l.norm();
        if len == 0.0 {
            return st;
        }
        let lu = l / len;
        let nu = axis.normalize();
        let du = l.cross(&axis).try_normalize(1e-12 * len).unwrap_or_else(|| {
            let x = if nu.x.abs() < 1.0 - 1e-6 { Vector3::x() } else { Vector3::y() };
            nu.cross(&x).normalize()
        });
        // Saturating float-to-int conversion: absurd densities just run long.
        let n = (len * self.samples_per_unit).floor() as u64;
        let spec = store.spec;
        let mut erase = |p: Point3, st: &mut Stats| {
            if let Some([i, j, k]) = spec.index_of(&p)
                && store.get(i, j, k)
            {
                store.set(i, j, k, false);
                st.removed += 1;
                if target.is_some_and(|t| t.get(i, j, k)) {
                    st.gouge += 1;
                    if st.first_gouge.is_none() {
                        st.first_gouge = Some(seq_line);
                    }
                }
            }
        };
        let pi = std::f64::consts::PI;
        for _ in 0..n {
            let lf = self.rng.uniform(0.0, 1.0);
            let d = self.rng.uniform(-1.0, 1.0);
            let np = self.rng.uniform(-1.0, 1.0);
            let r = self.rng.uniform(0.0, radius);
            let th = self.rng.uniform(0.0, pi);
            let ph = self.rng.uniform(0.0, 2.0 * pi);
            let ps = start + Vector3::new(r * th.sin() * ph.cos(), r * th.sin() * ph.sin(), r * th.cos());
            let along = start + lu * (lf * len);
            let pc = along + du * (r * th.cos()) + nu * (r * th.sin());
            let pr = along + du * (d * radius) + nu * (np * radius);
            erase(ps, &mut st);
            erase(pc, &mut st);
            erase(pr, &mut st);
        }
        st
    }
}
