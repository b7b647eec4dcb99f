//! The tool of the collision losses and checks (Appendix B of seed 002): a physical
//! cutter (geom's [`Cutter`], the one cutter vocabulary of the workspace) sampled as points
//! in rings along its axis, and the placement of those points at poses, on the host and as
//! tensors.

use burn::tensor::{Tensor, TensorData};
use s2g_geom::{Cutter, CutterShape, Flat, Point3, Vector3};

use crate::error::{FieldError, Result};
use crate::layer::{cross, layer_normal};

/// A tool sampled as points (Appendix B of seed 002): the physical [`Cutter`] (flutes,
/// shank and holder as one axisymmetric stack) and how its surface is sampled. The tool's
/// base point (the cutter's tip, the end's centre) sits at the pose point; its axis is the
/// layer normal. Each ring of points lies on the stack's surface at its height
/// ([`Cutter::radius_at`]). Printing uses the same model for the nozzle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tool {
    /// The physical cutter: its radius offsets the poses from the part, its stack (up to
    /// [`Tool::length`]) is what the collision terms sample, and the five-axis program is
    /// checked and simulated with it.
    pub cutter: Cutter,
    /// Where the sampling starts along the axis, measured from the base point, finite and
    /// `>= 0` (Appendix B starts above the cutting end: the end itself touches the layer
    /// being cut and the part's offset surface by construction).
    pub axial_offset: f64,
    /// Axial interval between rings, finite and `> 0` (Appendix B: 5 mm).
    pub axial_step: f64,
    /// Points per ring on the stack's surface, `>= 3` (Appendix B: 10).
    pub ring_points: usize,
}

impl Default for Tool {
    /// A 5 mm cylinder (radius 2.5) 40 mm long ([`Tool::cylinder`]), sampled from 3 mm at
    /// 4 mm intervals with 10 points per ring.
    fn default() -> Self {
        Self::cylinder(2.5, 40.0)
    }
}

impl Tool {
    /// The flute length of [`Tool::cylinder`]'s cutter: `10.0`, or the whole length when
    /// the cylinder is shorter.
    pub const CYLINDER_FLUTE_LENGTH: f64 = 10.0;

    /// `cutter` with the default sampling: rings from 3 mm at 4 mm intervals, 10 points
    /// per ring.
    pub fn from_cutter(cutter: Cutter) -> Self {
        Self { cutter, axial_offset: 3.0, axial_step: 4.0, ring_points: 10 }
    }

    /// A cylinder of `radius` from the tip up to `length`, as a flat end mill with
    /// [`Tool::CYLINDER_FLUTE_LENGTH`] of flutes, a shank of the same radius up to
    /// `length` (the stick-out) and no holder, with the default sampling
    /// ([`Tool::from_cutter`]). Not validated here ([`Tool::validate`]).
    pub fn cylinder(radius: f64, length: f64) -> Self {
        Self::from_cutter(Cutter {
            shape: CutterShape::Flat(Flat),
            radius,
            flute_length: Self::CYLINDER_FLUTE_LENGTH.min(length),
            shank_radius: radius,
            stickout: length,
            holder: None,
            neck: None,
        })
    }

    /// The cutting radius (the cutter's [`radius`](Cutter::radius)).
    pub fn radius(&self) -> f64 {
        self.cutter.radius
    }

    /// The length of the stack from the tip: the stick-out, plus the holder's length when
    /// one is modelled.
    pub fn length(&self) -> f64 {
        match self.cutter.holder {
            Some(holder) => self.cutter.stickout + holder.length,
            None => self.cutter.stickout,
        }
    }

    /// The largest radius of the stack (flutes, shank, holder): a bound on the distance of
    /// any tool point from the axis.
    pub fn envelope_radius(&self) -> f64 {
        let c = &self.cutter;
        c.holder.map_or(c.radius.max(c.shank_radius), |h| c.radius.max(c.shank_radius).max(h.radius))
    }

    /// Checks the cutter ([`Cutter::validate`]) and every sampling field's range.
    pub fn validate(&self) -> Result<()> {
        // The sizes a user gives first, by their names; then the rest of the cutter.
        FieldError::check_positive(&[("tool.radius", self.radius()), ("tool.axial_step", self.axial_step)])?;
        FieldError::check_non_negative(&[("tool.axial_offset", self.axial_offset)])?;
        let length = self.length();
        if !(length.is_finite() && length > self.axial_offset) {
            return Err(FieldError::config("tool.length", "must be finite and > axial_offset"));
        }
        self.cutter.validate().map_err(|e| FieldError::config("tool.cutter", e.to_string()))?;
        if (length - self.axial_offset) / self.axial_step > 1e4 {
            return Err(FieldError::config("tool.axial_step", "too many rings (> 10^4)"));
        }
        if !(3..=1024).contains(&self.ring_points) {
            return Err(FieldError::config("tool.ring_points", "must be in 3..=1024"));
        }
        Ok(())
    }

    /// The sample points in the tool's frame `(axial, u, v)`: the axis is `+axial`, the
    /// base point the origin. Rings at `axial_offset, axial_offset + axial_step, ...,
    /// length` (the last ring at [`Tool::length`] exactly), each with `ring_points` points
    /// on the stack's surface (radius [`Cutter::radius_at`] the ring's height) rotated by
    /// `phase` radians, and one axis point per ring.
    pub fn points(&self, phase: f64) -> Vec<[f64; 3]> {
        let length = self.length();
        let rings = ((length - self.axial_offset) / self.axial_step).ceil().max(0.0) as usize + 1;
        let mut out = Vec::with_capacity(rings * (self.ring_points + 1));
        for i in 0..rings {
            let a = (self.axial_offset + i as f64 * self.axial_step).min(length);
            let radius = self.cutter.radius_at(a);
            out.push([a, 0.0, 0.0]);
            for k in 0..self.ring_points {
                let t = phase + std::f64::consts::TAU * k as f64 / self.ring_points as f64;
                out.push([a, radius * t.cos(), radius * t.sin()]);
            }
        }
        out
    }
}

/// The tool points `local` (tool frame `(axial, u, v)`) placed at `x` along the unit axis
/// `n`, with the frame of the tensor losses (`e1` from `+x` projected off `n`).
pub(crate) fn place_tool<'l>(
    x: &Point3,
    n: &Vector3,
    local: &'l [[f64; 3]],
) -> impl Iterator<Item = Point3> + 'l {
    let raw = Vector3::x() - n * n.x;
    let e1 = raw.try_normalize(1e-12).unwrap_or_else(|| n.cross(&Vector3::y()).normalize());
    let e2 = n.cross(&e1);
    let (x, n) = (*x, *n);
    local.iter().map(move |q| x + n * q[0] + e1 * q[1] + e2 * q[2])
}

/// A unit vector field `e1 ⟂ n` continuous in `n` away from `±x`, and `e2 = n × e1`.
fn frame(n: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
    let dims = n.dims();
    let device = n.device();
    let ex = Tensor::<2>::from_data(TensorData::new(vec![1.0f32, 0.0, 0.0], [1, 3]), &device).expand(dims);
    let nx = n.clone().narrow(1, 0, 1);
    let raw = ex - n.clone() * nx;
    let e1 = layer_normal(raw);
    let e2 = cross(n, e1.clone());
    (e1, e2)
}

/// The points of `tool` (rings rotated by `phase`) placed at the poses `x_world` `[n, 3]`
/// (part units) along the unit normals `normal` `[n, 3]`: `p = x + a n + u e1 + v e2`,
/// `[n * t, 3]` with pose `k / t` for row `k`, differentiable through the normals; and `t`.
pub(crate) fn tool_points(
    x_world: Tensor<2>,
    normal: Tensor<2>,
    tool: &Tool,
    phase: f64,
) -> (Tensor<2>, usize) {
    let device = x_world.device();
    let n = x_world.dims()[0];
    let local = tool.points(phase);
    let t = local.len();
    let col = |k: usize| -> Tensor<3> {
        let v: Vec<f32> = local.iter().map(|p| p[k] as f32).collect();
        Tensor::<2>::from_data(TensorData::new(v, [1, t]), &device).reshape([1, t, 1])
    };
    let (a, u, v) = (col(0), col(1), col(2));
    let (e1, e2) = frame(normal.clone());
    let lift = |d: Tensor<2>| d.reshape([n, 1, 3]);
    let p = lift(x_world) + lift(normal) * a + lift(e1) * u + lift(e2) * v; // [n, t, 3]
    (p.reshape([n * t, 3]), t)
}
