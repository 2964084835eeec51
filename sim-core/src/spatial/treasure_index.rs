//! Treasures in a PR-quadtree (point-region quadtree, paper §4.1): a node splits when it
//! holds more than [`BUCKET`] points and merges back when its subtree drops to that many.

use glam::DVec2;

use crate::spatial::geometry::Aabb;
use crate::spatial::ids::TreasureId;
use crate::{Error, Result};

/// A treasure in the index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Treasure {
    /// Its id.
    pub id: TreasureId,
    /// World position.
    pub position: DVec2,
    /// Remaining quantity (units).
    pub quantity: u32,
}

/// Points per leaf before it splits.
pub const BUCKET: usize = 8;
/// Levels below which leaves no longer split (coincident points share a leaf).
const MAX_LEVELS: u32 = 40;

#[derive(Clone, Debug)]
enum Node {
    Leaf(Vec<u32>),
    Internal([u32; 4]),
}

/// A dynamic set of treasures answering disc and nearest-neighbour queries.
#[derive(Clone, Debug)]
pub struct TreasureIndex {
    /// Square covered by the root.
    root_box: Aabb,
    nodes: Vec<Node>,
    free_nodes: Vec<u32>,
    /// Treasures by id; `None` once removed.
    entries: Vec<Option<Treasure>>,
    len: usize,
}

#[inline]
fn quadrant(b: &Aabb, p: DVec2) -> usize {
    let mid = b.center();
    usize::from(p.x >= mid.x) | (usize::from(p.y >= mid.y) << 1)
}

#[inline]
fn child_box(b: &Aabb, i: usize) -> Aabb {
    let mid = b.center();
    let min = DVec2::new(
        if i & 1 != 0 { mid.x } else { b.min.x },
        if i & 2 != 0 { mid.y } else { b.min.y },
    );
    let max = DVec2::new(
        if i & 1 != 0 { b.max.x } else { mid.x },
        if i & 2 != 0 { b.max.y } else { mid.y },
    );
    Aabb { min, max }
}

impl TreasureIndex {
    /// An empty index covering `area` (treasures must lie inside it).
    pub fn new(area: Aabb) -> Result<Self> {
        let side = (area.max - area.min).max_element();
        if !(area.min.is_finite() && side.is_finite() && side > 0.0) {
            return Err(Error::InvalidParameter(format!(
                "treasure index needs a non-empty finite area, got {area:?}"
            )));
        }
        Ok(Self {
            root_box: Aabb {
                min: area.min,
                max: area.min + DVec2::splat(side),
            },
            nodes: vec![Node::Leaf(Vec::new())],
            free_nodes: Vec::new(),
            entries: Vec::new(),
            len: 0,
        })
    }

    /// Number of treasures held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no treasure is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Add a treasure; ids are handed out in order 0, 1, 2, ….
    pub fn insert(&mut self, position: DVec2, quantity: u32) -> Result<TreasureId> {
        let b = self.root_box;
        if !(position.is_finite()
            && b.min.x <= position.x
            && position.x < b.max.x
            && b.min.y <= position.y
            && position.y < b.max.y)
        {
            return Err(Error::InvalidParameter(format!(
                "treasure at {position} lies outside the map"
            )));
        }
        let id = TreasureId::new(
            u32::try_from(self.entries.len())
                .map_err(|_| Error::InvalidParameter("more than 2^32 treasures".into()))?,
        );
        self.entries.push(Some(Treasure { id, position, quantity }));
        self.len += 1;
        self.insert_at(0, b, 0, id.get(), position);
        Ok(id)
    }

    fn insert_at(&mut self, mut n: u32, mut b: Aabb, mut level: u32, id: u32, p: DVec2) {
        loop {
            match &mut self.nodes[n as usize] {
                Node::Internal(kids) => {
                    let q = quadrant(&b, p);
                    n = kids[q];
                    b = child_box(&b, q);
                    level += 1;
                }
                Node::Leaf(items) => {
                    items.push(id);
                    if items.len() > BUCKET && level < MAX_LEVELS {
                        self.split(n, b, level);
                    }
                    return;
                }
            }
        }
    }

    fn alloc(&mut self, node: Node) -> u32 {
        if let Some(i) = self.free_nodes.pop() {
            self.nodes[i as usize] = node;
            i
        } else {
            self.nodes.push(node);
            (self.nodes.len() - 1) as u32
        }
    }

    fn split(&mut self, n: u32, b: Aabb, level: u32) {
        let Node::Leaf(items) = std::mem::replace(&mut self.nodes[n as usize], Node::Leaf(Vec::new())) else {
            unreachable!("split of an internal node");
        };
        let kids = [0, 1, 2, 3].map(|_| self.alloc(Node::Leaf(Vec::new())));
        self.nodes[n as usize] = Node::Internal(kids);
        for id in items {
            let p = self.position_of(id);
            self.insert_at(n, b, level, id, p);
        }
    }

    fn position_of(&self, id: u32) -> DVec2 {
        self.entries[id as usize]
            .as_ref()
            .map(|t| t.position)
            .expect("indexed treasure exists")
    }

    /// Remove a treasure, returning it.
    pub fn remove(&mut self, id: TreasureId) -> Option<Treasure> {
        let t = self.entries.get_mut(id.index())?.take()?;
        self.len -= 1;
        self.remove_at(0, self.root_box, id.get(), t.position);
        Some(t)
    }

    /// Removes `id` below `n`, merging nodes that drop to one bucket on the way back up.
    fn remove_at(&mut self, n: u32, b: Aabb, id: u32, p: DVec2) {
        match &mut self.nodes[n as usize] {
            Node::Leaf(items) => {
                if let Some(i) = items.iter().position(|&x| x == id) {
                    items.swap_remove(i);
                }
            }
            Node::Internal(kids) => {
                let kids = *kids;
                let q = quadrant(&b, p);
                self.remove_at(kids[q], child_box(&b, q), id, p);
                let leaf_lens = kids.map(|k| match &self.nodes[k as usize] {
                    Node::Leaf(items) => Some(items.len()),
                    Node::Internal(_) => None,
                });
                // Only a node whose children are all leaves can become one leaf.
                let Some(total) = leaf_lens.iter().try_fold(0, |acc, l| l.map(|l| acc + l)) else {
                    return;
                };
                if total <= BUCKET {
                    let mut merged = Vec::with_capacity(total);
                    for k in kids {
                        if let Node::Leaf(items) =
                            std::mem::replace(&mut self.nodes[k as usize], Node::Leaf(Vec::new()))
                        {
                            merged.extend(items);
                        }
                        self.free_nodes.push(k);
                    }
                    self.nodes[n as usize] = Node::Leaf(merged);
                }
            }
        }
    }

    /// A treasure by id.
    pub fn get(&self, id: TreasureId) -> Option<&Treasure> {
        self.entries.get(id.index())?.as_ref()
    }

    /// Change a treasure's quantity; false if it is not in the index.
    pub fn set_quantity(&mut self, id: TreasureId, quantity: u32) -> bool {
        match self.entries.get_mut(id.index()) {
            Some(Some(t)) => {
                t.quantity = quantity;
                true
            }
            _ => false,
        }
    }

    /// All treasures, in id order.
    pub fn iter(&self) -> impl Iterator<Item = &Treasure> {
        self.entries.iter().flatten()
    }

    /// Visit every treasure within `radius_m` of `center` (closed disc).
    pub fn for_each_in_disc(&self, center: DVec2, radius_m: f64, mut visit: impl FnMut(&Treasure)) {
        let r2 = radius_m * radius_m;
        self.visit_disc(0, self.root_box, center, r2, &mut visit);
    }

    fn visit_disc(&self, n: u32, b: Aabb, c: DVec2, r2: f64, visit: &mut impl FnMut(&Treasure)) {
        if b.distance_squared_to(c) > r2 {
            return;
        }
        match &self.nodes[n as usize] {
            Node::Leaf(items) => {
                for &id in items {
                    let t = self.entries[id as usize].as_ref().expect("indexed treasure exists");
                    if t.position.distance_squared(c) <= r2 {
                        visit(t);
                    }
                }
            }
            Node::Internal(kids) => {
                // Children beyond a split line farther than the radius fail the box test
                // above; two comparisons skip them without a call. Exact: each box test
                // adds a square to the one compared here. Checked by
                // `treasure_index_matches_brute_force` (its lattice case).
                let mid = b.center();
                let (dx, dy) = (mid.x - c.x, mid.y - c.y);
                let (far_x, far_y) = (dx * dx > r2, dy * dy > r2);
                // Bit 0 of a child is its x half, bit 1 its y half (see `child_box`).
                let skip =
                    |i: usize| (far_x && ((i & 1 == 0) == (c.x > mid.x))) || (far_y && ((i & 2 == 0) == (c.y > mid.y)));
                for (i, &k) in kids.iter().enumerate() {
                    if !skip(i) {
                        self.visit_disc(k, child_box(&b, i), c, r2, visit);
                    }
                }
            }
        }
    }

    /// The treasure nearest to `p` among those accepted by `filter` (ties: lowest id).
    pub fn nearest_where(&self, p: DVec2, mut filter: impl FnMut(&Treasure) -> bool) -> Option<&Treasure> {
        let mut best: Option<(f64, &Treasure)> = None;
        self.nearest_in(0, self.root_box, p, &mut filter, &mut best);
        best.map(|(_, t)| t)
    }

    /// The treasure nearest to `p` (ties: lowest id).
    pub fn nearest(&self, p: DVec2) -> Option<&Treasure> {
        self.nearest_where(p, |_| true)
    }

    fn nearest_in<'a>(
        &'a self,
        n: u32,
        b: Aabb,
        p: DVec2,
        filter: &mut impl FnMut(&Treasure) -> bool,
        best: &mut Option<(f64, &'a Treasure)>,
    ) {
        if best.is_some_and(|(d, _)| b.distance_squared_to(p) > d) {
            return;
        }
        match &self.nodes[n as usize] {
            Node::Leaf(items) => {
                for &id in items {
                    let t = self.entries[id as usize].as_ref().expect("indexed treasure exists");
                    let d = t.position.distance_squared(p);
                    let better = match best {
                        None => true,
                        Some((bd, bt)) => d.total_cmp(bd).then(t.id.cmp(&bt.id)).is_lt(),
                    };
                    if better && filter(t) {
                        *best = Some((d, t));
                    }
                }
            }
            Node::Internal(kids) => {
                // Nearest quadrant first, so pruning bites early.
                let mut order = [0usize, 1, 2, 3].map(|i| (child_box(&b, i).distance_squared_to(p), i));
                order.sort_by(|a, c| a.0.total_cmp(&c.0));
                for (_, i) in order {
                    self.nearest_in(kids[i], child_box(&b, i), p, filter, best);
                }
            }
        }
    }

    /// Bytes held (approximate for the leaves' small vectors).
    pub fn memory_bytes(&self) -> usize {
        let leaves: usize = self
            .nodes
            .iter()
            .map(|n| match n {
                Node::Leaf(v) => v.capacity() * 4,
                Node::Internal(_) => 0,
            })
            .sum();
        std::mem::size_of::<Self>()
            + self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.free_nodes.capacity() * 4
            + self.entries.capacity() * std::mem::size_of::<Option<Treasure>>()
            + leaves
    }

    /// Check the invariants: every live treasure sits in exactly one leaf, inside that leaf's
    /// square; leaves stay within the bucket unless at the depth limit; subtrees small enough
    /// to be one leaf have been merged; free nodes are unreachable.
    pub fn validate(&self) -> crate::Result<()> {
        self.problems().map_err(crate::Error::Malformed)
    }

    fn problems(&self) -> Result<(), String> {
        let mut seen = vec![false; self.entries.len()];
        let mut reached = vec![false; self.nodes.len()];
        self.validate_node(0, self.root_box, 0, &mut seen, &mut reached)?;
        for (i, e) in self.entries.iter().enumerate() {
            if e.is_some() != seen[i] {
                return Err(format!("treasure {i} is live={} but indexed={}", e.is_some(), seen[i]));
            }
        }
        if seen.iter().filter(|&&s| s).count() != self.len {
            return Err("len disagrees with the indexed treasures".into());
        }
        for &f in &self.free_nodes {
            if reached[f as usize] {
                return Err(format!("free node {f} is reachable"));
            }
        }
        Ok(())
    }

    fn validate_node(
        &self,
        n: u32,
        b: Aabb,
        level: u32,
        seen: &mut [bool],
        reached: &mut [bool],
    ) -> Result<usize, String> {
        if std::mem::replace(&mut reached[n as usize], true) {
            return Err(format!("node {n} reached twice"));
        }
        match &self.nodes[n as usize] {
            Node::Leaf(items) => {
                if items.len() > BUCKET && level < MAX_LEVELS {
                    return Err(format!("leaf {n} holds {} > {BUCKET} points", items.len()));
                }
                for &id in items {
                    let Some(t) = self.entries.get(id as usize).and_then(Option::as_ref) else {
                        return Err(format!("leaf {n} holds removed treasure {id}"));
                    };
                    let p = t.position;
                    if !(b.min.x <= p.x && p.x < b.max.x && b.min.y <= p.y && p.y < b.max.y) {
                        return Err(format!("treasure {id} at {p} lies outside its leaf {b:?}"));
                    }
                    if std::mem::replace(&mut seen[id as usize], true) {
                        return Err(format!("treasure {id} indexed twice"));
                    }
                }
                Ok(items.len())
            }
            Node::Internal(kids) => {
                let mut total = 0;
                for (i, &k) in kids.iter().enumerate() {
                    total += self.validate_node(k, child_box(&b, i), level + 1, seen, reached)?;
                }
                let all_leaves = kids.iter().all(|&k| matches!(self.nodes[k as usize], Node::Leaf(_)));
                if all_leaves && total <= BUCKET {
                    return Err(format!(
                        "node {n} holds {total} points in four leaves and should be merged"
                    ));
                }
                Ok(total)
            }
        }
    }
}
