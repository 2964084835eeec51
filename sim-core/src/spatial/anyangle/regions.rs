//! The connected regions of free space under the any-angle rules, so that a query between
//! two of them is answered without a search (which would sweep the whole start region).
//!
//! A path passes from a free cell only into a free cell sharing an edge with it: a point
//! where two free cells touch only diagonally lies between two blocked cells and may not be
//! touched, and running along a blocked cell's edge keeps to the one free cell beside it. So
//! the regions are the 4-connected components of the free cells, found here as runs of free
//! cells along rows joined where runs of neighbouring rows overlap (union-find).

use glam::DVec2;

use super::raster::CellRaster;

/// Each run of free cells of the map and the region it belongs to.
#[derive(Clone, Debug)]
pub(crate) struct Regions {
    /// Row `y`'s runs are `runs[row_start[y]..row_start[y + 1]]`, left to right.
    row_start: Vec<usize>,
    /// Free cells `lo..hi` of a row.
    runs: Vec<(i64, i64)>,
    /// Each run's region.
    label: Vec<u32>,
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        // Path halving keeps the trees shallow.
        let p = parent[parent[i as usize] as usize];
        parent[i as usize] = p;
        i = p;
    }
    i
}

impl Regions {
    /// The regions of `raster`'s free cells.
    pub(crate) fn new(raster: &CellRaster) -> Self {
        let mut row_start = vec![0];
        let mut runs = Vec::new();
        for y in 0..raster.height() {
            let mut k = raster.next_free(y, 0);
            while let Some(lo) = k {
                let hi = raster.next_blocked(y, lo);
                runs.push((lo, hi));
                k = raster.next_free(y, hi);
            }
            row_start.push(runs.len());
        }
        let id = |i: usize| u32::try_from(i).expect("fewer runs than 2^32");
        let mut parent: Vec<u32> = (0..runs.len()).map(id).collect();
        for y in 1..row_start.len() - 1 {
            let (mut i, mut j) = (row_start[y - 1], row_start[y]);
            while i < row_start[y] && j < row_start[y + 1] {
                let (a, b) = (runs[i], runs[j]);
                // Cells of the two rows share an edge where the runs overlap.
                if a.0.max(b.0) < a.1.min(b.1) {
                    let (ra, rb) = (find(&mut parent, id(i)), find(&mut parent, id(j)));
                    // The smaller root wins: labels do not depend on the order of joining.
                    parent[ra.max(rb) as usize] = ra.min(rb);
                }
                if a.1 <= b.1 {
                    i += 1;
                } else {
                    j += 1;
                }
            }
        }
        let label = (0..runs.len()).map(|i| find(&mut parent, id(i))).collect();
        Self { row_start, runs, label }
    }

    /// The region of free cell `(x, y)`, or `None` for a blocked cell.
    fn of_cell(&self, x: i64, y: i64) -> Option<u32> {
        let row = usize::try_from(y).ok().filter(|&y| y + 1 < self.row_start.len())?;
        let runs = &self.runs[self.row_start[row]..self.row_start[row + 1]];
        // The first run ending after x.
        let i = runs.partition_point(|&(_, hi)| hi <= x);
        (i < runs.len() && runs[i].0 <= x).then(|| self.label[self.row_start[row] + i])
    }

    /// The region of a point a path may touch (any free cell whose closure holds it: they
    /// are all in one region), or `None` if no free cell's closure holds it.
    #[allow(clippy::cast_possible_truncation, clippy::cast_precision_loss, clippy::float_cmp)] // Map coordinates; exact integers.
    pub(crate) fn of_point(&self, p: DVec2) -> Option<u32> {
        if !p.is_finite() || p.x < 0.0 || p.y < 0.0 {
            return None;
        }
        let (x, y) = (p.x as i64, p.y as i64);
        let (on_x, on_y) = (p.x == x as f64, p.y == y as f64);
        [
            (x, y, true),
            (x - 1, y, on_x),
            (x, y - 1, on_y),
            (x - 1, y - 1, on_x && on_y),
        ]
        .into_iter()
        .filter(|c| c.2)
        .find_map(|(cx, cy, _)| self.of_cell(cx, cy))
    }

    /// Heap bytes.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.row_start.capacity() * 8 + self.runs.capacity() * 16 + self.label.capacity() * 4
    }
}
