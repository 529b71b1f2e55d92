//! The work queue of a render: the units of every pass in merge order,
//! handed out one at a time to whichever thread is free, so threads go on
//! to the next pass while the last units of one finish (no barrier between
//! passes, which on 16 threads and a small image idled 12% of the thread
//! time). Passes are taken out whole and in order by the one thread that
//! merges them. Units are handed out at most `ahead` beyond the end of the
//! oldest pass not yet taken, which bounds the results held at one pass
//! plus `ahead` units.

use std::collections::VecDeque;
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

/// How often a waiting thread looks at the stop condition, which a signal
/// handler may set without waking anyone.
const POLL: Duration = Duration::from_millis(20);

/// Units numbered 0.. in merge order, grouped into consecutive passes.
pub struct UnitQueue<T> {
    /// Index of each pass's first unit, then the number of units.
    starts: Vec<usize>,
    ahead: usize,
    state: Mutex<State<T>>,
    changed: Condvar,
}

struct State<T> {
    /// The next unit to hand out.
    next: usize,
    /// Passes taken out so far.
    taken: usize,
    /// Units handed out and not finished.
    in_flight: usize,
    /// Set once the stop condition was seen: nothing more is handed out.
    stopped: bool,
    /// Results of the units handed out from the oldest pass not taken on
    /// (unit `first_held` first): memory for one pass plus `ahead` units,
    /// not for the whole render.
    held: VecDeque<Option<T>>,
    first_held: usize,
    /// Per pass, units finished with a result.
    done: Vec<usize>,
}

/// What [`UnitQueue::try_take`] found.
pub enum Take<T> {
    /// The oldest pass not taken, its results in unit order.
    Pass(Vec<T>),
    /// That pass is not finished yet.
    Pending,
    /// It never will be (the queue stopped, or a unit of it was
    /// abandoned), or every pass was taken.
    Never,
}

impl<T> UnitQueue<T> {
    /// Passes of `pass_sizes` units each.
    pub fn new(pass_sizes: impl IntoIterator<Item = usize>, ahead: usize) -> UnitQueue<T> {
        let mut starts = vec![0];
        for n in pass_sizes {
            starts.push(starts.last().unwrap_or(&0) + n);
        }
        let passes = starts.len() - 1;
        UnitQueue {
            starts,
            ahead,
            state: Mutex::new(State {
                next: 0,
                taken: 0,
                in_flight: 0,
                stopped: false,
                held: VecDeque::new(),
                first_held: 0,
                done: vec![0; passes],
            }),
            changed: Condvar::new(),
        }
    }

    fn total(&self) -> usize {
        self.starts[self.starts.len() - 1]
    }

    fn passes(&self) -> usize {
        self.starts.len() - 1
    }

    fn pass_of(&self, unit: usize) -> usize {
        self.starts.partition_point(|&s| s <= unit) - 1
    }

    /// Unit `i`'s pass and its place in that pass.
    pub fn locate(&self, i: usize) -> (usize, usize) {
        let pass = self.pass_of(i);
        (pass, i - self.starts[pass])
    }

    fn lock(&self) -> MutexGuard<'_, State<T>> {
        // A panic while holding the lock poisons it; the data stays
        // consistent (each update is one step), so carry on.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Hands out the next unit if it may start now.
    fn claim_locked(&self, st: &mut State<T>, stop: &impl Fn() -> bool) -> Claim {
        if st.stopped || stop() {
            if !st.stopped {
                st.stopped = true;
                self.changed.notify_all();
            }
            return Claim::Never;
        }
        if st.next >= self.total() {
            return Claim::Never;
        }
        let oldest_end = self.starts[(st.taken + 1).min(self.passes())];
        if st.next >= oldest_end + self.ahead {
            return Claim::Later;
        }
        let i = st.next;
        st.next += 1;
        st.in_flight += 1;
        st.held.push_back(None);
        Claim::Unit(i)
    }

    /// The next unit to render, waiting while it would run too far ahead;
    /// `None` once every unit is handed out or `stop` says so.
    pub fn claim(&self, stop: impl Fn() -> bool) -> Option<usize> {
        let mut st = self.lock();
        loop {
            match self.claim_locked(&mut st, &stop) {
                Claim::Unit(i) => return Some(i),
                Claim::Never => return None,
                Claim::Later => {
                    st = self
                        .changed
                        .wait_timeout(st, POLL)
                        .unwrap_or_else(|e| e.into_inner())
                        .0;
                }
            }
        }
    }

    /// Like [`UnitQueue::claim`], without waiting: `None` also when the
    /// next unit may not start yet.
    pub fn try_claim(&self, stop: impl Fn() -> bool) -> Option<usize> {
        match self.claim_locked(&mut self.lock(), &stop) {
            Claim::Unit(i) => Some(i),
            Claim::Later | Claim::Never => None,
        }
    }

    /// Records unit `i`'s result; `None`: it was abandoned, so its pass
    /// will never be taken.
    pub fn finish(&self, i: usize, result: Option<T>) {
        let mut st = self.lock();
        st.in_flight -= 1;
        if let Some(r) = result {
            let at = i - st.first_held;
            st.held[at] = Some(r);
            let pass = self.pass_of(i);
            st.done[pass] += 1;
        }
        self.changed.notify_all();
    }

    /// The oldest pass not yet taken, if all its units are finished.
    pub fn try_take(&self) -> Take<T> {
        let mut st = self.lock();
        let pass = st.taken;
        if pass >= self.passes() {
            return Take::Never;
        }
        let (a, b) = (self.starts[pass], self.starts[pass + 1]);
        if st.done[pass] == b - a {
            st.taken += 1;
            st.first_held = b;
            // All of them hold a result: `done` counts only those.
            let results = st.held.drain(..b - a).flatten().collect();
            self.changed.notify_all();
            return Take::Pass(results);
        }
        // Unfinished: it can still finish while its units are handed out
        // or rendering; not once the queue stopped with none in flight,
        // nor after one of its units was abandoned (nothing in flight and
        // all of them handed out).
        let handed_out = st.next >= b;
        if st.in_flight == 0 && (st.stopped || handed_out) {
            Take::Never
        } else {
            Take::Pending
        }
    }

    /// Waits until something changes (or briefly, to look at a stop
    /// condition again).
    pub fn wait(&self) {
        let st = self.lock();
        drop(self.changed.wait_timeout(st, POLL));
    }
}

enum Claim {
    Unit(usize),
    /// Too far ahead of the oldest pass not taken.
    Later,
    Never,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicBool, Ordering};

    /// Drains a queue the way the renderer does: workers claim, one thread
    /// takes passes in order (rendering while it waits).
    fn drain(q: &UnitQueue<usize>, threads: usize, stop: &AtomicBool) -> Vec<Vec<usize>> {
        let stopped = || stop.load(Ordering::Relaxed);
        let mut passes = Vec::new();
        std::thread::scope(|s| {
            for _ in 1..threads {
                s.spawn(|| {
                    while let Some(i) = q.claim(stopped) {
                        q.finish(i, Some(i * 10));
                    }
                });
            }
            loop {
                match q.try_take() {
                    Take::Pass(p) => passes.push(p),
                    Take::Never => break,
                    Take::Pending => match q.try_claim(stopped) {
                        Some(i) => q.finish(i, Some(i * 10)),
                        None => q.wait(),
                    },
                }
            }
        });
        passes
    }

    #[test]
    fn passes_come_out_whole_and_in_order_on_any_thread_count() {
        let sizes = [1, 3, 0, 7, 2, 16];
        let q: UnitQueue<usize> = UnitQueue::new(sizes, 2);
        assert_eq!(q.locate(0), (0, 0));
        assert_eq!(q.locate(3), (1, 2));
        assert_eq!(q.locate(4), (3, 0), "the empty pass holds no unit");
        assert_eq!(q.locate(12), (4, 1));
        for threads in [1, 2, 5] {
            let q = UnitQueue::new(sizes, 2);
            let passes = drain(&q, threads, &AtomicBool::new(false));
            let mut next = 0;
            assert_eq!(passes.len(), sizes.len());
            for (p, &n) in passes.iter().zip(&sizes) {
                let want: Vec<usize> = (next..next + n).map(|i| i * 10).collect();
                assert_eq!(p, &want);
                next += n;
            }
        }
    }

    #[test]
    fn units_are_not_handed_out_beyond_the_window() {
        let q: UnitQueue<usize> = UnitQueue::new([2, 2, 2], 1);
        let go = || false;
        // Pass 0 and one unit ahead.
        assert_eq!(q.try_claim(go), Some(0));
        assert_eq!(q.try_claim(go), Some(1));
        assert_eq!(q.try_claim(go), Some(2));
        assert_eq!(q.try_claim(go), None);
        q.finish(2, Some(2));
        q.finish(0, Some(0));
        assert!(matches!(q.try_take(), Take::Pending));
        q.finish(1, Some(1));
        assert!(matches!(q.try_take(), Take::Pass(p) if p == [0, 1]));
        // Pass 1 is the oldest now: units up to pass 2's first may start.
        assert_eq!(q.try_claim(go), Some(3));
        assert_eq!(q.try_claim(go), Some(4));
        assert_eq!(q.try_claim(go), None);
    }

    #[test]
    fn a_stop_keeps_the_finished_passes_and_drops_the_rest() {
        let q: UnitQueue<usize> = UnitQueue::new([2, 2], 4);
        let go = || false;
        for _ in 0..3 {
            let i = q.try_claim(go).unwrap();
            q.finish(i, Some(i));
        }
        assert_eq!(q.try_claim(|| true), None);
        assert_eq!(q.try_claim(go), None, "a stop is final");
        assert!(matches!(q.try_take(), Take::Pass(p) if p == [0, 1]));
        assert!(matches!(q.try_take(), Take::Never));
        // Also when the stop is seen by the waiting thread alone.
        let stop = AtomicBool::new(true);
        let q = UnitQueue::new([3, 3], 4);
        assert!(drain(&q, 3, &stop).is_empty());
    }

    #[test]
    fn an_abandoned_unit_ends_its_pass() {
        let q: UnitQueue<usize> = UnitQueue::new([2, 1], 0);
        let go = || false;
        let (a, b) = (q.try_claim(go).unwrap(), q.try_claim(go).unwrap());
        q.finish(a, Some(a));
        assert!(matches!(q.try_take(), Take::Pending));
        q.finish(b, None);
        assert!(matches!(q.try_take(), Take::Never));
    }
}
