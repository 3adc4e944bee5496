//! Axis-aligned boxes with closed-interval tests (touching boxes overlap), the BVH's bounds.

use nalgebra::{Point3, Vector3};

/// The lower of `a` and `b`, `a` when `b` is NaN (as `f64::min`, in one instruction where
/// `f64::min`, which also passes over a NaN `a`, takes several).
#[inline]
fn lower(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// The higher of `a` and `b`, `a` when `b` is NaN.
#[inline]
fn upper(a: f64, b: f64) -> f64 {
    if b > a {
        b
    } else {
        a
    }
}

/// An axis-aligned box, `min <= max` componentwise when not empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Point3<f64>,
    /// Upper corner.
    pub max: Point3<f64>,
}

impl Aabb {
    /// The empty box (union identity).
    pub const EMPTY: Aabb = Aabb {
        min: Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
        max: Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
    };

    /// Exact bounding box of a triangle.
    pub fn of_triangle(p: [&Point3<f64>; 3]) -> Aabb {
        Aabb::EMPTY.grown(p[0]).grown(p[1]).grown(p[2])
    }

    /// Smallest box containing both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: Point3::from(std::array::from_fn(|i| lower(self.min[i], other.min[i]))),
            max: Point3::from(std::array::from_fn(|i| upper(self.max[i], other.max[i]))),
        }
    }

    /// The box grown to hold `p`.
    #[inline]
    pub(crate) fn grown(&self, p: &Point3<f64>) -> Aabb {
        Aabb {
            min: Point3::from(std::array::from_fn(|i| lower(self.min[i], p[i]))),
            max: Point3::from(std::array::from_fn(|i| upper(self.max[i], p[i]))),
        }
    }

    /// The box, or the empty box when it is a point (`min == max`). Chosen coordinate by
    /// coordinate: chosen as a whole, the two boxes went through memory and the box's reads
    /// waited for its writes (a load spanning two stores is not forwarded).
    #[inline]
    pub(super) fn empty_if_point(&self) -> Aabb {
        let point =
            (self.min.x == self.max.x) & (self.min.y == self.max.y) & (self.min.z == self.max.z);
        let or_empty = |c: f64, empty: f64| if point { empty } else { c };
        Aabb {
            min: self.min.map(|c| or_empty(c, f64::INFINITY)),
            max: self.max.map(|c| or_empty(c, f64::NEG_INFINITY)),
        }
    }

    /// Closed-interval overlap test (touching boxes overlap).
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.min.x <= other.max.x
            && other.min.x <= self.max.x
            && self.min.y <= other.max.y
            && other.min.y <= self.max.y
            && self.min.z <= other.max.z
            && other.min.z <= self.max.z
    }

    /// Whether `p` lies in the closed box (never in an empty one).
    #[inline]
    pub(crate) fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|k| self.min[k] <= p[k] && p[k] <= self.max[k])
    }

    /// Whether the box holds no point (e.g. [`Aabb::EMPTY`]).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Half the surface area (the SAH cost weight); 0 for an empty box.
    pub(super) fn half_area(&self) -> f64 {
        let d = self.max - self.min;
        if d.iter().any(|x| *x < 0.0) {
            return 0.0;
        }
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// Parameter interval `[t0, t1]` of the ray `origin + t dir` inside the box (conservative:
    /// widened by a few ulps), or `None`.
    pub fn ray_interval(&self, origin: &Point3<f64>, inv_dir: &Vector3<f64>) -> Option<(f64, f64)> {
        if self.is_empty() {
            return None;
        }
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..3 {
            if inv_dir[k].is_infinite() {
                // Ray parallel to the slab.
                if origin[k] < self.min[k] || origin[k] > self.max[k] {
                    return None;
                }
                continue;
            }
            let a = (self.min[k] - origin[k]) * inv_dir[k];
            let b = (self.max[k] - origin[k]) * inv_dir[k];
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        // Ize 2013: widen the far bound to cover the rounding of the slab distances.
        let slack = 4.0 * f64::EPSILON;
        let (t0, t1) = (t0 - slack * t0.abs(), t1 + slack * t1.abs());
        (t0 <= t1).then_some((t0, t1))
    }
}
