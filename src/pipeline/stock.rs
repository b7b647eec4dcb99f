//! The stock a run cuts from and the work coordinate system (G54) its programs are
//! written in.

use nalgebra::Translation3;

use super::api::{Datum, MillError, Stock};
use super::job::stock_in_setup;
use crate::geom::{Aabb, Point3, Setup, Vector3, VoxelGrid};
use crate::orient::stock_grid_points;

/// The stock body in planning units (part frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum StockBody {
    /// A box.
    Box(Aabb),
    /// A cylinder (bar stock): centre, unit axis, radius and half length.
    Cylinder {
        /// The centre of the bar.
        centre: Point3,
        /// Principal axis index of the bar (0 = X, 1 = Y, 2 = Z).
        axis: usize,
        /// Radius.
        radius: f64,
        /// Half the bar's length.
        half_length: f64,
    },
}

impl StockBody {
    /// The body `stock` describes for a part with bounding box `part` (planning units);
    /// `preset` is the preset's own stock box. Errors on sizes that are not positive and
    /// finite, and on a stock that does not hold the part's bounding box.
    pub(super) fn new(stock: &Stock, part: &Aabb, preset: Aabb) -> Result<Self, MillError> {
        let bad = |what: String| Err(MillError::InvalidOption(what));
        let positive = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x > 0.0);
        let c = part.center();
        let body = match *stock {
            Stock::Preset => Self::Box(preset),
            Stock::BoxSize(size) => {
                if !positive(&size) {
                    return bad(format!("stock box size must be positive and finite, got {size:?}"));
                }
                let h = Vector3::from(size) * 0.5;
                Self::Box(Aabb::new(c - h, c + h))
            }
            Stock::BoxCorners { min, max } => {
                let (lo, hi) = (Point3::from(min), Point3::from(max));
                if !(lo.iter().chain(hi.iter()).all(|x| x.is_finite()) && (0..3).all(|a| lo[a] < hi[a])) {
                    return bad(format!(
                        "stock box corners must be finite with min < max, got {min:?} and {max:?}"
                    ));
                }
                Self::Box(Aabb::new(lo, hi))
            }
            Stock::Cylinder { diameter, length, axis } => {
                if !positive(&[diameter, length]) || axis > 2 {
                    return bad(format!(
                        "bar stock needs a positive diameter and length and an axis X, Y or Z, got {diameter}, {length}, axis {axis}"
                    ));
                }
                Self::Cylinder { centre: c, axis, radius: 0.5 * diameter, half_length: 0.5 * length }
            }
        };
        let bbox = body.bbox();
        // A hair of tolerance: a stock exactly the part's size holds it.
        let tol = 1e-9 * part.extent().norm().max(f64::MIN_POSITIVE);
        let holds = match body {
            Self::Box(b) => b.inflated(tol).contains(&part.min) && b.inflated(tol).contains(&part.max),
            Self::Cylinder { .. } => {
                bbox.inflated(tol).contains(&part.min)
                    && bbox.inflated(tol).contains(&part.max)
                    && part.corners().iter().all(|p| body.radial(p) <= body.radius() + tol)
            }
        };
        if !holds {
            return bad(format!(
                "the stock {bbox:?} does not hold the part's bounding box {part:?} (size it larger, or centre it on the part)"
            ));
        }
        Ok(body)
    }

    fn radius(&self) -> f64 {
        match *self {
            Self::Box(_) => f64::INFINITY,
            Self::Cylinder { radius, .. } => radius,
        }
    }

    /// Distance of `p` from the bar's axis (0 for a box).
    fn radial(&self, p: &Point3) -> f64 {
        match *self {
            Self::Box(_) => 0.0,
            Self::Cylinder { centre, axis, .. } => {
                let mut d = p - centre;
                d[axis] = 0.0;
                d.norm()
            }
        }
    }

    /// The box around the body.
    pub(super) fn bbox(&self) -> Aabb {
        match *self {
            Self::Box(b) => b,
            Self::Cylinder { centre, axis, radius, half_length } => {
                let mut h = Vector3::repeat(radius);
                h[axis] = half_length;
                Aabb::new(centre - h, centre + h)
            }
        }
    }

    /// Whether `p` lies in the body.
    pub(super) fn contains(&self, p: &Point3) -> bool {
        match *self {
            Self::Box(b) => b.contains(p),
            Self::Cylinder { .. } => self.bbox().contains(p) && self.radial(p) <= self.radius(),
        }
    }

    /// The simulator's starting stock on `spec`: every voxel whose centre lies in the body
    /// (every voxel where the grid lies within a box).
    pub(super) fn voxels(&self, spec: crate::geom::GridSpec) -> VoxelGrid {
        let grid = spec.bounds();
        let tol = 1e-9 * grid.extent().norm();
        match self {
            Self::Box(b) if b.inflated(tol).contains(&grid.min) && b.inflated(tol).contains(&grid.max) => {
                VoxelGrid::full(spec)
            }
            _ => {
                let mut g = VoxelGrid::new(spec);
                g.set_where(|p| self.contains(p));
                g
            }
        }
    }

    /// About `count` sample points of the body, for the stock-removal term of
    /// orientation selection.
    pub(super) fn samples(&self, count: usize) -> Vec<Point3> {
        stock_grid_points(&self.bbox(), count, |p| self.contains(p))
    }

    /// A short description for program headers and reports.
    pub(super) fn describe(&self) -> String {
        match *self {
            Self::Box(b) => {
                let e = b.extent();
                format!("box {:.4} x {:.4} x {:.4}", e.x, e.y, e.z)
            }
            Self::Cylinder { axis, radius, half_length, .. } => {
                format!("bar D{:.4} x {:.4} along {}", 2.0 * radius, 2.0 * half_length, ["X", "Y", "Z"][axis])
            }
        }
    }
}

/// `setup` with its program origin moved to `datum` of the stock box `stock`: the
/// stock's top (along the tool axis) at Z0, and X0 Y0 at its centre or its lowest
/// corner in the setup's X and Y. Returns the setup and the datum's point in the part
/// frame.
pub(super) fn datum_setup(setup: &Setup, stock: &Aabb, datum: Datum) -> (Setup, Point3) {
    let b = stock_in_setup(stock, setup);
    let c = b.center();
    let origin = match datum {
        Datum::TopCentre => Point3::new(c.x, c.y, b.max.z),
        Datum::Corner => Point3::new(b.min.x, b.min.y, b.max.z),
    };
    let shifted = Setup { frame: setup.frame * Translation3::from(origin.coords) };
    (shifted, setup.to_part(&origin))
}

/// The program comment stating the work coordinate system of a setup whose datum sits at
/// `at` (part frame).
pub(super) fn datum_comment(datum: Datum, at: &Point3, body: &StockBody) -> String {
    let name = match datum {
        Datum::TopCentre => "stock top centre",
        Datum::Corner => "stock top corner (min X, min Y)",
    };
    format!(
        "WCS G54 X0 Y0 Z0 = {name}, part frame ({:.4} {:.4} {:.4}); stock {}",
        at.x,
        at.y,
        at.z,
        body.describe()
    )
}
