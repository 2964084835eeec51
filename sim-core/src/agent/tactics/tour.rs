//! Frontier tours: which of several frontiers to walk to first so that little is left
//! behind (after the exploration planners of Zhou et al., FUEL, 2021, with a weighted
//! arrival instead of the tour's length).

/// How a lone explorer plans a tour over the frontiers nearest to it (see
/// [`FrontierSeeking::with_tour`](super::FrontierSeeking::with_tour)).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Tour {
    /// Stops of the tour, at most (default [`TOUR_STOPS`]; at most [`MAX_TOUR_STOPS`]).
    pub stops: usize,
    /// Stops lie at least this many view radii apart (default 1): one stop per patch of
    /// frontier a view takes in.
    pub spacing_views: f64,
    /// What a stop weighs besides the part of its view still unknown (default
    /// [`TOUR_BASE_WEIGHT`]): above 0, a stop that reveals little is still worth not
    /// walking back for.
    pub base_weight: f64,
}

/// `tour_stops` of the `frontier` strategy, by default (BENCHMARKS.md, "Exploration
/// quality").
pub const TOUR_STOPS: usize = 7;

/// Stops a tour may have: the first stop costs O(2^stops × stops²) to find.
pub const MAX_TOUR_STOPS: usize = 12;

/// [`Tour::base_weight`] by default (BENCHMARKS.md, "Exploration quality").
pub const TOUR_BASE_WEIGHT: f64 = 0.6;

impl Default for Tour {
    fn default() -> Self {
        Self {
            stops: TOUR_STOPS,
            spacing_views: 1.0,
            base_weight: TOUR_BASE_WEIGHT,
        }
    }
}

/// The first stop of the open tour from the robot through every stop that minimises the
/// weighted arrival, Σ `weight[i]` × the walk until stop `i` is reached, and that sum.
/// `first_leg_m[i]` is the walk from the robot to stop `i`, `leg_m(i, j)` from stop `i` to
/// stop `j`. A stop that reveals much is reached early; one that reveals little is taken on
/// the way when it lies there, rather than left to walk back for. `None` for no stops.
///
/// Cost: O(2^n × n²) time and O(2^n × n) memory for n stops (Held and Karp's dynamic
/// programme: a leg's length counts once for every stop still ahead, so the sum splits
/// leg by leg). Ties go to the lower index. `first_stop_matches_every_order_tried`
/// checks it against all orders.
pub fn first_stop(first_leg_m: &[f64], leg_m: impl Fn(usize, usize) -> f64, weight: &[f64]) -> Option<(usize, f64)> {
    let n = first_leg_m.len();
    debug_assert!(n <= MAX_TOUR_STOPS && weight.len() == n);
    if n == 0 {
        return None;
    }
    let full = (1usize << n) - 1;
    // Weight of the stops not yet visited, for every set visited.
    let ahead: Vec<f64> = (0..=full)
        .map(|visited| (0..n).filter(|&i| visited & (1 << i) == 0).map(|i| weight[i]).sum())
        .collect();
    // best[visited][last] = (weighted arrival so far, first stop).
    let mut best = vec![vec![(f64::INFINITY, usize::MAX); n]; full + 1];
    for i in 0..n {
        best[1 << i][i] = (first_leg_m[i] * ahead[0], i);
    }
    for visited in 1..full {
        for last in (0..n).filter(|&j| visited & (1 << j) != 0) {
            let (so_far, first) = best[visited][last];
            if !so_far.is_finite() {
                continue;
            }
            for next in (0..n).filter(|&m| visited & (1 << m) == 0) {
                let cost = so_far + leg_m(last, next) * ahead[visited];
                let slot = &mut best[visited | (1 << next)][next];
                if cost.total_cmp(&slot.0).then(first.cmp(&slot.1)).is_lt() {
                    *slot = (cost, first);
                }
            }
        }
    }
    best[full]
        .iter()
        .filter(|e| e.0.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|&(cost, first)| (first, cost))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::first_stop;

    /// Every order of the stops, as lists of indices.
    fn orders(n: usize) -> Vec<Vec<usize>> {
        if n == 0 {
            return vec![Vec::new()];
        }
        let mut out = Vec::new();
        for order in orders(n - 1) {
            for at in 0..=order.len() {
                let mut o = order.clone();
                o.insert(at, n - 1);
                out.push(o);
            }
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, rng_seed: proptest::test_runner::RngSeed::Fixed(5), ..ProptestConfig::default() })]

        /// The first stop's weighted arrival is the least over every order of the stops,
        /// summed as the definition says (arrival by arrival), and the stop it names
        /// starts an order that reaches it.
        #[test]
        fn first_stop_matches_every_order_tried(
            points in proptest::collection::vec((0.0f64..50.0, 0.0f64..50.0, 0.0f64..1.5), 1..7),
        ) {
            let n = points.len();
            let first_leg: Vec<f64> = points.iter().map(|p| p.0.hypot(p.1)).collect();
            let leg = |i: usize, j: usize| (points[i].0 - points[j].0).hypot(points[i].1 - points[j].1);
            let weight: Vec<f64> = points.iter().map(|p| p.2).collect();
            let arrival = |order: &[usize]| {
                let (mut walked, mut sum) = (0.0, 0.0);
                for (k, &s) in order.iter().enumerate() {
                    walked += if k == 0 { first_leg[s] } else { leg(order[k - 1], s) };
                    sum += weight[s] * walked;
                }
                sum
            };
            let all = orders(n);
            let least = all.iter().map(|o| arrival(o)).fold(f64::INFINITY, f64::min);
            let (first, cost) = first_stop(&first_leg, leg, &weight).expect("stops given");
            prop_assert!((cost - least).abs() <= 1e-9 * least.max(1.0), "{} against {}", cost, least);
            let from_first = all.iter().filter(|o| o[0] == first).map(|o| arrival(o)).fold(f64::INFINITY, f64::min);
            prop_assert!((from_first - least).abs() <= 1e-9 * least.max(1.0));
        }
    }

    /// A corner near by is taken first when it weighs enough, and left for last when it
    /// weighs nothing, worked out by hand.
    #[test]
    fn a_near_corner_comes_first_unless_it_weighs_nothing() {
        // A big frontier 10 m off (weight 1.6), a corner 2 m off (0.6), 8 m between them
        // (on the way). Corner first: 0.6 × 2 + 1.6 × 10 = 17.2; big first: 1.6 × 10 +
        // 0.6 × 18 = 26.8.
        let (first, cost) =
            first_stop(&[10.0, 2.0], |i, j| if i == j { 0.0 } else { 8.0 }, &[1.6, 0.6]).expect("two stops");
        assert_eq!(first, 1);
        assert!((cost - 17.2).abs() < 1e-9, "{cost}");
        // The corner behind the robot, 12 m from the big one. Corner first: 0.6 × 2 + 1.6 ×
        // 14 = 23.6; big first: 1.6 × 10 + 0.6 × 22 = 29.2.
        let (first, cost) =
            first_stop(&[10.0, 2.0], |i, j| if i == j { 0.0 } else { 12.0 }, &[1.6, 0.6]).expect("two stops");
        assert_eq!(first, 1);
        assert!((cost - 23.6).abs() < 1e-9, "{cost}");
        // Weighing nothing, it is left for last: 1.6 × 10 = 16 against 1.6 × 14 = 22.4.
        let (first, cost) =
            first_stop(&[10.0, 2.0], |i, j| if i == j { 0.0 } else { 12.0 }, &[1.6, 0.0]).expect("two stops");
        assert_eq!(first, 0);
        assert!((cost - 16.0).abs() < 1e-9, "{cost}");
        assert_eq!(first_stop(&[], |_, _| 0.0, &[]), None);
    }
}
