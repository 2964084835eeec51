//! Obstacle shapes (parry2d) and their conservative rasterisation into a quadtree.
//!
//! A cell is blocked when a shape touches it: when the shape intersects the cell's square
//! shrunk by [`TOUCH_EPS`] cells on every side (so a shape whose edge runs exactly along a
//! cell border does not block the neighbouring cell). parry2d works in `f32`, so every test
//! is done in the shape's own frame, relative to its centre (small numbers, ~10 µm error).
//!
//! Shapes are kept in a bucket grid; the quadtree is built top-down with
//! [`ObstacleMap::from_regions`], asking each square which shapes' boxes it meets: squares
//! without shapes are empty at once, squares inside a convex shape are full at once, and only
//! squares on shape boundaries are split down to cells. No raster of the map is ever made.

use parry2d::math::{Pose, Vector};
use parry2d::query::intersection_test;
use parry2d::shape::{Cuboid, SharedShape};
use sim_core::glam::DVec2;
use sim_core::spatial::Aabb;
use sim_core::spatial::Region;
use sim_core::spatial::Square;
use sim_core::spatial::{Grid, ObstacleMap};

use crate::progress::Progress;

/// How far (in cells) a cell's square is shrunk before the touch test.
pub const TOUCH_EPS: f64 = 1e-4;

/// One obstacle: a parry2d shape, rotated by `rotation` about the origin of its own frame and
/// placed at `center`.
#[derive(Clone)]
pub struct Obstacle {
    shape: SharedShape,
    center: DVec2,
    rotation: f64,
    convex: bool,
    bounds: Aabb,
}

impl std::fmt::Debug for Obstacle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Obstacle")
            .field("center", &self.center)
            .field("rotation", &self.rotation)
            .field("bounds", &self.bounds)
            .finish_non_exhaustive()
    }
}

fn v(p: DVec2) -> Vector {
    Vector::new(p.x as f32, p.y as f32)
}

/// Signed area (counter-clockwise positive) of a polygon.
pub fn polygon_area(points: &[DVec2]) -> f64 {
    let n = points.len();
    (0..n).map(|i| points[i].perp_dot(points[(i + 1) % n])).sum::<f64>() / 2.0
}

fn is_convex(points: &[DVec2]) -> bool {
    let n = points.len();
    let mut sign = 0.0f64;
    for i in 0..n {
        let (a, b, c) = (points[i], points[(i + 1) % n], points[(i + 2) % n]);
        let cross = (b - a).perp_dot(c - b);
        if cross.abs() < 1e-12 {
            continue;
        }
        if sign == 0.0 {
            sign = cross.signum();
        } else if cross * sign < 0.0 {
            return false;
        }
    }
    true
}

/// Triangulate a simple polygon (counter-clockwise) by ear clipping.
fn ear_clip(points: &[DVec2]) -> Option<Vec<[DVec2; 3]>> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    let mut tris = Vec::new();
    let mut guard = 0;
    while idx.len() > 3 {
        guard += 1;
        if guard > 10 * points.len() * points.len() {
            return None;
        }
        let n = idx.len();
        let mut clipped = false;
        for i in 0..n {
            let (a, b, c) = (points[idx[(i + n - 1) % n]], points[idx[i]], points[idx[(i + 1) % n]]);
            if (b - a).perp_dot(c - b) <= 0.0 {
                continue; // reflex
            }
            let inside = idx.iter().any(|&k| {
                let p = points[k];
                if p == a || p == b || p == c {
                    return false;
                }
                (b - a).perp_dot(p - a) >= 0.0 && (c - b).perp_dot(p - b) >= 0.0 && (a - c).perp_dot(p - c) >= 0.0
            });
            if !inside {
                tris.push([a, b, c]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            return None;
        }
    }
    tris.push([points[idx[0]], points[idx[1]], points[idx[2]]]);
    Some(tris)
}

impl Obstacle {
    fn new(shape: SharedShape, center: DVec2, rotation: f64, convex: bool) -> Self {
        let aabb = shape.compute_aabb(&Pose::rotation(rotation as f32));
        let pad = 1e-3 + 1e-6 * center.abs().max_element();
        let bounds = Aabb {
            min: center + DVec2::new(f64::from(aabb.mins.x), f64::from(aabb.mins.y)) - pad,
            max: center + DVec2::new(f64::from(aabb.maxs.x), f64::from(aabb.maxs.y)) + pad,
        };
        Self {
            shape,
            center,
            rotation,
            convex,
            bounds,
        }
    }

    /// A disc.
    pub fn disc(center: DVec2, radius: f64) -> Option<Self> {
        (radius.is_finite() && radius > 0.0 && center.is_finite())
            .then(|| Self::new(SharedShape::ball(radius as f32), center, 0.0, true))
    }

    /// A rectangle of `width × height` centred on `center`, rotated by `rotation` radians.
    pub fn rect(center: DVec2, width: f64, height: f64, rotation: f64) -> Option<Self> {
        (width > 0.0 && height > 0.0 && width.is_finite() && height.is_finite() && center.is_finite()).then(|| {
            Self::new(
                SharedShape::cuboid((width / 2.0) as f32, (height / 2.0) as f32),
                center,
                rotation,
                true,
            )
        })
    }

    /// A capsule: the segment `a → b` thickened by `radius`.
    pub fn capsule(a: DVec2, b: DVec2, radius: f64) -> Option<Self> {
        if !(radius > 0.0 && radius.is_finite() && a.is_finite() && b.is_finite()) {
            return None;
        }
        let c = (a + b) / 2.0;
        Some(Self::new(
            SharedShape::capsule(v(a - c), v(b - c), radius as f32),
            c,
            0.0,
            true,
        ))
    }

    /// A simple polygon with vertices `points` (relative to `center`, either orientation),
    /// rotated by `rotation` radians about `center`. Non-convex polygons are triangulated.
    pub fn polygon(center: DVec2, points: &[DVec2], rotation: f64) -> Option<Self> {
        if points.len() < 3 || !center.is_finite() || points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let mut pts = points.to_vec();
        let area = polygon_area(&pts);
        if area.abs() < 1e-12 {
            return None;
        }
        if area < 0.0 {
            pts.reverse();
        }
        if is_convex(&pts) {
            let vs: Vec<Vector> = pts.iter().map(|&p| v(p)).collect();
            let shape = SharedShape::convex_polyline(vs).or_else(|| {
                let vs: Vec<Vector> = pts.iter().map(|&p| v(p)).collect();
                SharedShape::convex_hull(&vs)
            })?;
            Some(Self::new(shape, center, rotation, true))
        } else {
            let tris = ear_clip(&pts)?;
            let parts = tris
                .into_iter()
                .map(|[a, b, c]| (Pose::identity(), SharedShape::triangle(v(a), v(b), v(c))))
                .collect();
            Some(Self::new(SharedShape::compound(parts), center, rotation, false))
        }
    }

    /// The convex hull of `points` (relative to `center`), rotated by `rotation` radians.
    pub fn convex_hull(center: DVec2, points: &[DVec2], rotation: f64) -> Option<Self> {
        let vs: Vec<Vector> = points.iter().map(|&p| v(p)).collect();
        let shape = SharedShape::convex_hull(&vs)?;
        center.is_finite().then(|| Self::new(shape, center, rotation, true))
    }

    /// World bounding box (slightly padded).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The parry2d shape, in its own frame.
    pub fn shape(&self) -> &SharedShape {
        &self.shape
    }

    /// Pose of the shape relative to a frame whose origin is `frame_origin`.
    pub fn pose_from(&self, frame_origin: DVec2) -> Pose {
        let d = self.center - frame_origin;
        Pose::new(Vector::new(d.x as f32, d.y as f32), self.rotation as f32)
    }

    /// Whether the shape intersects the closed box `b` (already shrunk by the caller).
    pub fn touches(&self, b: &Aabb) -> bool {
        if !(b.min.x <= self.bounds.max.x
            && b.max.x >= self.bounds.min.x
            && b.min.y <= self.bounds.max.y
            && b.max.y >= self.bounds.min.y)
        {
            return false;
        }
        let c = b.center();
        let half = (b.max - b.min) / 2.0;
        let cuboid = Cuboid::new(Vector::new(half.x as f32, half.y as f32));
        let rel = self.center - c;
        intersection_test(
            &Pose::identity(),
            &cuboid,
            &Pose::new(Vector::new(rel.x as f32, rel.y as f32), self.rotation as f32),
            self.shape.as_ref(),
        )
        .map_or(true, |r| r.intersecting)
    }

    /// Whether the shape covers the whole box `b` (only answered for convex shapes).
    pub fn contains_box(&self, b: &Aabb) -> bool {
        if !self.convex || !self.bounds.contains_box(b) {
            return false;
        }
        let pose = Pose::rotation(self.rotation as f32);
        b.corners()
            .iter()
            .all(|&p| self.shape.contains_point(&pose, v(p - self.center)))
    }

    /// Whether world point `p` lies in the shape.
    pub fn contains_point(&self, p: DVec2) -> bool {
        self.shape
            .contains_point(&Pose::rotation(self.rotation as f32), v(p - self.center))
    }
}

/// Shapes bucketed on a grid of `2^level`-cell squares.
#[derive(Debug)]
pub struct ShapeSet {
    grid: Grid,
    shapes: Vec<Obstacle>,
    level: u8,
    side: u32,
    buckets: Vec<Vec<u32>>,
    /// 2-D prefix sums of bucket occupancy, `(side+1)²`.
    prefix: Vec<u32>,
}

impl ShapeSet {
    /// Bucket `shapes` over `grid`.
    pub fn new(grid: Grid, shapes: Vec<Obstacle>) -> Self {
        let level = grid.depth().min(8);
        let side = grid.side_cells() >> level;
        let mut buckets = vec![Vec::new(); side as usize * side as usize];
        let bucket_m = f64::from(1u32 << level) * grid.cell_m();
        let o = grid.origin();
        for (i, s) in shapes.iter().enumerate() {
            let b = s.bounds();
            let lo = ((b.min - o) / bucket_m).floor();
            let hi = ((b.max - o) / bucket_m).floor();
            let clamp = |t: f64| t.clamp(0.0, f64::from(side - 1)) as u32;
            if hi.x < 0.0 || hi.y < 0.0 || lo.x >= f64::from(side) || lo.y >= f64::from(side) {
                continue;
            }
            for by in clamp(lo.y)..=clamp(hi.y) {
                for bx in clamp(lo.x)..=clamp(hi.x) {
                    buckets[(by * side + bx) as usize].push(i as u32);
                }
            }
        }
        let n = side as usize + 1;
        let mut prefix = vec![0u32; n * n];
        for y in 0..side as usize {
            for x in 0..side as usize {
                let here = u32::from(!buckets[y * side as usize + x].is_empty());
                prefix[(y + 1) * n + x + 1] =
                    here + prefix[y * n + x + 1] + prefix[(y + 1) * n + x] - prefix[y * n + x];
            }
        }
        Self {
            grid,
            shapes,
            level,
            side,
            buckets,
            prefix,
        }
    }

    /// The shapes.
    pub fn shapes(&self) -> &[Obstacle] {
        &self.shapes
    }

    fn occupied_buckets(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> u32 {
        let n = self.side as usize + 1;
        let (x0, y0, x1, y1) = (x0 as usize, y0 as usize, x1 as usize, y1 as usize);
        self.prefix[y1 * n + x1] + self.prefix[y0 * n + x0] - self.prefix[y0 * n + x1] - self.prefix[y1 * n + x0]
    }

    /// Classify a square of cells against the shapes.
    pub fn classify(&self, sq: Square) -> Region {
        if sq.level > self.level {
            let d = sq.level - self.level;
            let (bx, by) = (sq.x >> self.level, sq.y >> self.level);
            let n = 1u32 << d;
            return if self.occupied_buckets(bx, by, bx + n, by + n) == 0 {
                Region::Empty
            } else {
                Region::Mixed
            };
        }
        let bucket = &self.buckets[((sq.y >> self.level) * self.side + (sq.x >> self.level)) as usize];
        if bucket.is_empty() {
            return Region::Empty;
        }
        let b = self.grid.square(sq.x, sq.y, sq.level);
        let eps = TOUCH_EPS * self.grid.cell_m();
        let shrunk = Aabb {
            min: b.min + eps,
            max: b.max - eps,
        };
        let mut mixed = false;
        for &i in bucket {
            let s = &self.shapes[i as usize];
            if s.touches(&shrunk) {
                if s.contains_box(&b) {
                    return Region::Full;
                }
                mixed = true;
            }
        }
        if mixed { Region::Mixed } else { Region::Empty }
    }

    /// Rasterise into an obstacle map (top-down, block by block), counting cells on `progress`.
    pub fn rasterise(&self, progress: &mut Progress) -> ObstacleMap {
        ObstacleMap::from_regions(self.grid, |sq| {
            let r = self.classify(sq);
            if r != Region::Mixed || sq.level == 0 {
                progress.inc(sq.cells());
            }
            r
        })
    }
}
