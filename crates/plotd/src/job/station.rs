//! A plotter as the job's life sees it: whether it answers, when to ask it
//! again, the job it runs and the stop asked of that run.
//!
//! The oldest unfinished job of a plotter holds it: a paused job blocks the
//! jobs behind it (they would be drawn on its paper). An idle plotter is
//! asked every [`IDLE_CHECK`] whether it is there, so that `status` shows a
//! dead one before a job finds it; a plotter that does not answer is asked
//! again after [`BACKOFF_MIN`], doubling up to [`BACKOFF_MAX`]. A plotter
//! takes its job only when it has just answered, and sets the device up
//! again then (it may have been power-cycled since the last job).

use super::action::StopReason;
use super::run::Run;
use crate::config::PlotterConfig;
use crate::protocol::{LinkCause, LinkState, Reach};
use crate::spool::{JobId, PauseCause, PlotterState};
use crate::stream::Stop;
use std::time::{Duration, Instant};

/// First wait before asking again a plotter that did not answer; doubles up
/// to [`BACKOFF_MAX`].
pub const BACKOFF_MIN: Duration = Duration::from_millis(250);
/// Longest wait between attempts to reach a plotter.
pub const BACKOFF_MAX: Duration = Duration::from_secs(30);
/// How often an idle plotter is asked whether it is there.
pub const IDLE_CHECK: Duration = Duration::from_secs(3);

/// One plotter's side of the job's life.
#[derive(Debug)]
pub(super) struct Station {
    /// Its configuration (replaced on SIGHUP).
    pub config: PlotterConfig,
    /// Whether it answered when last asked.
    pub link: LinkState,
    /// Why it did not, when it did not.
    pub cause: Option<LinkCause>,
    /// When to ask it next whether it is there; `None`: at once.
    next_probe: Option<Instant>,
    /// The wait after the next probe it does not answer.
    backoff: Duration,
    /// It answered the last probe, and nothing has been decided since.
    answered: bool,
    /// The job it runs.
    pub run: Option<Run>,
    /// Why its run was asked to stop.
    pub stop_reason: Option<StopReason>,
    /// The most its run was asked to stop (a stop now outranks one at the
    /// stroke's end).
    pub asked: Stop,
    /// What it keeps between jobs and across restarts (its sheet).
    pub state: PlotterState,
}

/// What a station does next, given the job at the head of its queue.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Next {
    /// Ask the device whether it is there.
    Probe,
    /// Nothing until then (`None`: until something happens).
    Wait(Option<Instant>),
    /// Run this job.
    Take(JobId),
}

/// The head of a plotter's queue: its oldest unfinished job, and why it is
/// paused when it is.
pub(super) type Head = Option<(JobId, Option<PauseCause>)>;

impl Station {
    pub fn new(config: PlotterConfig) -> Station {
        Station {
            config,
            link: LinkState::Unknown,
            cause: None,
            next_probe: None,
            backoff: BACKOFF_MIN,
            answered: false,
            run: None,
            stop_reason: None,
            asked: Stop::Continue,
            state: PlotterState::default(),
        }
    }

    /// The station's name.
    pub fn name(&self) -> &str {
        &self.config.name
    }

    /// What to do next with `head`. A paused job waits for a person, except
    /// one paused because the link went or the device reset: its plotter is
    /// watched, so that `status` shows when it is back (and `auto_resume`
    /// can go on after a lost link).
    pub fn next(&mut self, head: Head, now: Instant) -> Next {
        let answered = std::mem::take(&mut self.answered);
        let due = self.next_probe.is_none_or(|t| now >= t);
        let probe_when_due = if due { Next::Probe } else { Next::Wait(self.next_probe) };
        match head {
            None => probe_when_due,
            Some((_, Some(cause))) if super::position::watched(cause) => probe_when_due,
            Some((_, Some(_))) => Next::Wait(None),
            Some((id, None)) if answered => Next::Take(id),
            Some((_, None)) => probe_when_due,
        }
    }

    /// What the daemon knows of its port now.
    pub fn reach(&self) -> Reach {
        Reach { link: self.link, cause: self.cause.clone() }
    }

    /// Sets what the daemon knows of its port.
    pub fn set_reach(&mut self, answered: Result<(), LinkCause>) {
        (self.link, self.cause) = match answered {
            Ok(()) => (LinkState::Online, None),
            Err(cause) => (LinkState::Offline, Some(cause)),
        };
    }

    /// The device answered (`ok`) or not; `head` as when it was asked.
    /// Returns whether the head job, paused because the link went, goes on
    /// now (`auto_resume`).
    pub fn probed(&mut self, ok: bool, head: Head, now: Instant) -> bool {
        match head {
            None => self.next_probe = Some(now + IDLE_CHECK),
            Some((_, Some(PauseCause::Offline))) if ok && self.config.auto_resume => {
                self.next_probe = None;
                return true;
            }
            Some((_, None)) if ok => {
                self.backoff = BACKOFF_MIN;
                self.answered = true;
            }
            Some(_) => {
                self.next_probe = Some(now + self.backoff);
                self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
            }
        }
        false
    }

    /// Something changed for this plotter (a job came, was resumed or
    /// cancelled, its config was reloaded, its run ended): it looks at its
    /// queue again at once, asking the device first.
    pub fn wake(&mut self) {
        self.next_probe = None;
    }

    /// Starts running `job`, with no stop asked.
    pub fn start(&mut self, job: JobId) {
        self.run = Some(Run::new(job));
        self.stop_reason = None;
        self.asked = Stop::Continue;
    }

    /// Asks its run to stop for `why`, at least `how`; returns the stop now
    /// asked. A shutdown outranks a pause or a cancel already asked for.
    pub fn ask_stop(&mut self, why: StopReason, how: Stop) -> Stop {
        if self.stop_reason != Some(StopReason::Shutdown) {
            self.stop_reason = Some(why);
        }
        self.asked = self.asked.max(how);
        self.asked
    }

    /// Why its run was asked to stop, if it was, taken as the run ends (a
    /// run that ends while the daemon shuts down was stopped by the shutdown).
    pub fn why_stopped(&mut self, shutting_down: bool) -> Option<StopReason> {
        self.stop_reason.take().or(shutting_down.then_some(StopReason::Shutdown))
    }

    /// Its run is over (`lost`: the port must be opened afresh, for that
    /// cause): the plotter looks at its queue again at once.
    pub fn end_run(&mut self, lost: Option<LinkCause>) {
        self.run = None;
        self.asked = Stop::Continue;
        self.next_probe = None;
        if let Some(cause) = lost {
            self.set_reach(Err(cause));
        }
    }
}
