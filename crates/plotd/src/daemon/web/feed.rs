//! The page's live feed: the daemon's events, numbered, in a bounded ring.
//!
//! One task copies every event of the registry's broadcasts (what `watch`
//! reads: the jobs' events and the plotters' changes) into the ring with
//! the next sequence number. An event stream
//! reads the ring from the number after the last one its client saw, so a
//! browser that reconnects with `Last-Event-ID` gets every transition it
//! missed; one that was away longer than the ring holds is told to reload
//! (`resync`) rather than shown a state with a hole in its history.

use crate::protocol::{Event, PlotterChange};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use tokio::sync::broadcast::error::RecvError;
use tokio::sync::{broadcast, watch};

/// Events the ring keeps for clients that reconnect: at a few events a
/// second while plotting, minutes of history, in about 200 KiB.
pub const RING_EVENTS: usize = 2048;

/// What the feed carries.
#[derive(Clone, Debug, PartialEq)]
pub enum Entry {
    /// A job's event, as `watch` sends it.
    Job(Event),
    /// A plotter's state, after it changed, as `watch` sends it.
    Plotter(PlotterChange),
    /// Events were lost before they reached the ring (the daemon's
    /// broadcast ran ahead of the copying task): clients reload the state.
    Gap,
}

/// Where a client is to go on from.
#[derive(Debug, PartialEq)]
pub enum Since {
    /// These entries, in order, with their numbers (none: wait).
    Entries(Vec<(u64, Entry)>),
    /// The entries after the client's last one have left the ring: it must
    /// reload the state, then go on from `next`.
    Missed {
        /// The number of the oldest entry kept.
        next: u64,
    },
}

#[derive(Debug, Default)]
struct Ring {
    entries: VecDeque<(u64, Entry)>,
    /// The number the next entry gets (the first is 1).
    next: u64,
}

/// The numbered events, shared by the copying task and every stream.
#[derive(Debug)]
pub struct Feed {
    ring: Mutex<Ring>,
    capacity: usize,
    /// The number of the newest entry; streams wait on its changes.
    newest: watch::Sender<u64>,
    /// Tells this daemon's ids from another run's: numbers start at 1 again
    /// after a restart, and a browser's `Last-Event-ID` from before it
    /// must not skip the new run's first events.
    pub run: u64,
}

impl Feed {
    /// An empty feed keeping `capacity` entries, for the daemon run `run`.
    #[must_use]
    pub fn new(capacity: usize, run: u64) -> Arc<Feed> {
        Arc::new(Feed {
            ring: Mutex::new(Ring { entries: VecDeque::new(), next: 1 }),
            capacity: capacity.max(1),
            newest: watch::channel(0).0,
            run,
        })
    }

    fn lock(&self) -> MutexGuard<'_, Ring> {
        self.ring.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Appends `entry`, dropping the oldest beyond the capacity; returns its number.
    pub fn push(&self, entry: Entry) -> u64 {
        let mut ring = self.lock();
        let seq = ring.next;
        ring.next += 1;
        ring.entries.push_back((seq, entry));
        if ring.entries.len() > self.capacity {
            ring.entries.pop_front();
        }
        self.newest.send_replace(seq);
        seq
    }

    /// The number the next entry will get: a new client goes on from there.
    #[must_use]
    pub fn next(&self) -> u64 {
        self.lock().next
    }

    /// The entries numbered `from` and after.
    #[must_use]
    pub fn since(&self, from: u64) -> Since {
        let ring = self.lock();
        let oldest = ring.entries.front().map_or(ring.next, |(s, _)| *s);
        if from < oldest {
            return Since::Missed { next: oldest };
        }
        let skip = usize::try_from(from - oldest).unwrap_or(usize::MAX);
        Since::Entries(ring.entries.iter().skip(skip).cloned().collect())
    }

    /// Wakes when an entry is added.
    #[must_use]
    pub fn subscribe(&self) -> watch::Receiver<u64> {
        self.newest.subscribe()
    }

    /// Copies the daemon's job events and plotter changes into the feed
    /// until both broadcasts close.
    pub async fn copy(self: Arc<Feed>, mut events: broadcast::Receiver<Event>, mut changes: broadcast::Receiver<PlotterChange>) {
        let (mut jobs_open, mut plotters_open) = (true, true);
        while jobs_open || plotters_open {
            let got = tokio::select! {
                r = events.recv(), if jobs_open => r.map(Entry::Job),
                r = changes.recv(), if plotters_open => match r {
                    Err(RecvError::Closed) => {
                        plotters_open = false;
                        continue;
                    }
                    r => r.map(Entry::Plotter),
                },
            };
            match got {
                Ok(entry) => {
                    self.push(entry);
                }
                Err(RecvError::Lagged(n)) => {
                    tracing::warn!(lost = n, "web feed fell behind the daemon's events; pages reload their state");
                    self.push(Entry::Gap);
                }
                Err(RecvError::Closed) => jobs_open = false,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(job: u64) -> Entry {
        let json =
            serde_json::json!({"job": job, "state": "queued", "strokes_done": 0, "strokes_total": null, "bytes_acked": 0, "eta_s": null});
        Entry::Job(serde_json::from_value(json).unwrap())
    }

    fn numbers(since: Since) -> Vec<u64> {
        match since {
            Since::Entries(e) => e.into_iter().map(|(s, _)| s).collect(),
            Since::Missed { next } => panic!("missed, go on from {next}"),
        }
    }

    #[test]
    fn a_client_gets_what_came_after_its_last_entry_and_no_more() {
        let feed = Feed::new(4, 7);
        assert_eq!(feed.next(), 1);
        assert_eq!(numbers(feed.since(1)), Vec::<u64>::new());
        for j in 1..=3 {
            feed.push(event(j));
        }
        assert_eq!(numbers(feed.since(1)), [1, 2, 3]);
        assert_eq!(numbers(feed.since(3)), [3]);
        assert_eq!(numbers(feed.since(4)), Vec::<u64>::new());
        // An id from the future (another run's) finds nothing, never a panic.
        assert_eq!(numbers(feed.since(99)), Vec::<u64>::new());
        let Since::Entries(e) = feed.since(2) else { panic!() };
        assert_eq!(e[0].1, event(2));
    }

    #[test]
    fn a_client_away_longer_than_the_ring_is_told_it_missed_some() {
        let feed = Feed::new(4, 7);
        for j in 1..=6 {
            feed.push(event(j));
        }
        // 1 and 2 have left the ring.
        assert_eq!(feed.since(2), Since::Missed { next: 3 });
        assert_eq!(numbers(feed.since(3)), [3, 4, 5, 6]);
    }

    #[tokio::test]
    async fn the_copy_numbers_every_event_and_marks_a_lost_stretch() {
        let (tx, rx) = broadcast::channel(2);
        let feed = Feed::new(16, 1);
        // Three sent before the copy reads: the broadcast keeps two.
        for j in 1..=3 {
            let Entry::Job(ev) = event(j) else { unreachable!() };
            tx.send(ev).unwrap();
        }
        drop(tx);
        let (_, changes) = broadcast::channel(2);
        feed.clone().copy(rx, changes).await;
        let Since::Entries(e) = feed.since(1) else { panic!() };
        let got: Vec<Entry> = e.into_iter().map(|(_, e)| e).collect();
        assert_eq!(got, [Entry::Gap, event(2), event(3)]);
    }

    /// A plotter's change is numbered in the same ring as the jobs'
    /// events, so a reconnecting page gets those it missed too.
    #[tokio::test]
    async fn the_copy_numbers_the_plotters_changes_with_the_jobs_events() {
        let (jobs, rx) = broadcast::channel(8);
        let (plotters, changes) = broadcast::channel(8);
        let feed = Feed::new(16, 1);
        let copying = tokio::spawn(feed.clone().copy(rx, changes));
        let change = PlotterChange {
            plotter: "hp".into(),
            link: crate::protocol::LinkState::Offline,
            cause: Some(crate::protocol::LinkCause::new(crate::protocol::LinkFault::NoSuchPort, "/dev/ttyUSB0: no such file")),
            sheet: crate::spool::Sheet::Fresh,
            offset_mm: [0.0, 0.0],
            pen_loaded: None,
            v: 1,
        };
        plotters.send(change.clone()).unwrap();
        let mut newest = feed.subscribe();
        newest.wait_for(|n| *n == 1).await.unwrap();
        let Entry::Job(ev) = event(1) else { unreachable!() };
        jobs.send(ev).unwrap();
        drop((jobs, plotters));
        copying.await.unwrap();
        let Since::Entries(e) = feed.since(1) else { panic!() };
        assert_eq!(e, [(1, Entry::Plotter(change)), (2, event(1))]);
    }
}
