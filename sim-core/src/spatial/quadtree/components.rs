//! Connected components of free space, computed on the quadtree's free leaves (4-connected:
//! two free leaves are joined when they share a stretch of edge, never through a corner, as a
//! robot disc cannot slip between two blocked cells that touch diagonally).
//!
//! The walk never visits cells: for every internal node it joins the leaves along the two
//! seams between its children, so the cost is linear in the number of leaves along seams.

use std::borrow::Cow;

use glam::DVec2;

use super::{EMPTY, FULL, NodeRef, RegionQuadtree, Square, is_leaf};

const NONE: u32 = u32::MAX;

/// A child slot seen from the seam matcher.
#[derive(Clone, Copy)]
enum Slot {
    Free(u32),
    Blocked,
    Node(u32),
}

/// Free-space components of a map's obstacle tree.
#[derive(Debug)]
pub struct Components<'a> {
    /// The tree with groups down to single cells: the seam walk needs an id for every
    /// internal node, which the bits of a block do not have.
    tree: Cow<'a, RegionQuadtree>,
    /// Free-leaf id of child `i` of group `g` (or `NONE`).
    ids: Vec<[u32; 4]>,
    root_id: u32,
    /// Union-find parents, then component labels.
    parent: Vec<u32>,
    /// Square of every free leaf.
    squares: Vec<Square>,
    /// Cells per component label.
    component_cells: Vec<u64>,
}

impl<'a> Components<'a> {
    /// Label the free leaves of `tree` (`FULL` = blocked).
    pub fn new(tree: &'a RegionQuadtree) -> Self {
        let tree = if tree.packed {
            Cow::Owned(tree.unpacked())
        } else {
            Cow::Borrowed(tree)
        };
        let mut c = Components {
            tree,
            ids: Vec::new(),
            root_id: NONE,
            parent: Vec::new(),
            squares: Vec::new(),
            component_cells: Vec::new(),
        };
        c.number_leaves();
        c.join_seams();
        c.finish_labels();
        c
    }

    fn number_leaves(&mut self) {
        let root = self.tree.root();
        let root_sq = self.tree.root_square();
        if is_leaf(root) {
            if root == EMPTY {
                self.root_id = 0;
                self.squares.push(root_sq);
            }
            return;
        }
        let mut stack = vec![(root, root_sq)];
        while let Some((n, sq)) = stack.pop() {
            let kids = *self.tree.children(n);
            if self.ids.len() <= n as usize {
                self.ids.resize(n as usize + 1, [NONE; 4]);
            }
            for (i, &k) in kids.iter().enumerate() {
                if k == EMPTY {
                    self.ids[n as usize][i] = self.squares.len() as u32;
                    self.squares.push(sq.child(i));
                } else if !is_leaf(k) {
                    stack.push((k, sq.child(i)));
                }
            }
        }
    }

    #[inline]
    fn slot(&self, g: u32, i: usize) -> Slot {
        let k = self.tree.children(g)[i];
        if k == EMPTY {
            Slot::Free(self.ids[g as usize][i])
        } else if k == FULL {
            Slot::Blocked
        } else {
            Slot::Node(k)
        }
    }

    fn find(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let p = self.parent[self.parent[a as usize] as usize];
            self.parent[a as usize] = p;
            a = p;
        }
        a
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            self.parent[hi as usize] = lo;
        }
    }

    /// Join the leaves along a vertical seam: `a` lies west of `b`.
    fn join_h(&mut self, a: Slot, b: Slot) {
        match (a, b) {
            (Slot::Blocked, _) | (_, Slot::Blocked) => {}
            (Slot::Free(x), Slot::Free(y)) => self.union(x, y),
            (Slot::Node(g), Slot::Free(_)) => {
                self.join_h(self.slot(g, 1), b);
                self.join_h(self.slot(g, 3), b);
            }
            (Slot::Free(_), Slot::Node(g)) => {
                self.join_h(a, self.slot(g, 0));
                self.join_h(a, self.slot(g, 2));
            }
            (Slot::Node(ga), Slot::Node(gb)) => {
                self.join_h(self.slot(ga, 1), self.slot(gb, 0));
                self.join_h(self.slot(ga, 3), self.slot(gb, 2));
            }
        }
    }

    /// Join the leaves along a horizontal seam: `a` lies south of `b`.
    fn join_v(&mut self, a: Slot, b: Slot) {
        match (a, b) {
            (Slot::Blocked, _) | (_, Slot::Blocked) => {}
            (Slot::Free(x), Slot::Free(y)) => self.union(x, y),
            (Slot::Node(g), Slot::Free(_)) => {
                self.join_v(self.slot(g, 2), b);
                self.join_v(self.slot(g, 3), b);
            }
            (Slot::Free(_), Slot::Node(g)) => {
                self.join_v(a, self.slot(g, 0));
                self.join_v(a, self.slot(g, 1));
            }
            (Slot::Node(ga), Slot::Node(gb)) => {
                self.join_v(self.slot(ga, 2), self.slot(gb, 0));
                self.join_v(self.slot(ga, 3), self.slot(gb, 1));
            }
        }
    }

    fn join_seams(&mut self) {
        self.parent = (0..self.squares.len() as u32).collect();
        let root = self.tree.root();
        if is_leaf(root) {
            return;
        }
        let mut stack: Vec<NodeRef> = vec![root];
        while let Some(g) = stack.pop() {
            let s = [0, 1, 2, 3].map(|i| self.slot(g, i));
            self.join_h(s[0], s[1]);
            self.join_h(s[2], s[3]);
            self.join_v(s[0], s[2]);
            self.join_v(s[1], s[3]);
            for &k in self.tree.children(g) {
                if !is_leaf(k) {
                    stack.push(k);
                }
            }
        }
    }

    fn finish_labels(&mut self) {
        let n = self.parent.len();
        let roots: Vec<u32> = (0..n as u32).map(|i| self.find(i)).collect();
        let mut label_of_root = vec![NONE; n];
        for (i, &r) in roots.iter().enumerate() {
            if label_of_root[r as usize] == NONE {
                label_of_root[r as usize] = self.component_cells.len() as u32;
                self.component_cells.push(0);
            }
            let l = label_of_root[r as usize];
            self.component_cells[l as usize] += self.squares[i].cells();
        }
        for (p, &r) in self.parent.iter_mut().zip(&roots) {
            *p = label_of_root[r as usize];
        }
    }

    /// Number of components.
    pub fn count(&self) -> usize {
        self.component_cells.len()
    }

    /// Cells in component `label`.
    pub fn cells(&self, label: u32) -> u64 {
        self.component_cells[label as usize]
    }

    /// Free leaves: `(square, component label)`.
    pub fn leaves(&self) -> impl Iterator<Item = (Square, u32)> + '_ {
        self.squares.iter().copied().zip(self.parent.iter().copied())
    }

    /// The component label of the free leaf holding cell `(x, y)`, or `None` if it is blocked
    /// or outside the map.
    pub fn label_of_cell(&self, x: u32, y: u32) -> Option<u32> {
        let g = self.tree.grid();
        if !g.in_map(x, y) {
            return None;
        }
        let mut n = self.tree.root();
        if is_leaf(n) {
            return (n == EMPTY).then_some(self.parent[self.root_id as usize]);
        }
        let mut level = g.depth();
        loop {
            level -= 1;
            let i = ((x >> level) & 1) as usize | ((((y >> level) & 1) as usize) << 1);
            let k = self.tree.children(n)[i];
            if k == EMPTY {
                return Some(self.parent[self.ids[n as usize][i] as usize]);
            } else if k == FULL {
                return None;
            }
            n = k;
        }
    }

    /// The component label at world point `p`, if it lies in a free cell of the map.
    pub fn label_at(&self, p: DVec2) -> Option<u32> {
        let g = self.tree.grid();
        if !p.is_finite() {
            return None;
        }
        let e = g.extent();
        if p.x < e.min.x || p.y < e.min.y || p.x > e.max.x || p.y > e.max.y {
            return None;
        }
        let (x, y) = g.cell_of(p)?;
        // A point on the map's top or right edge belongs to the last cell.
        self.label_of_cell(x.min(g.width_cells() - 1), y.min(g.height_cells() - 1))
    }

    /// The largest component, if any cell is free.
    pub fn largest(&self) -> Option<u32> {
        (0..self.component_cells.len() as u32).max_by_key(|&l| (self.component_cells[l as usize], u32::MAX - l))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spatial::grid::Grid;
    use crate::spatial::obstacle_map::ObstacleMap;

    fn flood_count(blocked: &dyn Fn(u32, u32) -> bool, w: u32, h: u32) -> usize {
        let mut seen = vec![false; (w * h) as usize];
        let mut comps = 0;
        for sy in 0..h {
            for sx in 0..w {
                if blocked(sx, sy) || seen[(sy * w + sx) as usize] {
                    continue;
                }
                comps += 1;
                let mut stack = vec![(sx, sy)];
                seen[(sy * w + sx) as usize] = true;
                while let Some((x, y)) = stack.pop() {
                    let nb = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
                    for (nx, ny) in nb {
                        if nx < w && ny < h && !blocked(nx, ny) && !seen[(ny * w + nx) as usize] {
                            seen[(ny * w + nx) as usize] = true;
                            stack.push((nx, ny));
                        }
                    }
                }
            }
        }
        comps
    }

    #[test]
    fn matches_a_cell_flood_fill() {
        for seed in 0..20u64 {
            let (w, h) = (37, 29);
            let blocked = move |x: u32, y: u32| {
                let v = (u64::from(x) * 7919 + u64::from(y) * 104_729 + seed * 31).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                (v >> 60) < 6 + (seed % 4)
            };
            let grid = Grid::new(DVec2::ZERO, 1.0, w, h).unwrap();
            let map = ObstacleMap::from_fn(grid, blocked);
            let c = Components::new(map.tree());
            assert_eq!(c.count(), flood_count(&blocked, w, h), "seed {seed}");
        }
    }

    #[test]
    fn diagonal_contact_does_not_connect() {
        // Two free cells touching only at a corner.
        let grid = Grid::new(DVec2::ZERO, 1.0, 2, 2).unwrap();
        let map = ObstacleMap::from_fn(grid, |x, y| x != y);
        let c = Components::new(map.tree());
        assert_eq!(c.count(), 2);
        assert_ne!(c.label_of_cell(0, 0), c.label_of_cell(1, 1));
        assert_eq!(c.label_of_cell(1, 0), None);
    }
}
