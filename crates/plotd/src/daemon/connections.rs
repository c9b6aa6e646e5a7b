//! Which client connections the daemon keeps: at most `max_connections` in
//! all and `max_connections_per_uid` per user. A new connection over a limit
//! takes the place of the connection that has waited longest for a request
//! (its own user's, or the user holding the most), which is closed; when
//! every one is busy (mid-request, or watching) the new one is refused with
//! an error line. So idle connections held by one user can delay nobody,
//! and the daemon never runs out of file descriptors for its spool and ports.
//! Connections silent for `idle_timeout_s` are closed by the server.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tokio::sync::Notify;

/// The limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Connections in all.
    pub total: usize,
    /// Connections per uid.
    pub per_uid: usize,
}

#[derive(Debug)]
struct Conn {
    uid: u32,
    /// Since when it waits for a request; `None` while it is busy.
    idle_since: Option<Instant>,
    /// Told to close: it was displaced by a newer connection.
    close: Arc<Notify>,
}

/// The open connections.
#[derive(Debug)]
pub struct Connections {
    limits: Limits,
    open: Mutex<(u64, HashMap<u64, Conn>)>,
}

/// Why a connection was not admitted.
#[derive(Debug, PartialEq, Eq)]
pub struct Refused {
    /// For the client.
    pub message: String,
}

/// An admitted connection; leaving it (drop) frees its place.
#[derive(Debug)]
pub struct Slot {
    id: u64,
    conns: Arc<Connections>,
    close: Arc<Notify>,
}

impl Connections {
    /// No connections yet, under `limits`.
    #[must_use]
    pub fn new(limits: Limits) -> Arc<Connections> {
        Arc::new(Connections { limits, open: Mutex::new((0, HashMap::new())) })
    }

    /// Admits a connection from `uid` (idle), displacing an idle one if a
    /// limit is reached.
    ///
    /// # Errors
    /// [`Refused`] when a limit is reached and every connection that could
    /// give way is busy.
    pub fn admit(self: &Arc<Self>, uid: u32, now: Instant) -> Result<Slot, Refused> {
        let mut guard = self.open.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let (next, open) = &mut *guard;
        let of_uid = open.values().filter(|c| c.uid == uid).count();
        let victim_uid = if of_uid >= self.limits.per_uid {
            Some((uid, format!("uid {uid} holds {of_uid} connections, the limit per user (max_connections_per_uid)")))
        } else if open.len() >= self.limits.total {
            // The user holding the most gives way.
            let mut counts: HashMap<u32, usize> = HashMap::new();
            for c in open.values() {
                *counts.entry(c.uid).or_default() += 1;
            }
            let top = counts.into_iter().max_by_key(|&(u, n)| (n, u == uid)).map_or(uid, |(u, _)| u);
            Some((top, format!("{} connections are open, the limit (max_connections)", open.len())))
        } else {
            None
        };
        if let Some((victim_uid, why)) = victim_uid {
            let oldest = open.iter().filter(|(_, c)| c.uid == victim_uid).filter_map(|(id, c)| c.idle_since.map(|t| (t, *id))).min();
            let Some((_, id)) = oldest else {
                return Err(Refused { message: format!("too many connections: {why}, all busy; try again later") });
            };
            if let Some(c) = open.remove(&id) {
                c.close.notify_one();
            }
        }
        let close = Arc::new(Notify::new());
        let id = *next;
        *next += 1;
        open.insert(id, Conn { uid, idle_since: Some(now), close: Arc::clone(&close) });
        Ok(Slot { id, conns: Arc::clone(self), close })
    }

    fn set_idle(&self, id: u64, idle_since: Option<Instant>) {
        let mut guard = self.open.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(c) = guard.1.get_mut(&id) {
            c.idle_since = idle_since;
        }
    }

    /// Connections open now.
    #[must_use]
    pub fn count(&self) -> usize {
        self.open.lock().unwrap_or_else(std::sync::PoisonError::into_inner).1.len()
    }
}

impl Slot {
    /// The connection is working on a request (or watching): it keeps its place.
    pub fn busy(&self) {
        self.conns.set_idle(self.id, None);
    }

    /// The connection waits for a request, from `now`.
    pub fn idle(&self, now: Instant) {
        self.conns.set_idle(self.id, Some(now));
    }

    /// Resolves when a newer connection has taken this one's place.
    pub async fn displaced(&self) {
        self.close.notified().await;
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut guard = self.conns.open.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        guard.1.remove(&self.id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_user_at_the_limit_displaces_its_longest_idle_connection() {
        let conns = Connections::new(Limits { total: 10, per_uid: 3 });
        let t0 = Instant::now();
        let at = |s: u64| t0 + Duration::from_secs(s);
        let a = conns.admit(1000, at(0)).unwrap();
        let b = conns.admit(1000, at(1)).unwrap();
        let c = conns.admit(1000, at(2)).unwrap();
        // `a` is busy: `b` waited longest of the idle ones and gives way.
        a.busy();
        let d = conns.admit(1000, at(3)).unwrap();
        assert_eq!(conns.count(), 3);
        let ids: Vec<u64> = conns.open.lock().unwrap().1.keys().copied().collect();
        assert!(!ids.contains(&b.id) && ids.contains(&a.id) && ids.contains(&c.id) && ids.contains(&d.id));
        // Another user is not touched by it.
        let other = conns.admit(2000, at(4)).unwrap();
        // All of 1000's busy: refused, saying why.
        c.busy();
        d.busy();
        let e = conns.admit(1000, at(5)).unwrap_err();
        assert!(e.message.contains("uid 1000") && e.message.contains("max_connections_per_uid"), "{}", e.message);
        drop(other);
        drop((a, b, c, d));
        assert_eq!(conns.count(), 0);
    }

    #[test]
    fn at_the_total_limit_the_user_holding_most_gives_way() {
        let conns = Connections::new(Limits { total: 4, per_uid: 4 });
        let t = Instant::now();
        let hog: Vec<Slot> = (0..3).map(|i| conns.admit(1, t + Duration::from_millis(i)).unwrap()).collect();
        let mine = conns.admit(2, t).unwrap();
        // Full: a new user's connection displaces the hog's oldest idle one.
        let new = conns.admit(3, t + Duration::from_secs(1)).unwrap();
        let open: Vec<u32> = conns.open.lock().unwrap().1.values().map(|c| c.uid).collect();
        assert_eq!((open.len(), open.iter().filter(|&&u| u == 1).count()), (4, 2));
        assert!(open.contains(&2) && open.contains(&3));
        drop((hog, mine, new));
    }

    #[tokio::test]
    async fn a_displaced_connection_is_told() {
        let conns = Connections::new(Limits { total: 1, per_uid: 1 });
        let old = conns.admit(1, Instant::now()).unwrap();
        let _new = conns.admit(1, Instant::now()).unwrap();
        tokio::time::timeout(Duration::from_secs(1), old.displaced()).await.expect("told to close");
    }
}
