//! The five named shop parts of issue 35, in millimetres, 60-100 mm: a flanged bushing,
//! an L-bracket, a pocketed plate (100 x 70 x 15), a stepped boss and a T-slot block. They
//! are fixed (no seed), built by the same exact mesher as the random prismatic parts.

use crate::prism::{Edge, Outline, Prism};

/// The shop parts' names, in the order [`crate::shop_parts`] returns them.
pub const SHOP_PARTS: [&str; 5] =
    ["flanged_bushing", "l_bracket", "pocketed_plate", "stepped_boss", "t_slot_block"];

/// The shop part at `index` (in [`SHOP_PARTS`] order).
pub(crate) fn shop_prism(index: usize) -> Option<Prism> {
    Some(match index {
        0 => flanged_bushing(),
        1 => l_bracket(),
        2 => pocketed_plate(),
        3 => stepped_boss(),
        4 => t_slot_block(),
        _ => return None,
    })
}

/// A flange of 80 mm diameter and 10 mm with a 1 mm chamfer, a 50 mm body 45 mm long
/// (1.5 mm chamfer), a 30 mm bore through with a 1.5 mm countersink, and four 6.6 mm bolt
/// holes on a 65 mm circle. 80 x 80 x 55 mm.
fn flanged_bushing() -> Prism {
    let mut p = Prism::new(Outline::Disc { r: 40.0 }, 10.0, Edge::Chamfer(1.0));
    p.boss([0.0, 0.0], 50.0, 10.0, 45.0, 1.5);
    p.hole([0.0, 0.0], 30.0, 55.0, 0.0, 1.5);
    for k in 0..4 {
        let a = std::f64::consts::FRAC_PI_2 * k as f64 + std::f64::consts::FRAC_PI_4;
        p.hole([32.5 * a.cos(), 32.5 * a.sin()].map(crate::ring::snap), 6.6, 10.0, 0.0, 0.0);
    }
    p
}

/// An angle: a 100 x 60 x 10 mm base with a 12 mm upright 70 mm tall (a step), two
/// counterbored M6 holes and a slot in the base, two blind 5 mm holes in the upright's
/// top. 100 x 60 x 70 mm.
fn l_bracket() -> Prism {
    let mut p = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 4.0 }, 70.0, Edge::None);
    p.step(-38.0, 10.0);
    for y in [-15.0, 15.0] {
        p.counterbore([5.0, y], 6.6, 11.0, 5.0, 10.0, 0.0);
        p.hole([-44.0, y], 5.0, 70.0, 55.0, 0.0);
    }
    p.slot([32.0, 0.0], 24.0, 8.0, true, 10.0, 0.0);
    p
}

/// A 100 x 70 x 15 mm plate (6 mm corners, 1 mm chamfer) with two pockets: one 32 x 40
/// mm, 8 deep, with a 14 x 20 mm pocket 4 mm deeper in its floor; one 32 x 28 mm, 6 deep,
/// with a 10 mm hole through its floor; a 26 x 8 mm slot 5 deep; four counterbored M6
/// holes at the corners.
fn pocketed_plate() -> Prism {
    let mut p = Prism::new(Outline::Rect { h: [50.0, 35.0], r: 6.0 }, 15.0, Edge::Chamfer(1.0));
    p.pocket([-20.0, 0.0], [16.0, 20.0], 5.0, 15.0, 7.0, 0.0);
    p.pocket([-20.0, 0.0], [7.0, 10.0], 3.0, 7.0, 3.0, 0.0);
    p.pocket([24.0, 6.0], [16.0, 14.0], 4.0, 15.0, 9.0, 0.0);
    p.hole([24.0, 6.0], 10.0, 9.0, 0.0, 0.0);
    p.slot([20.0, -20.0], 26.0, 8.0, true, 15.0, 10.0);
    for (x, y) in [(-41.0, -26.0), (41.0, -26.0), (41.0, 26.0), (-41.0, 26.0)] {
        p.counterbore([x, y], 6.6, 11.0, 6.5, 15.0, 0.0);
    }
    p
}

/// An 80 x 80 x 12 mm base (8 mm corners) with a 50 mm boss 18 mm tall and a 30 mm boss
/// 15 mm tall on it (1.5 mm chamfer), a 16 mm bore through (1 mm countersink), and four
/// 9 mm holes in the base. 80 x 80 x 45 mm.
fn stepped_boss() -> Prism {
    let mut p = Prism::new(Outline::Rect { h: [40.0, 40.0], r: 8.0 }, 12.0, Edge::None);
    p.boss([0.0, 0.0], 50.0, 12.0, 18.0, 0.0);
    p.boss([0.0, 0.0], 30.0, 30.0, 15.0, 1.5);
    p.hole([0.0, 0.0], 16.0, 45.0, 0.0, 1.0);
    for (x, y) in [(-30.0, -30.0), (30.0, -30.0), (30.0, 30.0), (-30.0, 30.0)] {
        p.hole([x, y], 9.0, 12.0, 0.0, 0.0);
    }
    p
}

/// A 100 x 60 x 40 mm block (3 mm corners) with a T-slot along its length (neck 12 mm
/// wide and 12 deep, head 22 mm wide and 10 high) and four 8.5 mm holes through.
fn t_slot_block() -> Prism {
    let mut p = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 3.0 }, 40.0, Edge::None);
    p.t_slot(0.0, [12.0, 12.0], [22.0, 10.0]);
    for (x, y) in [(-38.0, -20.0), (38.0, -20.0), (38.0, 20.0), (-38.0, 20.0)] {
        p.hole([x, y], 8.5, 40.0, 0.0, 0.0);
    }
    p
}
