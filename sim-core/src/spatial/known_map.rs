//! A robot's knowledge of the terrain: a region quadtree where `1` = explored (paper §4.2).
//!
//! Only *which* cells are known is stored; what is in them is read from the kernel's
//! [`ObstacleMap`] on demand, never copied.

use std::cell::RefCell;

use glam::DVec2;

use crate::spatial::geometry::{Aabb, CellRows, Clipped, Disc, DiscBeyond, Shape};
use crate::spatial::grid::Grid;
use crate::spatial::known_window::{self, KnownWindow};
use crate::spatial::obstacle_map::ObstacleMap;
use crate::spatial::quadtree::RegionQuadtree;
use crate::spatial::quadtree::{CellSet, Finger, PartialCells};
use crate::spatial::view_stencil::{Stencils, ViewStencil};

thread_local! {
    /// The rows of a view being marked, in a buffer kept from call to call so that none is
    /// zeroed per view, and the stencils of the views this thread marks.
    static VIEW: RefCell<(CellRows, Stencils)> = RefCell::new((CellRows::empty(), Stencils::default()));
}

/// The explored part of the map, as seen by one robot (or a team).
#[derive(Debug, serde::Serialize, serde::Deserialize)]
pub struct KnownMap {
    tree: RegionQuadtree,
    /// Cells known, kept up to date by every mutation (maps only grow).
    known_cells: u64,
    /// The view disc [`mark_view`](Self::mark_view) marked last: all it holds is known.
    last_view: Option<Disc>,
    /// Known cells around the views marked through it (a part of the tree's: see
    /// [`KnownWindow`]; checked by [`validate`](Self::validate)). Not saved: a restored map
    /// starts without.
    #[serde(skip)]
    window: Option<Box<KnownWindow>>,
}

/// A copy without the window: copies are mostly maps sent to others, who never mark views
/// in them (and a copy that does loads its own).
impl Clone for KnownMap {
    fn clone(&self) -> Self {
        Self {
            tree: self.tree.clone(),
            known_cells: self.known_cells,
            last_view: self.last_view,
            window: None,
        }
    }
}

impl KnownMap {
    /// Nothing known yet.
    pub fn new(grid: Grid) -> Self {
        Self {
            tree: RegionQuadtree::uniform(grid, false),
            known_cells: 0,
            last_view: None,
            window: None,
        }
    }

    /// Wrap a tree whose `FULL` leaves are known space.
    pub fn from_tree(tree: RegionQuadtree) -> Self {
        let known_cells = tree.count_cells(true);
        Self {
            tree,
            known_cells,
            last_view: None,
            window: None,
        }
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        self.tree.grid()
    }

    /// The underlying quadtree.
    pub fn tree(&self) -> &RegionQuadtree {
        &self.tree
    }

    /// Mark as known every map cell lying wholly inside the disc (a conservative raster: a
    /// robot never claims to know a cell it has only partly seen). Returns whether anything
    /// new became known.
    pub fn mark_disc(&mut self, center: DVec2, radius_m: f64) -> bool {
        self.mark(&Disc {
            center,
            radius: radius_m,
        })
    }

    /// [`mark_disc`](Self::mark_disc) for a robot's view, which moves a little each round:
    /// squares wholly inside the view this map marked last time are skipped, as they are
    /// known already (maps only grow). Same result as `mark_disc`, less work; checked by
    /// `moving_views_mark_exactly_what_whole_discs_mark`.
    pub fn mark_view(&mut self, center: DVec2, radius_m: f64) -> bool {
        self.mark_view_reporting(center, radius_m, |_| {})
    }

    /// [`mark_view`](Self::mark_view), calling `newly_known` with the cells that became
    /// known.
    pub fn mark_view_reporting(&mut self, center: DVec2, radius_m: f64, mut newly_known: impl FnMut(CellSet)) -> bool {
        let disc = Disc {
            center,
            radius: radius_m,
        };
        let before = self.known_cells;
        // The same view as last time (a robot that did not move): all it holds is known.
        if self.last_view == Some(disc) {
            return false;
        }
        // The window sits in an allocation of its own, most likely out of the processor's
        // caches by the time the robot's turn comes round again: fetched while the view's
        // rows are worked out.
        if let Some(window) = &self.window {
            window.prefetch();
        }
        let by_rows = VIEW.with_borrow_mut(|(rows, stencils)| {
            let stencil = stencils.get(radius_m, self.grid().cell_m());
            self.mark_view_rows(&disc, stencil, rows, &mut newly_known)
        });
        if !by_rows {
            // Bigger views walk the tree, skipping what the last view marked.
            let beyond = DiscBeyond {
                disc,
                seen: self.last_view,
            };
            self.mark_reporting(&beyond, |sq| newly_known(CellSet::whole(sq)));
        }
        self.last_view = Some(disc);
        self.known_cells > before
    }

    /// Mark a view of at most 60 cells across by its rows of cells (worked out at once, then
    /// set by one descent per block): through the window of known cells when the view is at
    /// most [`known_window::MAX_VIEW_CELLS`] across, otherwise directly. `false` (nothing
    /// done) for a bigger view or a tree without blocks.
    fn mark_view_rows(
        &mut self,
        disc: &Disc,
        stencil: Option<&ViewStencil>,
        rows: &mut CellRows,
        newly_known: &mut impl FnMut(CellSet),
    ) -> bool {
        let grid = *self.tree.grid();
        let clip = grid.extent();
        let mut added = 0;
        let mut report = |set: CellSet| {
            added += set.cells();
            newly_known(set);
        };
        let marked = if let Some(stencil) = stencil
            && KnownWindow::fits(&self.tree)
            && let Some(view) = stencil.place(disc, &grid, &clip)
            && let (lo, hi) = view.cells()
            && hi.0 - lo.0 < known_window::MAX_VIEW_CELLS
            && hi.1 - lo.1 < known_window::MAX_VIEW_CELLS
        {
            // Its cells not known yet, left out through the window as its rows are made:
            // most views of a walker add none.
            let window = self.window.get_or_insert_default();
            window.cover(&self.tree, lo, hi);
            if view.rows_except_into(&grid, Some(window.known_rows()), rows)
                && let new = &rows.rows[..rows.len]
                && new.iter().any(|&row| row != 0)
            {
                let filled = self.tree.fill_new_rows_reporting(rows, true, &mut report);
                debug_assert!(filled, "a tree the window fits is packed");
                window.add_rows(rows.x0, rows.y0, new);
            }
            true
        } else {
            (stencil.is_some_and(|stencil| stencil.rows_into(disc, &grid, &clip, rows))
                || disc.contained_rows_into(&grid, &clip, rows))
                && self.tree.fill_new_rows_reporting(rows, true, &mut report)
        };
        self.known_cells += added;
        marked
    }

    /// Mark as known every map cell lying wholly inside `shape`.
    pub fn mark<S: Shape>(&mut self, shape: &S) -> bool {
        let before = self.known_cells;
        self.mark_reporting(shape, |_| {});
        self.known_cells > before
    }

    /// Mark the cells of `set` known, reporting those that became known: what
    /// [`mark_reporting`](Self::mark_reporting) does with them, by one descent along the
    /// square's coordinates (the square must lie inside the map; whole squares that do not
    /// take the general path). Returns the block's known cells after (Z order) for a set of
    /// some of a block's cells (see `spatial::BlockMemo`).
    pub fn mark_cells_reporting(&mut self, set: CellSet, mut newly_known: impl FnMut(CellSet)) -> Option<u64> {
        let sq = set.square();
        let square = self.grid().square(sq.x, sq.y, sq.level);
        if set.is_whole() && !self.grid().extent().contains_box(&square) {
            self.mark_reporting(&square, |sq| newly_known(CellSet::whole(sq)));
            return None;
        }
        let mut added = 0;
        let after = self.tree.fill_cells_reporting(set, true, |set| {
            added += set.cells();
            newly_known(set);
        });
        self.known_cells += added;
        after
    }

    /// [`mark`](Self::mark), calling `newly_known` with the squares that became known.
    pub fn mark_reporting<S: Shape>(
        &mut self,
        shape: &S,
        mut newly_known: impl FnMut(crate::spatial::quadtree::Square),
    ) {
        let clip = self.grid().extent();
        let mut added = 0;
        let mut report = |sq: crate::spatial::quadtree::Square| {
            added += sq.cells();
            newly_known(sq);
        };
        // Clipping costs a box test at every node; most shapes lie inside the map anyway.
        if clip.contains_box(&shape.bounds()) {
            self.tree
                .fill_reporting(shape, true, PartialCells::Exclude, &mut report);
        } else {
            self.tree
                .fill_reporting(&Clipped { shape, clip }, true, PartialCells::Exclude, &mut report);
        }
        self.known_cells += added;
    }

    /// Whether [`mark`](Self::mark) of `shape` could mark anything: an unknown cell of the
    /// map overlaps it. Conservative (a cell the shape covers only in part counts, though
    /// `mark` leaves it); read-only, so views can be sorted out on all workers before
    /// they are marked one by one.
    pub fn may_mark<S: Shape>(&self, shape: &S) -> bool {
        let clip = self.grid().extent();
        if clip.contains_box(&shape.bounds()) {
            self.tree.any_leaf_in(shape, false)
        } else {
            self.tree.any_leaf_in(&Clipped { shape, clip }, false)
        }
    }

    /// The part (0 to 1) of the disc of `radius_m` round `center` that is known, sampled at
    /// the points of a 9 × 9 lattice over the disc's box that lie in the disc and strictly
    /// inside the map (1 when none does). Cost: up to 69 point queries, each a descent of the
    /// tree. An estimate for ranking targets, not an area: thin strips between lattice
    /// points go unseen.
    pub fn known_fraction_near(&self, center: DVec2, radius_m: f64) -> f64 {
        let extent = self.grid().extent();
        let (mut inside, mut known) = (0u32, 0u32);
        for i in -4i32..=4 {
            for j in -4i32..=4 {
                let q = center + DVec2::new(f64::from(i), f64::from(j)) * (radius_m / 4.0);
                if q.distance_squared(center) <= radius_m * radius_m && extent.contains_strictly(q) {
                    inside += 1;
                    known += u32::from(self.is_known(q));
                }
            }
        }
        if inside == 0 {
            1.0
        } else {
            f64::from(known) / f64::from(inside)
        }
    }

    /// Whether the cell holding `p` is known (false outside the map).
    pub fn is_known(&self, p: DVec2) -> bool {
        self.tree.value_at(p) == Some(true)
    }

    /// Whether every cell overlapping the box's interior is known.
    pub fn is_box_known(&self, area: &Aabb) -> bool {
        self.tree.all_in(area, true)
    }

    /// Whether some cell of a grid square is known (one descent; see
    /// [`RegionQuadtree::square_value`]).
    #[inline]
    pub fn touches_square(&self, sq: crate::spatial::quadtree::Square) -> bool {
        self.tree.square_value(sq) != Some(false)
    }

    /// Whether every cell of a grid square is known.
    #[inline]
    pub fn covers_square(&self, sq: crate::spatial::quadtree::Square) -> bool {
        self.tree.square_value(sq) == Some(true)
    }

    /// Whether some cell of the cell rectangle `lo ..= hi` is known.
    #[inline]
    pub fn touches_cells(&self, lo: (u32, u32), hi: (u32, u32)) -> bool {
        self.tree.any_cell_in_rect(lo, hi, true)
    }

    /// Whether every cell of the cell rectangle `lo ..= hi` is known.
    #[inline]
    pub fn covers_cells(&self, lo: (u32, u32), hi: (u32, u32)) -> bool {
        !self.tree.any_cell_in_rect(lo, hi, false)
    }

    /// Whether some cell of the cell rectangle `lo ..= hi` is known, and whether every cell
    /// is: [`touches_cells`](Self::touches_cells) and [`covers_cells`](Self::covers_cells)
    /// from one descent of the tree, starting from `finger` (of this map's
    /// [`tree`](Self::tree); see [`RegionQuadtree::values_in_rect_from`]).
    #[inline]
    pub fn touches_and_covers_cells_from(&self, finger: &mut Finger, lo: (u32, u32), hi: (u32, u32)) -> (bool, bool) {
        let (some_unknown, some_known) = self.tree.values_in_rect_from(finger, lo, hi);
        (some_known, !some_unknown)
    }

    /// Whether some cell overlapping the shape is known.
    pub fn touches_known<S: Shape>(&self, shape: &S) -> bool {
        self.tree.any_leaf_in(shape, true)
    }

    /// Add everything `other` knows (both over the same map). Returns whether anything new
    /// became known.
    pub fn merge(&mut self, other: &KnownMap) -> bool {
        let added = self.tree.union_counting(&other.tree);
        self.known_cells += added;
        added > 0
    }

    /// Work out the content hashes that let maps merging a copy of this one skip what they
    /// hold alike (see [`RegionQuadtree::complete_hashes`]); copies made after this carry
    /// them. Changes nothing else.
    pub fn complete_hashes(&mut self) {
        self.tree.complete_hashes();
    }

    /// Number of known cells (kept up to date, no traversal).
    pub fn known_cells(&self) -> u64 {
        self.known_cells
    }

    /// Known area in m².
    pub fn known_area_m2(&self) -> f64 {
        self.known_cells as f64 * self.grid().cell_area_m2()
    }

    /// Known free area in m² (explored space a robot could stand on).
    pub fn known_free_area_m2(&self, obstacles: &ObstacleMap) -> f64 {
        self.tree.count_cells_where(true, obstacles.tree(), false) as f64 * self.grid().cell_area_m2()
    }

    /// Bytes held by the map's tree (the window aside: a restored run has none until it
    /// marks a view, and this figure is part of the run's metrics, which must not depend on
    /// where a run was resumed).
    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes()
    }

    /// Number of quadtree leaves.
    pub fn leaf_count(&self) -> usize {
        self.tree.leaf_count()
    }

    /// Check the tree's invariants.
    pub fn validate(&self) -> crate::Result<()> {
        self.problems().map_err(crate::Error::Malformed)
    }

    fn problems(&self) -> Result<(), String> {
        self.tree.problems()?;
        let counted = self.tree.count_cells(true);
        if counted != self.known_cells {
            return Err(format!("cached known cells {} ≠ {counted} counted", self.known_cells));
        }
        if let Some(window) = &self.window {
            window.check(&self.tree)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec2;

    use super::KnownMap;
    use crate::spatial::{Aabb, Grid};

    /// The lattice's count worked out by hand: of the 49 points of a 9 × 9 lattice with 1 m
    /// steps within 4 m of the centre, 9 lie on its column and 20 on each side of it.
    #[test]
    #[allow(clippy::float_cmp)] // the ratios of small whole counts, exact as computed
    fn known_fraction_counts_the_lattice_points_in_the_disc() {
        let grid = Grid::new(DVec2::ZERO, 1.0, 20, 20).unwrap();
        let mut known = KnownMap::new(grid);
        let centre = DVec2::new(10.0, 10.0);
        assert_eq!(known.known_fraction_near(centre, 4.0), 0.0);
        // The left half: every point left of the centre's column.
        known.mark(&Aabb::from_corners(DVec2::ZERO, DVec2::new(10.0, 20.0)));
        assert_eq!(known.known_fraction_near(centre, 4.0), 20.0 / 49.0);
        known.mark(&Aabb::from_corners(DVec2::ZERO, DVec2::new(20.0, 20.0)));
        assert_eq!(known.known_fraction_near(centre, 4.0), 1.0);
        // Only points strictly inside the map count; a disc wholly outside it counts as known.
        assert_eq!(
            KnownMap::new(grid).known_fraction_near(DVec2::new(-10.0, -10.0), 4.0),
            1.0
        );
    }
}
