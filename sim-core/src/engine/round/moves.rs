//! Step 3's moves settled side by side, with the outcome of one pass in id order.
//!
//! A mover's turn reads other robots only in its contact test, and only those on its
//! contact list (step 2's `Turn::near`): a robot before it in id order where that one's
//! move ended, a robot after it where it stood. So where each mover ends depends only on
//! where the movers before it on its list end.
//!
//! The movers are split into blocks, strips of the map across x holding about as many
//! movers each, one per worker. Each block settles its movers in id order, publishing each
//! end as it goes. A mover that lists a mover of another block not yet settled waits for
//! it; if no worker is at that block, it settles the block's movers up to that one itself.
//! Nothing waits for ever: the lowest-numbered mover not yet settled waits for nobody, and
//! a worker settling another block on behalf of its own stops at the mover it waits for,
//! below the one it left. Movers near one another are mostly in the same strip, so waits
//! are few. `turns_side_by_side_give_the_id_order_run` (tests/kernel.rs) checks the outcome.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError, TryLockError};

use glam::DVec2;
use rayon::prelude::*;

use super::resolve::TurnKind;
use super::turn::{end_of_step, halve_until_free};
use crate::cache::prefetch;
use crate::engine::simulation::Turn;

/// A robot's role this round, beside the blocks' numbers `0..`: not in step 3, a turn at a
/// treasure, a turn that moves nobody.
const NOT_PENDING: u16 = u16::MAX;
const AT_TREASURE: u16 = u16::MAX - 1;
const FREE: u16 = u16::MAX - 2;

/// Movers below this many a block are settled as fewer blocks: splitting costs more than
/// it saves.
const MIN_MOVERS_PER_BLOCK: usize = 256;

/// Robots sampled to cut the strips.
const SAMPLE: u64 = 1024;

/// How many movers ahead a block prefetches a turn (and half as many, its contact list):
/// hints that change nothing.
const READ_AHEAD: usize = 8;

/// How many times a mover waiting for another block's mover checks before it yields its
/// core at each further check. Waits between two running workers are far shorter; yielding
/// sooner hands the core to any other process that wants it (BENCHMARKS.md, "Scaling").
const SPINS_BEFORE_YIELD: u32 = 1 << 12;

/// The bits of an end's `x` while it is not settled: a NaN no arithmetic makes, and ends
/// are finite.
const UNSETTLED: u64 = u64::MAX;

/// A mover's settled step and end this round, stored once settled, `end.x` last with
/// release ordering: whoever reads an `end.x` other than [`UNSETTLED`] with acquire
/// ordering reads the rest.
#[derive(Debug, Default)]
pub(crate) struct Slot {
    end: [AtomicU64; 2],
    step: [AtomicU64; 2],
}

impl Slot {
    /// Step 2, for a robot that moves in step 3: not settled yet.
    fn unsettle(&mut self) {
        *self.end[0].get_mut() = UNSETTLED;
    }

    fn publish(&self, step: DVec2, end: DVec2) {
        self.step[0].store(step.x.to_bits(), Ordering::Relaxed);
        self.step[1].store(step.y.to_bits(), Ordering::Relaxed);
        self.end[1].store(end.y.to_bits(), Ordering::Relaxed);
        self.end[0].store(end.x.to_bits(), Ordering::Release);
    }

    fn end(&self) -> Option<DVec2> {
        let x = self.end[0].load(Ordering::Acquire);
        (x != UNSETTLED).then(|| DVec2::new(f64::from_bits(x), f64::from_bits(self.end[1].load(Ordering::Relaxed))))
    }

    fn step(&self) -> DVec2 {
        DVec2::new(
            f64::from_bits(self.step[0].load(Ordering::Relaxed)),
            f64::from_bits(self.step[1].load(Ordering::Relaxed)),
        )
    }
}

/// A block: its movers in id order and the next to settle. A worker settles a block only
/// while holding its lock, and says so in `busy` for the others to see without the lock.
#[derive(Debug, Default)]
struct Block {
    cursor: Mutex<(Vec<u32>, usize)>,
    busy: AtomicBool,
}

/// Marks a block busy while it lives, whether the work ends or panics.
struct Busy<'a>(&'a AtomicBool);

impl<'a> Busy<'a> {
    fn new(flag: &'a AtomicBool) -> Self {
        flag.store(true, Ordering::Relaxed);
        Self(flag)
    }
}

impl Drop for Busy<'_> {
    fn drop(&mut self) {
        self.0.store(false, Ordering::Relaxed);
    }
}

/// The round's moves settled side by side, kept from round to round to reuse allocations.
#[derive(Debug, Default)]
pub(crate) struct SettledMoves {
    /// Per robot.
    slots: Vec<Slot>,
    /// Per robot: its block if it moves in step 3, else its role (see [`NOT_PENDING`]),
    /// set in step 2.
    role: Vec<u16>,
    /// Where this round's strips meet, along x (from the last round's movers).
    cuts: Vec<f64>,
    blocks: Vec<Block>,
}

/// What settling a mover reads.
struct Settle<'a> {
    moves: &'a SettledMoves,
    turns: &'a [Turn],
    bodies: &'a [(DVec2, f64)],
}

impl SettledMoves {
    /// Slots for `n` robots.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            slots: (0..n).map(|_| Slot::default()).collect(),
            role: vec![NOT_PENDING; n],
            cuts: Vec::new(),
            blocks: Vec::new(),
        }
    }

    /// What step 2 sets of each robot, side by side: its role and slot, with the strips'
    /// cuts (see [`Step2Marks::mark`]).
    pub(super) fn step2_marks(&mut self) -> (Step2Marks<'_>, &mut [u16], &mut [Slot]) {
        (Step2Marks { cuts: &self.cuts }, &mut self.role, &mut self.slots)
    }

    /// Sort the turns of step 3 by the roles step 2 gave them: each block's movers in id
    /// order, the turns at treasures into `at_treasures`. Then cut the strips for the next
    /// round, one a worker with about as many of this round's movers each (at the quantiles
    /// of a sample of `bodies`, where the robots stood).
    pub(crate) fn sort(&mut self, bodies: &[(DVec2, f64)], at_treasures: &mut Vec<u32>) {
        self.blocks.resize_with(self.cuts.len() + 1, Block::default);
        let mut lists: Vec<&mut (Vec<u32>, usize)> = self
            .blocks
            .iter_mut()
            .map(|b| b.cursor.get_mut().unwrap_or_else(PoisonError::into_inner))
            .collect();
        for list in &mut lists {
            list.0.clear();
            list.1 = 0;
        }
        at_treasures.clear();
        // One pass over two bytes a robot, in id order.
        for (i, &role) in self.role.iter().enumerate() {
            let i = u32::try_from(i).expect("robot ids are u32");
            match role {
                NOT_PENDING | FREE => {}
                AT_TREASURE => at_treasures.push(i),
                b => lists[usize::from(b)].0.push(i),
            }
        }
        let movers: usize = lists.iter().map(|l| l.0.len()).sum();
        self.cut_strips(bodies, movers);
    }

    /// The cuts of `blocks` strips across x with about as many of `movers` movers each.
    fn cut_strips(&mut self, bodies: &[(DVec2, f64)], movers: usize) {
        let blocks = rayon::current_num_threads()
            .min(movers / MIN_MOVERS_PER_BLOCK)
            .clamp(1, usize::from(FREE));
        self.cuts.clear();
        if blocks < 2 {
            return;
        }
        // Robots picked all over the id range by a multiplicative step: a plain stride can
        // alias with the order robots were placed in (rows of a multiple of it) and miss
        // whole columns of the map.
        let n = self.role.len() as u64;
        let mut sample: Vec<f64> = (0..SAMPLE.min(n))
            .map(|k| usize::try_from(k.wrapping_mul(0x9E37_79B9_7F4A_7C15) % n).expect("robot ids fit usize"))
            .filter(|&i| self.role[i] < FREE)
            .map(|i| bodies[i].0.x)
            .collect();
        if sample.is_empty() {
            return;
        }
        sample.sort_unstable_by(f64::total_cmp);
        self.cuts.extend((1..blocks).map(|b| sample[b * sample.len() / blocks]));
    }

    /// Settle the movers [`sort`](Self::sort) put in blocks, a worker a block.
    /// `bodies` is every robot's position at the start of step 3 and its radius. The
    /// outcome is the pass in id order's (see the module's docs).
    pub(crate) fn settle(&self, turns: &[Turn], bodies: &[(DVec2, f64)]) {
        let s = Settle {
            moves: self,
            turns,
            bodies,
        };
        self.blocks.par_iter().for_each(|block| {
            let mut cursor = block.cursor.lock().unwrap_or_else(PoisonError::into_inner);
            let _busy = Busy::new(&block.busy);
            s.advance(&mut cursor, u32::MAX);
        });
    }

    /// Robot `i`'s settled step, if it moves in step 3 this round.
    pub(crate) fn step_of(&self, i: usize) -> Option<DVec2> {
        (self.role[i] < FREE).then(|| self.slots[i].step())
    }

    /// Each robot's role this round (see [`takes_turn_side_by_side`]).
    pub(crate) fn roles(&self) -> &[u16] {
        &self.role
    }
}

/// Whether a robot of this role takes its turn in the pass side by side (it moves, or its
/// turn touches nobody else's); turns at treasures follow in id order.
pub(crate) fn takes_turn_side_by_side(role: u16) -> bool {
    role != NOT_PENDING && role != AT_TREASURE
}

/// Step 2's part: the strips' cuts, to place each mover in its block.
pub(crate) struct Step2Marks<'a> {
    cuts: &'a [f64],
}

impl Step2Marks<'_> {
    /// Give a robot whose turn step 2 has just worked out (`turn`) its role in step 3, and
    /// unsettle its slot if it moves.
    pub(crate) fn mark(&self, turn: &Turn, role: &mut u16, slot: &mut Slot) {
        *role = match turn.kind {
            _ if !turn.alive || turn.alone => NOT_PENDING,
            TurnKind::Moves { .. } => {
                slot.unsettle();
                u16::try_from(self.cuts.partition_point(|&c| c <= turn.start.x)).expect("fewer blocks than roles")
            }
            TurnKind::AtTreasure => AT_TREASURE,
            TurnKind::Free | TurnKind::Unknown => FREE,
        };
    }
}

impl Settle<'_> {
    /// Settle a block's movers in id order from its cursor (movers, next), those below
    /// robot `before` only.
    fn advance(&self, cursor: &mut (Vec<u32>, usize), before: u32) {
        let (movers, next) = cursor;
        let mut near = Vec::new();
        while let Some(&i) = movers.get(*next).filter(|&&i| i < before) {
            if let Some(&ahead) = movers.get(*next + READ_AHEAD) {
                let turn = &self.turns[ahead as usize];
                prefetch(&turn.kind);
                prefetch(&turn.near);
                prefetch(&self.bodies[ahead as usize]);
            }
            if let Some(first) = movers
                .get(*next + READ_AHEAD / 2)
                .and_then(|&a| self.turns[a as usize].near.first())
            {
                prefetch(first);
            }
            self.settle_one(i as usize, &mut near);
            *next += 1;
        }
    }

    /// Settle mover `i` and publish its move; `near` is scratch.
    fn settle_one(&self, i: usize, near: &mut Vec<(DVec2, f64)>) {
        let turn = &self.turns[i];
        let TurnKind::Moves { free } = turn.kind else {
            unreachable!("only movers are in blocks");
        };
        near.clear();
        near.extend(turn.near.iter().map(|&j| {
            let body = self.bodies[j as usize];
            if j as usize >= i || self.moves.role[j as usize] >= FREE {
                body
            } else {
                (self.end_of(j as usize), body.1)
            }
        }));
        let (from, radius_m) = self.bodies[i];
        let step = halve_until_free(from, free, radius_m, near.len(), |k| near[k]);
        self.moves.slots[i].publish(step, end_of_step(from, step));
    }

    /// Where robot `j` ends. A mover not yet settled is settled first: by this worker, up to
    /// `j`, if no worker is at its block, or else by the worker that is (it is waited for).
    fn end_of(&self, j: usize) -> DVec2 {
        let slot = &self.moves.slots[j];
        let mut spins = 0_u32;
        loop {
            if let Some(end) = slot.end() {
                return end;
            }
            let block = &self.moves.blocks[usize::from(self.moves.role[j])];
            let cursor = if block.busy.load(Ordering::Relaxed) {
                None
            } else {
                match block.cursor.try_lock() {
                    Ok(cursor) => Some(cursor),
                    // A worker panicked settling this block: settling it again here meets
                    // the same panic, which then reaches the caller rather than a wait.
                    Err(TryLockError::Poisoned(p)) => Some(p.into_inner()),
                    Err(TryLockError::WouldBlock) => None,
                }
            };
            if let Some(mut cursor) = cursor {
                let _busy = Busy::new(&block.busy);
                self.advance(&mut cursor, u32::try_from(j + 1).expect("robot ids are u32"));
            } else if spins < SPINS_BEFORE_YIELD {
                spins += 1;
                std::hint::spin_loop();
            } else {
                // The worker waited for has likely lost its core to another process.
                std::thread::yield_now();
            }
        }
    }
}
