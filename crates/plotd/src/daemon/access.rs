//! Who may act on which job, and what each client reads of the others', on
//! a daemon shared by the users of its socket's group. A job belongs to the
//! uid that submitted it (the socket's peer credentials). Root and the
//! daemon's own user are operators: they act on and read every job. Any
//! other user may `cancel`, `pause` or `resume` only their own jobs, by id
//! (without one, these act on every user's jobs: operators only), and reads
//! another user's job only as its id, kind, plotter, uid, submission time,
//! state, pause cause and progress: its name, pid and reason (which may
//! quote its content or paths) are left out. `pen-changed` and
//! `sheet-loaded` say what a person did at a plotter: anyone may.

use super::registry::Registry;
use crate::protocol::{Event, JobInfo, Request};
use crate::spool::JobId;

/// Who a client is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Caller {
    /// Its uid (the socket's peer credentials).
    pub uid: u32,
    /// Root or the daemon's own user.
    pub operator: bool,
}

impl Caller {
    /// The client `uid`, for a daemon running as `daemon_uid`.
    #[must_use]
    pub fn new(uid: u32, daemon_uid: u32) -> Caller {
        Caller { uid, operator: uid == 0 || uid == daemon_uid }
    }

    /// The client `uid` of this daemon.
    #[must_use]
    pub fn of(uid: u32) -> Caller {
        Caller::new(uid, nix::unistd::geteuid().as_raw())
    }

    /// Whether it may act on, and read all of, a job submitted by `owner`.
    #[must_use]
    pub fn owns(self, owner: u32) -> bool {
        self.operator || self.uid == owner
    }

    /// `info` as this client reads it.
    #[must_use]
    pub fn sees(self, info: JobInfo) -> JobInfo {
        if self.owns(info.uid) {
            return info;
        }
        JobInfo { name: String::new(), pid: 0, reason: None, ..info }
    }

    /// `event`, of a job submitted by `owner` (`None`: a job forgotten
    /// since, read as another user's), as this client reads it.
    #[must_use]
    pub fn sees_event(self, event: Event, owner: Option<u32>) -> Event {
        if owner.is_some_and(|o| self.owns(o)) || self.operator {
            return event;
        }
        Event { reason: None, ..event }
    }

    /// Whether this client may make control request `req`; the refusal's
    /// message when not.
    ///
    /// # Errors
    /// Why not: another user's job, or every user's jobs at once.
    pub fn may(self, reg: &Registry, req: &Request) -> Result<(), String> {
        let (id, verb) = match req {
            Request::Cancel { id, .. } => (Some(*id), "cancel"),
            Request::Pause { id, .. } => (*id, "pause"),
            Request::Resume { id, .. } => (*id, "resume"),
            _ => return Ok(()),
        };
        if self.operator {
            return Ok(());
        }
        let Some(id) = id else {
            return Err(format!(
                "{verb} without a job id acts on every user's jobs: only root or the daemon's user may; name your job (plotd {verb} ID)"
            ));
        };
        self.may_act_on(reg, id, verb)
    }

    fn may_act_on(self, reg: &Registry, id: JobId, verb: &str) -> Result<(), String> {
        match reg.job(id) {
            // The machine answers for a job that does not exist.
            None => Ok(()),
            Some(job) if self.owns(job.uid) => Ok(()),
            Some(job) => Err(format!(
                "job {id} belongs to uid {}: only its submitter, root or the daemon's user may {verb} it (you are uid {})",
                job.uid, self.uid
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::State;
    use crate::spool::JobKind;

    fn info(uid: u32) -> JobInfo {
        JobInfo {
            id: 3,
            kind: JobKind::Hpgl,
            plotter: "hp".into(),
            class: None,
            name: "secret-plans.hpgl".into(),
            uid,
            pid: 42,
            submitted_at: 9,
            state: State::Failed,
            cause: None,
            reason: Some("/home/alice/secret-plans: line 3".into()),
            insert_pen: None,
            load_page: None,
            checkpoint: 2,
            total: Some(5),
            strokes_done: 1,
            strokes_total: Some(4),
            pen_loaded: None,
            page_loaded: 0,
            same_sheet: false,
            copies: 1,
            copy: 1,
            pens: std::collections::BTreeMap::new(),
            offset_mm: Default::default(),
            waiting: None,
        }
    }

    #[test]
    fn another_users_job_is_read_without_its_name_pid_or_reason() {
        let alice = Caller::new(1001, 999);
        assert_eq!(alice.sees(info(1001)), info(1001), "her own, whole");
        let seen = Caller::new(1002, 999).sees(info(1001));
        assert_eq!((seen.name.as_str(), seen.pid, seen.reason.as_deref()), ("", 0, None));
        assert_eq!((seen.id, seen.uid, seen.state, seen.checkpoint, seen.total), (3, 1001, State::Failed, 2, Some(5)));
        for operator in [Caller::new(0, 999), Caller::new(999, 999)] {
            assert!(operator.operator);
            assert_eq!(operator.sees(info(1001)), info(1001));
        }
    }
}
