//! The submit checks' pool: each check runs a job worker with the whole
//! render budget, so at most [`CheckPool::workers`] run at once (one per
//! plotter plus one, fixed at start) and the rest wait. The waiting are
//! served user by user in turn (round robin by uid, each user's in the
//! order they came), and a user holds at most [`MAX_CHECKS_PER_UID`]
//! checks waiting or running: a further submit is refused with the reason,
//! so one user's flood neither fills the queue nor delays another user's
//! check by more than one check per worker.

use std::collections::{BTreeMap, VecDeque};
use std::future::Future;
use std::sync::{Mutex, MutexGuard};
use tokio::sync::oneshot;

/// Submit checks one user may have waiting or running at once: a batch
/// submitted from a shell loop (`for f in *.svg; do plotd submit $f & done`)
/// goes in, while a flood's waiting requests (each up to
/// `max_request_bytes` in memory) stay bounded; the pool serves users in
/// turn, so one user's share never delays another's.
pub const MAX_CHECKS_PER_UID: usize = 16;

/// A submit refused because its user's share of the pool is full.
#[derive(Debug, PartialEq, Eq)]
pub struct ShareFull {
    /// The user.
    pub uid: u32,
}

impl std::fmt::Display for ShareFull {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "uid {} already has {MAX_CHECKS_PER_UID} submits being checked, its share of the daemon's checks; submit again once one is answered",
            self.uid
        )
    }
}

/// The pool. See the module doc.
#[derive(Debug)]
pub struct CheckPool {
    /// Checks that run at once.
    workers: usize,
    state: Mutex<State>,
}

#[derive(Debug, Default)]
struct State {
    /// Checks running now.
    running: usize,
    /// The most that ever ran at once.
    peak: usize,
    /// Checks waiting or running, per uid.
    held: BTreeMap<u32, usize>,
    /// The waiting, per uid, each told through its sender when its turn comes.
    waiting: BTreeMap<u32, VecDeque<oneshot::Sender<()>>>,
    /// The uid served last: the next turn goes to the next uid after it.
    last: Option<u32>,
}

impl State {
    /// Hands a freed slot to the next waiting check (the next uid after
    /// the last served, in turn); returns whether one took it.
    fn hand_on(&mut self) -> bool {
        loop {
            let after = self.last.map_or(0, |u| u.saturating_add(1));
            let uid = self.waiting.range(after..).next().or_else(|| self.waiting.iter().next()).map(|(u, _)| *u);
            let Some(uid) = uid else { return false };
            let queue = self.waiting.get_mut(&uid).expect("just found");
            let next = queue.pop_front();
            if queue.is_empty() {
                self.waiting.remove(&uid);
            }
            self.last = Some(uid);
            // A check whose client went away while it waited takes nothing.
            if next.is_some_and(|tx| tx.send(()).is_ok()) {
                return true;
            }
        }
    }
}

impl CheckPool {
    /// A pool running `workers` checks at once (at least one).
    #[must_use]
    pub fn new(workers: usize) -> CheckPool {
        CheckPool { workers: workers.max(1), state: Mutex::new(State::default()) }
    }

    /// Checks that run at once.
    #[must_use]
    pub fn workers(&self) -> usize {
        self.workers
    }

    /// Checks running now, and the most that ever ran at once.
    #[must_use]
    pub fn running(&self) -> (usize, usize) {
        let s = self.lock();
        (s.running, s.peak)
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Runs `check` for `uid` once a worker is free and its turn has come.
    ///
    /// # Errors
    /// [`ShareFull`] when `uid` already holds [`MAX_CHECKS_PER_UID`].
    pub async fn run<F: Future>(&self, uid: u32, check: F) -> Result<F::Output, ShareFull> {
        let turn = {
            let mut s = self.lock();
            let held = s.held.entry(uid).or_default();
            if *held >= MAX_CHECKS_PER_UID {
                return Err(ShareFull { uid });
            }
            *held += 1;
            if s.running < self.workers && s.waiting.is_empty() {
                s.running += 1;
                s.peak = s.peak.max(s.running);
                s.last = Some(uid);
                None
            } else {
                let (tx, rx) = oneshot::channel();
                s.waiting.entry(uid).or_default().push_back(tx);
                Some(rx)
            }
        };
        let mut place = Place { pool: self, uid, started: turn.is_none(), turn };
        if let Some(rx) = place.turn.as_mut() {
            // The sender is only dropped unsent by a pool that is gone.
            let _ = rx.await;
            place.started = true;
            place.turn = None;
        }
        Ok(check.await)
    }
}

/// A check's place in the pool, given back when it ends or its client goes.
struct Place<'a> {
    pool: &'a CheckPool,
    uid: u32,
    /// It holds a worker.
    started: bool,
    /// Its turn, while it waits.
    turn: Option<oneshot::Receiver<()>>,
}

impl Drop for Place<'_> {
    fn drop(&mut self) {
        let mut s = self.pool.lock();
        if let Some(held) = s.held.get_mut(&self.uid) {
            *held -= 1;
            if *held == 0 {
                s.held.remove(&self.uid);
            }
        }
        // A turn handed over just as its client went is a worker to pass on.
        let handed = self.turn.as_mut().is_some_and(|rx| rx.try_recv().is_ok());
        if (self.started || handed) && !s.hand_on() {
            s.running -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use tokio::sync::Notify;

    /// A check that counts itself live until `release` lets it go, and
    /// records which (uid, n) ran, in order.
    struct Checks {
        live: AtomicUsize,
        most: AtomicUsize,
        release: Notify,
        order: Mutex<Vec<(u32, usize)>>,
    }

    impl Checks {
        fn new() -> Arc<Checks> {
            Arc::new(Checks { live: AtomicUsize::new(0), most: AtomicUsize::new(0), release: Notify::new(), order: Mutex::new(Vec::new()) })
        }

        /// Submits check `n` of `uid` to `pool` on a task of its own.
        fn submit(self: &Arc<Self>, pool: &Arc<CheckPool>, uid: u32, n: usize) -> tokio::task::JoinHandle<Result<(), ShareFull>> {
            let (pool, checks) = (Arc::clone(pool), Arc::clone(self));
            tokio::spawn(async move { pool.run(uid, checks.check(uid, n)).await })
        }

        async fn check(&self, uid: u32, n: usize) {
            let live = self.live.fetch_add(1, Ordering::SeqCst) + 1;
            self.most.fetch_max(live, Ordering::SeqCst);
            self.order.lock().unwrap().push((uid, n));
            self.release.notified().await;
            self.live.fetch_sub(1, Ordering::SeqCst);
        }
    }

    /// Lets the spawned tasks run until none can go on.
    async fn settle() {
        for _ in 0..50 {
            tokio::task::yield_now().await;
        }
    }

    /// A flood of K submits from one user runs at most the pool's size at
    /// once (counted by the checks themselves), refuses beyond the user's
    /// share with the reason, and a second user's check runs next, ahead of
    /// the first user's waiting ones.
    #[tokio::test]
    async fn a_flood_runs_at_most_the_pool_and_another_user_is_served_in_turn() {
        let pool = Arc::new(CheckPool::new(2));
        let checks = Checks::new();
        let mut tasks = Vec::new();
        let flood = MAX_CHECKS_PER_UID + 6;
        for n in 0..flood {
            tasks.push(checks.submit(&pool, 1000, n));
            settle().await;
        }
        settle().await;
        assert_eq!(checks.live.load(Ordering::SeqCst), 2, "two workers busy");
        assert_eq!(pool.running(), (2, 2));
        // Beyond the share: refused at once, with the reason.
        let mut refused = 0;
        for t in tasks.drain(MAX_CHECKS_PER_UID..) {
            let e = t.await.unwrap().unwrap_err();
            assert_eq!(e, ShareFull { uid: 1000 });
            assert!(e.to_string().contains(&format!("uid 1000 already has {MAX_CHECKS_PER_UID} submits being checked")), "{e}");
            refused += 1;
        }
        assert_eq!(refused, flood - MAX_CHECKS_PER_UID);
        // Another user's check waits for a worker, and goes before the
        // first user's waiting ones.
        let other = checks.submit(&pool, 1001, 0);
        settle().await;
        for _ in 0..=MAX_CHECKS_PER_UID {
            checks.release.notify_one();
            settle().await;
            assert!(checks.live.load(Ordering::SeqCst) <= 2);
        }
        other.await.unwrap().unwrap();
        for t in tasks {
            t.await.unwrap().unwrap();
        }
        let order = checks.order.lock().unwrap().clone();
        let first_user = (2..MAX_CHECKS_PER_UID).map(|n| (1000, n));
        let expected: Vec<_> = [(1000, 0), (1000, 1), (1001, 0)].into_iter().chain(first_user).collect();
        assert_eq!(order, expected);
        assert_eq!(checks.most.load(Ordering::SeqCst), 2);
        assert_eq!(pool.running(), (0, 2));
        assert!(pool.lock().held.is_empty(), "every place given back");
    }

    /// A client that goes away while its check waits takes no worker, and
    /// gives its share back.
    #[tokio::test]
    async fn a_waiting_check_whose_client_went_frees_its_place() {
        let pool = Arc::new(CheckPool::new(1));
        let checks = Checks::new();
        let first = checks.submit(&pool, 7, 0);
        settle().await;
        let gone = checks.submit(&pool, 7, 1);
        settle().await;
        gone.abort();
        settle().await;
        assert_eq!(pool.lock().held.get(&7), Some(&1));
        checks.release.notify_one();
        first.await.unwrap().unwrap();
        assert_eq!(pool.running(), (0, 1));
        let next = checks.submit(&pool, 7, 2);
        settle().await;
        assert_eq!(checks.live.load(Ordering::SeqCst), 1, "the freed worker is taken");
        checks.release.notify_one();
        next.await.unwrap().unwrap();
        assert_eq!(*checks.order.lock().unwrap(), [(7, 0), (7, 2)]);
    }
}
