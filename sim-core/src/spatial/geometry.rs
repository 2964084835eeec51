//! Plane geometry shared by the spatial structures: axis-aligned boxes, discs, capsules
//! (swept discs) and the overlap tests the quadtrees prune with.
//!
//! Conventions: boxes are closed, discs and capsules are open. A robot that *touches* a wall
//! is therefore legal, and a shape "intersects" a box only when it overlaps the box's area.

use glam::DVec2;

/// An axis-aligned box `[min, max]` in world (or cell) coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower-left corner.
    pub min: DVec2,
    /// Upper-right corner.
    pub max: DVec2,
}

impl Aabb {
    /// A box from its two corners (in any order).
    pub fn from_corners(a: DVec2, b: DVec2) -> Self {
        Self {
            min: a.min(b),
            max: a.max(b),
        }
    }

    /// Width times height.
    pub fn area(&self) -> f64 {
        let d = self.max - self.min;
        d.x * d.y
    }

    /// Centre point.
    pub fn center(&self) -> DVec2 {
        (self.min + self.max) * 0.5
    }

    /// Squared distance from `p` to the closed box (0 inside).
    pub fn distance_squared_to(&self, p: DVec2) -> f64 {
        let q = p.clamp(self.min, self.max);
        q.distance_squared(p)
    }

    /// Whether `p` lies strictly inside.
    pub fn contains_strictly(&self, p: DVec2) -> bool {
        p.x > self.min.x && p.x < self.max.x && p.y > self.min.y && p.y < self.max.y
    }

    /// The squared distance from `p` to the farthest corner.
    pub fn farthest_corner_distance_squared(&self, p: DVec2) -> f64 {
        let dx = (p.x - self.min.x).abs().max((p.x - self.max.x).abs());
        let dy = (p.y - self.min.y).abs().max((p.y - self.max.y).abs());
        dx * dx + dy * dy
    }

    /// The four corners, counter-clockwise from `min`.
    pub fn corners(&self) -> [DVec2; 4] {
        [
            self.min,
            DVec2::new(self.max.x, self.min.y),
            self.max,
            DVec2::new(self.min.x, self.max.y),
        ]
    }

    /// Whether the open interiors of two boxes overlap.
    pub fn overlaps_open(&self, other: &Aabb) -> bool {
        self.min.x < other.max.x && other.min.x < self.max.x && self.min.y < other.max.y && other.min.y < self.max.y
    }

    /// Whether `other` lies inside `self` (closed).
    pub fn contains_box(&self, other: &Aabb) -> bool {
        self.min.x <= other.min.x && self.min.y <= other.min.y && other.max.x <= self.max.x && other.max.y <= self.max.y
    }
}

/// How a shape relates to a box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Overlap {
    /// No common area.
    Disjoint,
    /// Some common area, but the box is not inside the shape.
    Partial,
    /// The whole box lies inside the shape.
    Contains,
}

/// A region of the plane the quadtrees can test boxes against.
pub trait Shape {
    /// How the shape relates to the closed box `b`.
    fn classify(&self, b: &Aabb) -> Overlap;
    /// Whether the shape and the box share some area (the cheap half of `classify`).
    #[inline]
    fn intersects(&self, b: &Aabb) -> bool {
        self.classify(b) != Overlap::Disjoint
    }
    /// A box enclosing the shape.
    fn bounds(&self) -> Aabb;
}

impl<S: Shape + ?Sized> Shape for &S {
    fn classify(&self, b: &Aabb) -> Overlap {
        (**self).classify(b)
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn intersects(&self, b: &Aabb) -> bool {
        (**self).intersects(b)
    }
}

/// An open disc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    /// Centre.
    pub center: DVec2,
    /// Radius (≥ 0).
    pub radius: f64,
}

impl Shape for Disc {
    #[inline]
    fn intersects(&self, b: &Aabb) -> bool {
        b.distance_squared_to(self.center) < self.radius * self.radius
    }

    #[inline]
    fn classify(&self, b: &Aabb) -> Overlap {
        let r2 = self.radius * self.radius;
        if b.distance_squared_to(self.center) >= r2 {
            Overlap::Disjoint
        } else if b.farthest_corner_distance_squared(self.center) <= r2 {
            Overlap::Contains
        } else {
            Overlap::Partial
        }
    }

    fn bounds(&self) -> Aabb {
        let r = DVec2::splat(self.radius);
        Aabb {
            min: self.center - r,
            max: self.center + r,
        }
    }
}

impl Shape for Aabb {
    fn classify(&self, b: &Aabb) -> Overlap {
        if !self.overlaps_open(b) {
            Overlap::Disjoint
        } else if self.contains_box(b) {
            Overlap::Contains
        } else {
            Overlap::Partial
        }
    }

    fn bounds(&self) -> Aabb {
        *self
    }
}

/// The open region swept by a disc of `radius` moving from `a` to `b` (a capsule). With
/// radius 0 it is the segment itself, which overlaps a box when it passes through the box's
/// interior (grazing an edge or a corner does not count).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    /// Start of the axis.
    pub a: DVec2,
    /// End of the axis.
    pub b: DVec2,
    /// Radius (≥ 0).
    pub radius: f64,
}

impl Shape for Capsule {
    fn classify(&self, b: &Aabb) -> Overlap {
        if self.radius <= 0.0 {
            return if segment_enters_box_interior(self.a, self.b, b) {
                Overlap::Partial
            } else {
                Overlap::Disjoint
            };
        }
        let r2 = self.radius * self.radius;
        if segment_box_distance_squared(self.a, self.b, b) >= r2 {
            Overlap::Disjoint
        } else if b
            .corners()
            .iter()
            .all(|&c| point_segment_distance_squared(c, self.a, self.b) <= r2)
        {
            // A capsule is convex: it holds the box when it holds the corners.
            Overlap::Contains
        } else {
            Overlap::Partial
        }
    }

    fn bounds(&self) -> Aabb {
        let r = DVec2::splat(self.radius);
        Aabb {
            min: self.a.min(self.b) - r,
            max: self.a.max(self.b) + r,
        }
    }
}

/// The part of `disc` not wholly inside `seen`, for marking a view that moved: squares
/// lying wholly inside the disc seen last time were marked then (known maps only grow), so
/// they count as disjoint and the quadtree descent skips them (issue 11: half the disc's
/// rim need not be walked again each round).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiscBeyond {
    /// The view now.
    pub disc: Disc,
    /// The view marked last time, if any.
    pub seen: Option<Disc>,
}

impl DiscBeyond {
    fn inside_seen(&self, b: &Aabb) -> bool {
        self.seen
            .is_some_and(|s| b.farthest_corner_distance_squared(s.center) <= s.radius * s.radius)
    }
}

impl Shape for DiscBeyond {
    #[inline]
    fn intersects(&self, b: &Aabb) -> bool {
        !self.inside_seen(b) && self.disc.intersects(b)
    }

    #[inline]
    fn classify(&self, b: &Aabb) -> Overlap {
        match self.disc.classify(b) {
            Overlap::Disjoint => Overlap::Disjoint,
            _ if self.inside_seen(b) => Overlap::Disjoint,
            other => other,
        }
    }

    fn bounds(&self) -> Aabb {
        self.disc.bounds()
    }
}

/// The intersection of two shapes (used to clip a shape to the map's extent).
#[derive(Clone, Copy, Debug)]
pub struct Clipped<S> {
    /// The shape.
    pub shape: S,
    /// The clip box.
    pub clip: Aabb,
}

impl<S: Shape> Shape for Clipped<S> {
    fn classify(&self, b: &Aabb) -> Overlap {
        match (self.clip.classify(b), self.shape.classify(b)) {
            (Overlap::Disjoint, _) | (_, Overlap::Disjoint) => Overlap::Disjoint,
            (Overlap::Contains, Overlap::Contains) => Overlap::Contains,
            _ => Overlap::Partial,
        }
    }

    fn bounds(&self) -> Aabb {
        let s = self.shape.bounds();
        Aabb {
            min: s.min.max(self.clip.min),
            max: s.max.min(self.clip.max).max(s.min.max(self.clip.min)),
        }
    }
}

/// Squared distance from `p` to the segment `ab`.
pub fn point_segment_distance_squared(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t).distance_squared(p)
}

/// The parameter interval `[t0, t1]` ⊆ `[0, 1]` of the segment `a + t (b - a)` inside the
/// closed box, or `None` (Liang–Barsky clipping).
pub fn clip_segment(a: DVec2, b: DVec2, bx: &Aabb) -> Option<(f64, f64)> {
    clip_line(a, b - a, 0.0, 1.0, bx)
}

/// Clip the line `origin + t * dir` for `t ∈ [t0, t1]` against a closed box.
pub fn clip_line(origin: DVec2, dir: DVec2, mut t0: f64, mut t1: f64, bx: &Aabb) -> Option<(f64, f64)> {
    for axis in 0..2 {
        let (o, d, lo, hi) = (origin[axis], dir[axis], bx.min[axis], bx.max[axis]);
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
        } else {
            let inv = 1.0 / d;
            let (mut ta, mut tb) = ((lo - o) * inv, (hi - o) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return None;
            }
        }
    }
    Some((t0, t1))
}

/// Whether the segment `ab` passes through the open interior of the box.
pub fn segment_enters_box_interior(a: DVec2, b: DVec2, bx: &Aabb) -> bool {
    // The chord cut out by a convex box lies on its boundary only when it runs along an edge
    // or touches a corner; otherwise its midpoint is interior.
    clip_segment(a, b, bx).is_some_and(|(t0, t1)| bx.contains_strictly(a + (b - a) * (0.5 * (t0 + t1))))
}

/// Squared distance between the segment `ab` and the closed box (0 when they meet).
pub fn segment_box_distance_squared(a: DVec2, b: DVec2, bx: &Aabb) -> f64 {
    if clip_segment(a, b, bx).is_some() {
        return 0.0;
    }
    // Two disjoint convex sets in the plane are closest at a vertex of one of them.
    let from_ends = bx.distance_squared_to(a).min(bx.distance_squared_to(b));
    bx.corners()
        .iter()
        .map(|&c| point_segment_distance_squared(c, a, b))
        .fold(from_ends, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::from_corners(DVec2::ZERO, DVec2::ONE)
    }

    #[test]
    fn disc_classification_by_hand() {
        let d = |x, y, r| Disc {
            center: DVec2::new(x, y),
            radius: r,
        };
        // Touching the right edge from outside: open disc, no common area.
        assert_eq!(d(2.0, 0.5, 1.0).classify(&unit()), Overlap::Disjoint);
        assert_eq!(d(1.9, 0.5, 1.0).classify(&unit()), Overlap::Partial);
        // Farthest corner of the unit box from its centre is sqrt(0.5) ≈ 0.7071 away.
        assert_eq!(d(0.5, 0.5, 0.70).classify(&unit()), Overlap::Partial);
        assert_eq!(d(0.5, 0.5, 0.71).classify(&unit()), Overlap::Contains);
        // Near a corner: distance to (1,1) from (1.6,1.8) is 1.0.
        assert_eq!(d(1.6, 1.8, 1.0).classify(&unit()), Overlap::Disjoint);
        assert_eq!(d(1.6, 1.8, 1.01).classify(&unit()), Overlap::Partial);
    }

    #[test]
    fn segment_interior_by_hand() {
        let b = unit();
        let p = DVec2::new;
        assert!(segment_enters_box_interior(p(-1.0, 0.5), p(2.0, 0.5), &b));
        // Along the bottom edge, through a corner, ending on the boundary: no interior.
        assert!(!segment_enters_box_interior(p(-1.0, 0.0), p(2.0, 0.0), &b));
        assert!(!segment_enters_box_interior(p(-1.0, 1.0), p(1.0, -1.0), &b));
        assert!(!segment_enters_box_interior(p(-1.0, 2.0), p(0.0, 1.0), &b));
        // The diagonal crosses the interior.
        assert!(segment_enters_box_interior(p(-1.0, 2.0), p(1.0, 0.0), &b));
        assert!(!segment_enters_box_interior(p(-1.0, 0.5), p(0.0, 0.5), &b));
        // Starting inside.
        assert!(segment_enters_box_interior(p(0.5, 0.5), p(0.5, 0.5), &b));
    }

    #[test]
    fn capsule_distance_by_hand() {
        let b = unit();
        let p = DVec2::new;
        // A horizontal segment 2 above the box: distance 1 from the top edge.
        let d2 = segment_box_distance_squared(p(-3.0, 2.0), p(3.0, 2.0), &b);
        assert!((d2 - 1.0).abs() < 1e-12);
        // A diagonal segment passing the corner (1,1) at distance sqrt(2)/2.
        let d2 = segment_box_distance_squared(p(1.0, 2.0), p(2.0, 1.0), &b);
        assert!((d2 - 0.5).abs() < 1e-12);
        let c = Capsule {
            a: p(1.0, 2.0),
            b: p(2.0, 1.0),
            radius: 0.70,
        };
        assert_eq!(c.classify(&b), Overlap::Disjoint);
        let c = Capsule { radius: 0.71, ..c };
        assert_eq!(c.classify(&b), Overlap::Partial);
        let c = Capsule {
            a: p(-5.0, 0.5),
            b: p(5.0, 0.5),
            radius: 0.8,
        };
        assert_eq!(c.classify(&b), Overlap::Contains);
    }
}
