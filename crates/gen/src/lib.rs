//! `s2g-gen`: a deterministic generator of CAD-like parts.
//!
//! Placeholder docs.

mod error;
mod face;
mod feature;
mod prism;
mod ring;
mod stack;

pub use crate::error::{GenError, Result};
pub use crate::feature::Feature;
pub use crate::ring::{MAX_COORD, QUANTUM};

#[cfg(test)]
mod tests {
    use crate::prism::{Edge, Outline, Prism};
    use s2g_geom::report;

    fn check(p: &Prism, expect: Option<f64>) {
        let b = p.build().unwrap();
        let r = report(&b.mesh);
        assert!(r.closed && r.manifold && r.consistently_oriented, "{r:?}");
        let v = b.mesh.signed_volume();
        assert!((v - b.volume).abs() <= 1e-9 * b.volume, "{v} vs {}", b.volume);
        if let Some(e) = expect {
            assert!((v - e).abs() <= 1e-9 * e, "{v} vs {e}");
        }
    }

    #[test]
    fn simple_solids() {
        let mut p = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 0.0 }, 20.0, Edge::None);
        check(&p, Some(100.0 * 60.0 * 20.0));
        p.raw_cut(crate::ring::rounded_rect(-10.0, -10.0, 10.0, 10.0, [0.0; 4], 1).reversed(), 5.0, 20.0);
        check(&p, Some(100.0 * 60.0 * 20.0 - 400.0 * 15.0));
        p.raw_cut(crate::ring::rounded_rect(-5.0, -5.0, 5.0, 5.0, [0.0; 4], 1).reversed(), 0.0, 5.0);
        check(&p, Some(100.0 * 60.0 * 20.0 - 400.0 * 15.0 - 500.0));
        let mut t = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 5.0 }, 40.0, Edge::None);
        t.t_slot(0.0, [12.0, 12.0], [22.0, 10.0]);
        check(&t, None);
        let mut s = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 5.0 }, 40.0, Edge::None);
        s.step(10.0, 20.0);
        s.open_slot(-10.0, 8.0, 5.0);
        check(&s, None);
        let mut c = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 8.0 }, 20.0, Edge::Chamfer(2.0));
        c.pocket([0.0, 0.0], [20.0, 10.0], 4.0, 20.0, 10.0, 0.1);
        c.hole([35.0, 0.0], 6.0, 20.0, 0.0, 1.0);
        c.boss([-35.0, 0.0], 12.0, 20.0, 10.0, 1.0);
        c.counterbore([35.0, 20.0], 6.0, 10.0, 4.0, 20.0, 0.0);
        c.slot([-30.0, -20.0], 20.0, 6.0, true, 20.0, 15.0);
        c.rib([0.0, 20.0], [15.0, 2.0], 20.0, 8.0);
        check(&c, None);
        let f = Prism::new(Outline::Disc { r: 40.0 }, 20.0, Edge::Fillet(4.0, 5));
        check(&f, None);
        let d = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 8.0 }, 20.0, Edge::Draft(0.05));
        check(&d, None);
    }
}
