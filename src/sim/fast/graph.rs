//! A layout's relaxation passes as a graph of tasks, so that threads wait
//! on their neighbours, not on every group of a round.
//!
//! Both layouts cut the cloth into a chain of groups (the coloured
//! layout's blocks of particles, the grid's tiles of columns) and relax a
//! pass in rounds, each ended by a barrier: a thread that finished its
//! share waits for the slowest, and a group's next pass waits for every
//! group of the pass, not only the two beside it. Here each group's pass
//! is a task that runs as soon as the tasks it must follow are done. The
//! edges depend on how the chain's groups share particles ([`Chain`]):
//!
//! **Blocks and seams** (`generic::blocks`: three rounds a pass, the
//! blocks, the seams after even blocks, those after odd ones). Task
//! (block k, pass p) or (seam k, pass p):
//!
//! - block k, pass p: seams k − 1 and k of pass p − 1 (the only seams that
//!   touch block k's particles);
//! - seam k, pass p: blocks k and k + 1 of pass p, and where k is odd the
//!   even seams k − 1 and k + 1 of pass p (they touch blocks k and k + 1).
//!
//! Every particle then sees its groups in the rounds' order (its block,
//! its even seam, its odd seam, its block again).
//!
//! **Tiles** (`grid::sweep`: two rounds a pass, even tiles then odd ones;
//! tile k's task sweeps tile k, then the seam bars between its last lane
//! and tile k + 1's first, so it touches tiles k and k + 1):
//!
//! - even tile k, pass p: tiles k − 1 and k + 1 of pass p − 1;
//! - odd tile k, pass p: tiles k − 1 and k + 1 of pass p.
//!
//! Every tile then sees the tasks that touch it in the rounds' order.
//!
//! Either way the graph computes the rounds' bits on any thread count. Two
//! tasks that share a particle are always joined by a path of these edges
//! (a test checks every pair), so two tasks that run at once share none,
//! which is what lets a layout hand each its particles through a raw
//! pointer.
//!
//! Ready tasks are taken lowest pass first, then seams (short, and the next
//! pass waits on them) before blocks, then a thread's own groups (the first
//! `groups / threads`, and so on) before another's, so each group tends to
//! stay on one core. A worker with nothing ready spins: a task takes tens
//! of microseconds, and a sleeping thread takes longer than that to wake.
//!
//! Measured on disc-183 (101 017 particles, 8 blocks) on the two vCPUs of
//! host D (a Zen 4), both schedules in one process, alternated in windows
//! of two steps: the rounds' mean step 1.01–1.18 times the graph's over
//! ten runs (the most when the host was busiest, 1.01 in its quietest:
//! 7.54 ms against 7.59 ms). Taking seams or a thread's own blocks first
//! or not moved the mean by less than the noise (±4 %).
//!
//! The rounds stay for a pass that must end with every group done: when a
//! tolerance is set (the step stops after the first pass that meets it) and
//! when bars join blocks further apart than neighbours (they are relaxed
//! after every seam, on one thread).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};

/// How a chain's groups share particles, which sets the graph's edges (the
/// module's rules).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Chain {
    /// The coloured layout's blocks, and the seams between neighbours as
    /// tasks of their own.
    BlocksAndSeams,
    /// The grid's tiles, each task a tile and its seam to the next.
    Tiles,
}

/// One group's pass. With [`Chain::BlocksAndSeams`]: block `node`, or seam
/// `node − groups` (between blocks `node − groups` and `node − groups +
/// 1`); with [`Chain::Tiles`]: tile `node`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Task {
    pub(crate) pass: usize,
    pub(crate) node: usize,
}

/// The tasks of `passes` passes over a chain of `groups` groups (≥ 2), and
/// which are done, ready or waiting.
#[derive(Clone, Debug)]
pub(crate) struct Schedule {
    chain: Chain,
    groups: usize,
    passes: usize,
    /// Per task (pass-major), how many of the tasks it follows are not done.
    waiting: Vec<u8>,
    ready: Vec<Task>,
    /// Tasks not done.
    left: usize,
}

impl Schedule {
    pub(crate) fn new(chain: Chain, groups: usize, passes: usize) -> Self {
        assert!(groups >= 2, "a schedule needs two groups and the seam between them");
        let mut schedule = Schedule { chain, groups, passes, waiting: Vec::new(), ready: Vec::new(), left: 0 };
        let tasks: Vec<Task> =
            (0..passes).flat_map(|pass| (0..schedule.nodes()).map(move |node| Task { pass, node })).collect();
        schedule.waiting = tasks.iter().map(|&t| schedule.follows(t).count() as u8).collect();
        schedule.ready = tasks.into_iter().filter(|&t| schedule.waiting[schedule.index(t)] == 0).collect();
        schedule.left = schedule.waiting.len();
        schedule
    }

    /// Blocks, then seams; or tiles.
    fn nodes(&self) -> usize {
        match self.chain {
            Chain::BlocksAndSeams => 2 * self.groups - 1,
            Chain::Tiles => self.groups,
        }
    }

    fn index(&self, t: Task) -> usize {
        t.pass * self.nodes() + t.node
    }

    /// The seam task's seam, or `None` for a block or a tile.
    fn seam(&self, t: Task) -> Option<usize> {
        match self.chain {
            Chain::BlocksAndSeams => t.node.checked_sub(self.groups),
            Chain::Tiles => None,
        }
    }

    /// The tasks `t` must follow (the module's rules for its chain).
    pub(crate) fn follows(&self, t: Task) -> impl Iterator<Item = Task> + use<> {
        if self.chain == Chain::Tiles {
            // Its neighbours, of the pass before (even tiles) or this one
            // (odd tiles).
            let k = t.node;
            let pass = if k.is_multiple_of(2) { t.pass.checked_sub(1) } else { Some(t.pass) };
            let tile = |k: Option<usize>| Some(Task { pass: pass?, node: k.filter(|&k| k < self.groups)? });
            return [tile(k.checked_sub(1)), tile(Some(k + 1)), None, None].into_iter().flatten();
        }
        // Blocks and seams: the groups are blocks.
        let (blocks, seams) = (self.groups, self.groups - 1);
        let seam = |pass: usize, k: usize| Task { pass, node: blocks + k };
        let block = |k: usize| Task { pass: t.pass, node: k };
        // At most four, kept on the stack: this runs under the lock.
        let mut follows = [None; 4];
        match self.seam(t) {
            None if t.pass > 0 => {
                let k = t.node;
                follows[0] = k.checked_sub(1).map(|k| seam(t.pass - 1, k));
                follows[1] = (k < seams).then(|| seam(t.pass - 1, k));
            }
            None => {}
            Some(k) => {
                (follows[0], follows[1]) = (Some(block(k)), Some(block(k + 1)));
                if k % 2 == 1 {
                    follows[2] = Some(seam(t.pass, k - 1));
                    follows[3] = (k + 1 < seams).then(|| seam(t.pass, k + 1));
                }
            }
        }
        follows.into_iter().flatten()
    }

    /// The tasks that follow `t`: those at its pass or the next, near its
    /// groups, whose [`Schedule::follows`] holds it.
    fn followers(&self, t: Task) -> impl Iterator<Item = Task> + '_ {
        let k = self.seam(t).unwrap_or(t.node);
        let near = k.saturating_sub(1)..(k + 3).min(self.groups);
        let passes = t.pass..(t.pass + 2).min(self.passes);
        let with_seams = self.chain == Chain::BlocksAndSeams;
        passes
            .flat_map(move |pass| {
                let blocks = near.clone().map(move |node| Task { pass, node });
                let seams = near
                    .clone()
                    .filter(move |&s| with_seams && s + 1 < self.groups)
                    .map(move |s| Task { pass, node: self.groups + s });
                blocks.chain(seams)
            })
            .filter(move |&f| self.follows(f).any(|p| p == t))
    }

    /// Marks `t` done: the tasks that waited on it last become ready.
    pub(crate) fn complete(&mut self, t: Task) {
        self.left -= 1;
        // At most four (an even seam's: two blocks, two odd seams).
        let mut followers = [None; 4];
        for (slot, f) in followers.iter_mut().zip(self.followers(t)) {
            *slot = Some(f);
        }
        for f in followers.into_iter().flatten() {
            let i = self.index(f);
            self.waiting[i] -= 1;
            if self.waiting[i] == 0 {
                self.ready.push(f);
            }
        }
    }

    /// Every task done.
    pub(crate) fn finished(&self) -> bool {
        self.left == 0
    }

    /// Takes the ready task thread `me` of `threads` should run next (the
    /// module's order), if any.
    pub(crate) fn take(&mut self, me: usize, threads: usize) -> Option<Task> {
        let home_of = |t: &Task| home(self.seam(*t).unwrap_or(t.node), self.groups, threads);
        let key = |t: &Task| (t.pass, self.seam(*t).is_none(), home_of(t) != me, t.node);
        let (at, _) = self.ready.iter().enumerate().min_by_key(|(_, t)| key(t))?;
        Some(self.ready.swap_remove(at))
    }
}

/// The worker whose own groups include group `k` of `groups` on `threads`
/// workers: the first `groups / threads` are worker 0's, and so on
/// ([`Schedule::take`] takes a worker's own groups first).
fn home(k: usize, groups: usize, threads: usize) -> usize {
    k * threads / groups
}

/// The group a worker most likely takes after group `k` of `groups` (on
/// `threads` workers): the next of its own groups, or after its last its
/// first (the next pass's). Ready tasks are taken lowest pass first, then
/// the worker's own groups in order, so a worker that relaxed block k of a
/// pass goes on with block k + 1 of its share when the seams allow, and
/// with its first block in the next pass. A layout prefetches that group's
/// rows while it relaxes group `k` ([`crate::sim::fast::generic`]'s
/// `Ahead`); a wrong guess costs the prefetches, not a bit.
pub(crate) fn next_at_home(k: usize, groups: usize, threads: usize) -> usize {
    // At most one worker a group (as `run` is called).
    let threads = threads.clamp(1, groups.max(1));
    let me = home(k, groups, threads);
    match k + 1 {
        next if next < groups && home(next, groups, threads) == me => next,
        // The least j with j · threads / groups = me.
        _ => (me * groups).div_ceil(threads),
    }
}

/// Runs every task of `schedule` with `run`, on `threads` workers of the
/// rayon pool (the calling thread one of them), each taking the next ready
/// task as it finishes one ([`Schedule::take`]). `run` is called for two
/// tasks at once only when neither follows the other. A panic in `run`
/// stops the other workers and is raised again here.
pub(crate) fn run(schedule: Schedule, threads: usize, run: &(dyn Fn(Task) + Sync)) {
    let threads = threads.max(1);
    let shared = Mutex::new(schedule);
    let failed = AtomicBool::new(false);
    let worker = |me: usize| {
        /// Tells the other workers to stop if this one unwinds.
        struct Alarm<'a>(&'a AtomicBool);
        impl Drop for Alarm<'_> {
            fn drop(&mut self) {
                if std::thread::panicking() {
                    self.0.store(true, Ordering::Relaxed);
                }
            }
        }
        let _alarm = Alarm(&failed);
        let mut done = None;
        loop {
            let next = {
                let mut schedule = shared.lock().unwrap_or_else(PoisonError::into_inner);
                if let Some(t) = done.take() {
                    schedule.complete(t);
                }
                if schedule.finished() || failed.load(Ordering::Relaxed) {
                    return;
                }
                schedule.take(me, threads)
            };
            match next {
                Some(t) => {
                    run(t);
                    done = Some(t);
                }
                // A task in progress on another worker will make one ready:
                // a seam takes a few µs.
                None => (0..64).for_each(|_| std::hint::spin_loop()),
            }
        }
    };
    rayon::scope(|scope| {
        for me in 1..threads {
            scope.spawn(move |_| worker(me));
        }
        worker(0);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The groups a task's particles lie in: its block, its seam's two, or
    /// its tile and the next (its seam bars' far ends).
    fn touches(s: &Schedule, t: Task) -> Vec<usize> {
        match (s.chain, s.seam(t)) {
            (Chain::Tiles, _) => (t.node..(t.node + 2).min(s.groups)).collect(),
            (_, None) => vec![t.node],
            (_, Some(k)) => vec![k, k + 1],
        }
    }

    /// The pairs of tasks over 3 passes that touch a common block while
    /// neither reaches the other along `follows` (two workers could run
    /// them at once on the same particles).
    fn unordered_sharing(s: &Schedule, follows: &dyn Fn(Task) -> Vec<Task>) -> Vec<(Task, Task)> {
        let tasks: Vec<Task> = (0..3).flat_map(|pass| (0..s.nodes()).map(move |node| Task { pass, node })).collect();
        // reach[i][j]: task j follows task i, directly or not (a search
        // from each task along the edges).
        let n = tasks.len();
        let mut after = vec![Vec::new(); n];
        for &t in &tasks {
            for p in follows(t) {
                after[s.index(p)].push(s.index(t));
            }
        }
        let mut reach = vec![vec![false; n]; n];
        for (i, reach) in reach.iter_mut().enumerate() {
            let mut stack = vec![i];
            while let Some(h) = stack.pop() {
                for &j in &after[h] {
                    if !reach[j] {
                        reach[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        let mut pairs = Vec::new();
        for (i, &a) in tasks.iter().enumerate() {
            for (j, &b) in tasks.iter().enumerate().skip(i + 1) {
                if !reach[i][j] && !reach[j][i] && touches(s, a).iter().any(|k| touches(s, b).contains(k)) {
                    pairs.push((a, b));
                }
            }
        }
        pairs
    }

    #[test]
    fn a_worker_goes_on_with_its_next_group_then_its_first() {
        // 8 groups on 2 workers: worker 0 owns 0–3 (k · 2 / 8 = 0), worker
        // 1 owns 4–7. After its last group a worker comes back to its first.
        let next = |k, threads| next_at_home(k, 8, threads);
        assert_eq!((0..8).map(|k| next(k, 2)).collect::<Vec<_>>(), [1, 2, 3, 0, 5, 6, 7, 4]);
        // One worker owns all eight: 7 is followed by 0.
        assert_eq!((0..8).map(|k| next(k, 1)).collect::<Vec<_>>(), [1, 2, 3, 4, 5, 6, 7, 0]);
        // Three workers: homes k · 3 / 8 = 0 0 0 1 1 1 2 2.
        assert_eq!((0..8).map(|k| next(k, 3)).collect::<Vec<_>>(), [1, 2, 0, 4, 5, 3, 7, 6]);
        // As many workers as groups: each owns one and comes back to it.
        assert_eq!((0..4).map(|k| next_at_home(k, 4, 4)).collect::<Vec<_>>(), [0, 1, 2, 3]);
        // Each answer is a group of the same worker, as `take` counts them.
        for threads in 1..=8 {
            for k in 0..8 {
                assert_eq!(home(next(k, threads), 8, threads), home(k, 8, threads), "group {k}, {threads} workers");
            }
        }
    }

    #[test]
    fn tasks_that_share_a_particle_are_always_ordered() {
        // Every pair of tasks over 3 passes of 2 to 6 groups, either chain.
        for chain in [Chain::BlocksAndSeams, Chain::Tiles] {
            for groups in 2..=6 {
                let s = Schedule::new(chain, groups, 3);
                let pairs = unordered_sharing(&s, &|t| s.follows(t).collect());
                assert!(pairs.is_empty(), "{chain:?}, {groups} groups: unordered tasks sharing one: {pairs:?}");
            }
        }
        // The check can fail: without the odd seams' edges to the even
        // seams of their pass, seams 0 and 1 of pass 0 (both in block 1)
        // are unordered.
        let s = Schedule::new(Chain::BlocksAndSeams, 4, 3);
        let blocks_only = |t: Task| s.follows(t).filter(|p| s.seam(*p).is_none() || p.pass < t.pass).collect();
        let pairs = unordered_sharing(&s, &blocks_only);
        assert!(pairs.contains(&(Task { pass: 0, node: 4 }, Task { pass: 0, node: 5 })), "{pairs:?}");
        // Nor without an odd tile's edge to the even tile after it: tile 1
        // (its seam reaches into tile 2) and tile 2 of pass 0 are unordered.
        let s = Schedule::new(Chain::Tiles, 4, 3);
        let left_only = |t: Task| s.follows(t).filter(|p| p.node < t.node || p.pass < t.pass).collect();
        let pairs = unordered_sharing(&s, &left_only);
        assert!(pairs.contains(&(Task { pass: 0, node: 1 }, Task { pass: 0, node: 2 })), "{pairs:?}");
    }

    #[test]
    fn every_task_runs_once_after_those_it_follows_in_any_order_of_taking() {
        // Taken by thread 0, by the last of three threads, and in an order
        // shuffled by a fixed LCG: each task once, each after its
        // prerequisites, every one of the 5 passes × 9 nodes (5 blocks and
        // their 4 seams) or 5 × 5 tiles.
        for (chain, policy) in
            [Chain::BlocksAndSeams, Chain::Tiles].into_iter().flat_map(|c| (0..3).map(move |p| (c, p)))
        {
            let mut s = Schedule::new(chain, 5, 5);
            let mut done = vec![false; 5 * s.nodes()];
            let mut lcg = 12_345u64;
            loop {
                let t = match policy {
                    0 => s.take(0, 1),
                    1 => s.take(2, 3),
                    _ if s.ready.is_empty() => None,
                    _ => {
                        lcg = lcg.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                        Some(s.ready.swap_remove((lcg >> 33) as usize % s.ready.len()))
                    }
                };
                let Some(t) = t else { break };
                assert!(s.follows(t).all(|p| done[s.index(p)]), "{t:?} ran before a task it follows");
                assert!(!done[s.index(t)], "{t:?} ran twice");
                done[s.index(t)] = true;
                s.complete(t);
            }
            assert!(s.finished() && done.iter().all(|&d| d), "{chain:?}, policy {policy}: not every task ran");
        }
    }

    #[test]
    fn a_panicking_task_stops_every_worker_and_is_raised() {
        // On two threads, the task of seam 1 in pass 2 panics: the tasks
        // after it never become ready, so a worker that kept waiting for
        // them would hang; instead the call returns by raising the panic.
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a pool");
        let bad = Task { pass: 2, node: 4 + 1 };
        let result = pool.install(|| {
            std::panic::catch_unwind(|| {
                run(Schedule::new(Chain::BlocksAndSeams, 4, 5), 2, &|t| assert_ne!(t, bad, "the task meant to fail"));
            })
        });
        assert!(result.is_err());
    }
}
