//! Every fault class the end-to-end tests prove on a pty, on the job's life
//! alone: results scripted, the clock moved by hand, and each step's
//! actions asserted in full, in order. A [`Desk`] plays the daemon's part:
//! it carries out saves (on a disk that can be full), removals and
//! announcements, and shows every action as a line.

use super::*;
use crate::config::Config;
use crate::protocol::{LinkCause, LinkFault, LinkState};
use crate::spool::{JobId, JobKind, JobRecord, JobState, PauseCause, PlotterState, Sheet, SpoolError, WrittenMark};
use crate::stream::{DeviceError, ErrorAt, Excerpt, Hold, Outcome, Reset, Restore, StreamError};
use crate::written::Written;
use plotcode::answer::ErrorCode;
use plotcode::{DeviceProfile, Program};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// What a full disk says (as a file size limit makes it).
const FULL: &str = "spool /s/jobs/1.json: File too large (os error 27)";

/// The spool's error for OS error `errno` (27: a full disk, as a file size
/// limit makes it; 30: a read-only file system).
fn disk_error(errno: i32) -> SpoolError {
    SpoolError::Io { path: "/s/jobs/1.json".into(), source: std::io::Error::from_raw_os_error(errno) }
}

/// The daemon's part, by hand.
struct Desk {
    life: JobLife,
    now: Instant,
    /// The spool's records, as saved.
    disk: BTreeMap<JobId, JobRecord>,
    /// Every save fails.
    full: bool,
    /// Removals fail too.
    read_only: bool,
    /// The plotters' states, as saved. Their saves are not shown as lines:
    /// the sheet's tests read them here, and the other tests' lines stay
    /// what the job does.
    plotters_disk: BTreeMap<String, PlotterState>,
    /// The plotters announced to watchers (their links' changes), with
    /// their link then; not shown as lines either.
    plotters_announced: Vec<(String, LinkState)>,
}

/// A config with one plotter: `hp` (an HP 7475A, six pens) or `cnc` (a
/// GRBL board with a servo pen, one pen); `extra` goes in its table.
fn plotters(name: &str, extra: &str) -> Vec<crate::config::PlotterConfig> {
    let (device, handshake) = if name == "hp" { ("hp7475a", "escb") } else { ("grbl-servo", "grbl") };
    let text = format!(
        "socket = \"/s/plotd.sock\"\nspool = \"/s\"\n[[plotter]]\nname = \"{name}\"\nport = \"/dev/ttyUSB0\"\ndevice = \"{device}\"\nhandshake = \"{handshake}\"\n{extra}\n"
    );
    Config::from_toml(&text, "test").expect("test config").plotters
}

/// `n` HP-GL strokes and the job's tail, cut for an HP 7475A: `n + 1` chunks.
fn hpgl(n: usize) -> Program {
    let mut text = String::from("IN;SP1;");
    for k in 0..n {
        text += &format!("PU{},0;PD{},400;", 500 * k, 500 * k);
    }
    text += "PU;SP0;";
    let program = plotcode::cut(text.as_bytes(), &DeviceProfile::builtin("hp7475a").unwrap()).unwrap();
    assert_eq!(program.chunks.len(), n + 1, "one chunk per stroke, and the tail");
    program
}

/// Two strokes with pen 1, then two with pen 2, for a one-pen GRBL board.
fn two_pens() -> Program {
    let mut g = String::from("G21 G90\nM5\n");
    for (k, pen) in [1, 1, 2, 2].into_iter().enumerate() {
        if k % 2 == 0 {
            g += &format!("T{pen}\n");
        }
        g += &format!("G0 X{0} Y10\nM3 S1000\nG1 X{0} Y30 F3000\nM5\n", 10 + 20 * k);
    }
    let program = plotcode::cut(g.as_bytes(), &DeviceProfile::builtin("grbl-servo").unwrap()).unwrap();
    let pens: Vec<Option<u32>> = program.chunks.iter().filter(|c| c.draws).map(|c| c.pen).collect();
    assert_eq!(pens, [Some(1), Some(1), Some(2), Some(2)]);
    program
}

/// What a plotter that does not answer is offline for.
fn silent() -> LinkCause {
    LinkCause::new(LinkFault::Silent, "no answer to ESC.B for 10 s")
}

fn offline() -> StreamError {
    StreamError::Offline(std::io::Error::from_raw_os_error(5))
}

fn reset() -> StreamError {
    StreamError::Reset(Reset::PowerOnTerminator { answer: Excerpt::of("1024") })
}

/// A job record as a spool holds it.
fn record(id: JobId, plotter: &str, state: JobState, checkpoint: usize) -> JobRecord {
    JobRecord {
        uid: 1000,
        pid: 7,
        state,
        checkpoint,
        total: (checkpoint > 0).then_some(9),
        strokes_done: checkpoint,
        strokes_total: (checkpoint > 0).then_some(8),
        ..JobRecord::queued(id, plotter, &format!("job-{id}"))
    }
}

/// An action as a line: what it is, and what of it matters.
fn show(a: &Action) -> String {
    let state = |r: &JobRecord| match &r.state {
        JobState::Paused { cause, .. } => format!("paused/{}", serde_json::to_value(cause).unwrap().as_str().unwrap()),
        s => s.name().to_owned(),
    };
    match a {
        Action::Save(s) => format!("save {} {} @{}", s.record.id, state(&s.record), s.record.checkpoint),
        Action::SaveCheckpoint(s) => format!("checkpoint {} {} @{}", s.record.id, state(&s.record), s.record.checkpoint),
        Action::Announce(r) => format!("announce {} {}", r.id, state(r)),
        Action::Remove { job, why: Removal::Pruned } => format!("remove {job} (pruned)"),
        Action::Remove { job, why: Removal::Cancelled { .. } } => format!("remove {job} (cancelled, unsaved)"),
        Action::ForgetWritten(job) => format!("forget mark {job}"),
        Action::Stop { plotter, how } => format!("stop {plotter} {how:?}"),
        Action::Wake(plotter) => format!("wake {plotter}"),
        Action::SavePlotter { .. } | Action::AnnouncePlotter(_) => unreachable!("kept by the desk, not shown"),
        Action::Reply(Ok(m)) => format!("ok: {m}"),
        Action::Reply(Err(e)) => format!("refused: {e}"),
        Action::Render { job, offset_mm: [0.0, 0.0], .. } => format!("render {job}"),
        Action::Render { job, offset_mm, .. } => format!("render {job} offset {offset_mm:?}"),
        Action::ReadMark(job) => format!("read mark {job}"),
        Action::Locate { from, mark, .. } => format!("locate from {from} in {mark:?}"),
        Action::StartMark(job) => format!("start mark {job}"),
        Action::Stream { from, until, resume, lift, restore, .. } => {
            let restore = match restore {
                Restore::Nothing => "",
                Restore::Confirmed => " confirmed",
                Restore::Home => " home",
            };
            format!("stream {from}..{until}{}{}{restore}", if *resume { " resume" } else { "" }, if *lift { " lift" } else { "" })
        }
        Action::Park { at_mm: [x, y] } => format!("park at ({x}, {y})"),
        Action::RunEnded { lost } => format!("run ended{}", if *lost { ", link lost" } else { "" }),
    }
}

impl Desk {
    fn new(plotters: &[crate::config::PlotterConfig], records: Vec<JobRecord>) -> Desk {
        let disk = records.iter().map(|r| (r.id, r.clone())).collect();
        let (life, restarted) = JobLife::new(records, 0, plotters, 100);
        let mut desk = Desk {
            life,
            now: Instant::now(),
            disk,
            full: false,
            read_only: false,
            plotters_disk: BTreeMap::new(),
            plotters_announced: Vec::new(),
        };
        for r in restarted {
            desk.disk.insert(r.id, r);
        }
        desk
    }

    fn plotter(&self) -> String {
        self.life.plotters().next().unwrap().name.clone()
    }

    /// Carries out `actions` as the registry does (what follows an action
    /// before the next one); every action, as a line.
    fn carry(&mut self, actions: Vec<Action>) -> Vec<String> {
        let mut lines = Vec::new();
        let mut todo: std::collections::VecDeque<Action> = actions.into();
        while let Some(a) = todo.pop_front() {
            if let Action::SavePlotter { plotter, state } = a {
                self.plotters_disk.insert(plotter, state);
                continue;
            }
            if let Action::AnnouncePlotter(plotter) = a {
                let link = self.life.plotter_state(&plotter).unwrap().0;
                self.plotters_announced.push((plotter, link));
                continue;
            }
            lines.push(show(&a));
            let next = match &a {
                Action::Save(s) | Action::SaveCheckpoint(s) => {
                    let result = if self.full {
                        Err(disk_error(27))
                    } else {
                        self.disk.insert(s.record.id, s.record.clone());
                        Ok(())
                    };
                    self.life.saved(s, result.as_ref().map(|_| ()))
                }
                Action::Remove { job, why } => {
                    let result = if self.read_only {
                        Err(disk_error(30))
                    } else {
                        self.disk.remove(job);
                        Ok(())
                    };
                    self.life.removed(*job, why, result.as_ref().map(|_| ()))
                }
                _ => Vec::new(),
            };
            for n in next.into_iter().rev() {
                todo.push_front(n);
            }
        }
        lines
    }

    fn poll(&mut self) -> Step {
        let name = self.plotter();
        self.life.poll(&name, self.now)
    }

    /// The plotter is asked whether it is there, and answers `ok` (or is
    /// silent).
    fn probe(&mut self, ok: bool) -> Vec<String> {
        self.probe_as(if ok { Ok(()) } else { Err(silent()) })
    }

    /// The plotter is asked whether it is there: it answers, or why not.
    fn probe_as(&mut self, answered: Result<(), LinkCause>) -> Vec<String> {
        assert_eq!(self.poll(), Step::Probe);
        let name = self.plotter();
        let actions = self.life.probed(&name, answered, self.now);
        self.carry(actions)
    }

    /// The plotter answers, and takes its next job: the run's first actions.
    fn take(&mut self) -> Vec<String> {
        // Jobs that showed their plotter offline are told again.
        let probed = self.probe(true);
        assert!(probed.iter().all(|l| l.starts_with("announce ")), "{probed:?}");
        match self.poll() {
            Step::Run { actions, .. } => self.carry(actions),
            other => panic!("the plotter did not take its job: {other:?}"),
        }
    }

    fn feed(&mut self, f: impl FnOnce(&mut JobLife, &str) -> Vec<Action>) -> Vec<String> {
        let name = self.plotter();
        let actions = f(&mut self.life, &name);
        self.carry(actions)
    }

    fn rendered(&mut self, program: Program, pens: u32) -> Vec<String> {
        self.feed(|l, p| l.rendered(p, Rendered::Program { program, pens }))
    }

    fn mark(&mut self, mark: Option<WrittenMark>) -> Vec<String> {
        self.feed(|l, p| l.mark_read(p, mark))
    }

    fn confirm(&mut self, k: usize) -> Vec<String> {
        self.feed(|l, p| l.confirmed(p, k))
    }

    fn ended(&mut self, outcome: Result<Outcome, StreamError>) -> Vec<String> {
        self.feed(|l, p| l.span_ended(p, outcome))
    }

    /// Submits a job: its id, once it is in the spool.
    fn submit(&mut self) -> JobId {
        self.submit_on(false)
    }

    /// Submits a job drawn on the sheet in the plotter (`same_sheet`) or
    /// on a fresh one.
    fn submit_on(&mut self, same_sheet: bool) -> JobId {
        self.submit_with(|j| j.same_sheet = same_sheet)
    }

    /// Submits a job as `f` makes it.
    fn submit_with(&mut self, f: impl FnOnce(&mut NewJob)) -> JobId {
        let Ok(Target::Plotter(plotter)) = self.life.admit(None) else { panic!("no plotter") };
        let mut new = NewJob {
            kind: JobKind::Hpgl,
            plotter: plotter.name,
            class: None,
            name: None,
            uid: 1000,
            pid: 7,
            submitted_at: 0,
            same_sheet: false,
            copies: 1,
            pens: BTreeMap::new(),
            occult: None,
        };
        f(&mut new);
        let record = self.life.new_job(new);
        assert!(self.life.shown_job(record.id).is_none(), "a job is not shown before it is in the spool");
        self.disk.insert(record.id, record.clone());
        let id = record.id;
        let actions = self.life.created(record);
        let plotter = self.plotter();
        assert_eq!(self.carry(actions), [format!("announce {id} queued"), format!("wake {plotter}")]);
        id
    }

    /// A job submitted, taken and rendered as `program`, with no mark:
    /// the first span's actions.
    fn plotting(&mut self, program: Program, pens: u32) -> (JobId, Vec<String>) {
        let id = self.submit();
        assert_eq!(self.take(), [format!("save {id} rendering @0"), format!("render {id}")]);
        assert_eq!(self.rendered(program, pens), [format!("save {id} plotting @0"), format!("read mark {id}")]);
        (id, self.mark(None))
    }

    fn state(&self, id: JobId) -> JobState {
        self.life.shown_job(id).unwrap().state.clone()
    }

    fn reason(&self, id: JobId) -> String {
        match self.state(id) {
            JobState::Paused { reason, .. } | JobState::Failed { reason } => reason,
            s => panic!("job {id} is {s:?}"),
        }
    }

    /// The plotter's sheet as last saved.
    fn sheet_saved(&self) -> Option<Sheet> {
        self.plotters_disk.get(&self.plotter()).map(|s| s.sheet)
    }

    fn link(&self) -> LinkState {
        self.life.plotter_state(&self.plotter()).unwrap().0
    }

    /// Job `id` as `jobs` and `status` show it: what it waits for, as now.
    fn shown(&self, id: JobId) -> crate::protocol::JobInfo {
        let record = self.life.shown_job(id).unwrap();
        crate::protocol::JobInfo::waiting_on(record, &self.life.reach(&record.plotter))
    }
}

mod any;
mod cancel;
mod copies;
mod manual;
mod plotter_news;
mod position;
mod waiting;

/// Lines, for comparing with what a desk showed.
fn lines(l: &[&str]) -> Vec<String> {
    l.iter().map(|s| (*s).to_owned()).collect()
}

/// A span that ends "finished" having confirmed nothing (a streamer that
/// misread the device: issue 37's EBB run read its counters mid-move) is
/// streamed again once; a second such span ends the run with the error,
/// instead of asking for the same chunks every few milliseconds for ever.
#[test]
fn spans_that_finish_without_confirming_anything_are_not_streamed_for_ever() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    assert_eq!(desk.probe(true), Vec::<String>::new());
    let (id, span) = desk.plotting(hpgl(3), 6);
    assert_eq!(span, lines(&["start mark 1", "stream 0..4"]));
    assert_eq!(desk.confirm(2), lines(&["checkpoint 1 plotting @2"]));
    assert_eq!(desk.ended(Ok(Outcome::Finished)), lines(&["stream 2..4"]), "the rest");
    assert_eq!(desk.ended(Ok(Outcome::Finished)), lines(&["stream 2..4"]), "streamed again once");
    let ended = desk.ended(Ok(Outcome::Finished));
    assert!(ended.iter().any(|l| l.starts_with("save 1 paused/device-error @2")), "{ended:?}");
    assert!(desk.reason(id).contains("confirmed none of chunks 2..4"), "{}", desk.reason(id));
}

/// A job runs from submit to done: every state saved before it is shown,
/// each confirmation a checkpoint, the mark forgotten at the end.
#[test]
fn a_job_from_submit_to_done() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    // Idle: asked at once, then every 3 s.
    assert_eq!(desk.probe(true), Vec::<String>::new());
    assert_eq!(desk.link(), LinkState::Online);
    assert_eq!(desk.poll(), Step::Wait(Some(desk.now + IDLE_CHECK)));
    let (id, span) = desk.plotting(hpgl(3), 6);
    assert_eq!(span, lines(&["start mark 1", "stream 0..4"]));
    assert_eq!(desk.confirm(2), lines(&["checkpoint 1 plotting @2"]));
    assert_eq!(desk.confirm(2), Vec::<String>::new(), "nothing new confirmed");
    assert_eq!(desk.confirm(4), lines(&["checkpoint 1 plotting @4"]));
    assert_eq!(desk.ended(Ok(Outcome::Finished)), lines(&["forget mark 1", "save 1 done @4", "run ended"]));
    let done = desk.life.shown_job(id).unwrap();
    assert_eq!((done.strokes_done, done.strokes_total), (3, Some(3)));
    assert_eq!(desk.disk[&id], *done);
}

/// A record change is shown only once its save is done.
#[test]
fn a_change_is_shown_only_once_saved() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit();
    assert_eq!(desk.probe(true), Vec::<String>::new());
    let Step::Run { actions, .. } = desk.poll() else { panic!("not taken") };
    let [Action::Save(save)] = actions.as_slice() else { panic!("{actions:?}") };
    assert_eq!(save.record.state, JobState::Rendering);
    assert_eq!(desk.state(id), JobState::Queued, "shown before it was saved");
    let next = desk.life.saved(save, Ok(()));
    assert_eq!(desk.state(id), JobState::Rendering);
    assert_eq!(next.iter().map(show).collect::<Vec<_>>(), ["render 1"]);
}

/// Unplugged mid-job (the port fails), `auto_resume` off: the job pauses
/// `offline` keeping the written mark, the port is closed, and the plotter
/// is asked again after 0.25 s, doubling; back, it waits for a person's
/// `resume`, which locates the pen from the mark and goes on past it.
#[test]
fn unplug_pauses_offline_and_a_person_resumes_past_the_located_stroke() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(3);
    assert_eq!(desk.ended(Err(offline())), lines(&["save 1 paused/offline @3", "run ended, link lost"]));
    assert_eq!(
        desk.reason(id),
        "device offline: the port closed: the device was unplugged or switched off (Input/output error (os error 5))"
    );
    assert_eq!(desk.link(), LinkState::Offline);
    // Asked again at once, then after 0.25 s, 0.5 s: still unplugged (the
    // job is told again once, as the cause changed).
    assert_eq!(desk.probe(false), lines(&["announce 1 paused/offline"]));
    assert_eq!(desk.poll(), Step::Wait(Some(desk.now + BACKOFF_MIN)));
    desk.now += BACKOFF_MIN;
    assert_eq!(desk.probe(false), Vec::<String>::new());
    assert_eq!(desk.poll(), Step::Wait(Some(desk.now + BACKOFF_MIN * 2)));
    desk.now += BACKOFF_MIN * 2;
    // Plugged back: online, and the job waits for a person (and says so).
    assert_eq!(desk.probe(true), lines(&["announce 1 paused/offline"]));
    assert_eq!(desk.link(), LinkState::Online);
    assert_eq!(desk.state(id).pause_cause(), Some(PauseCause::Offline));
    assert!(matches!(desk.poll(), Step::Wait(Some(_))), "watched, not taken");
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), lines(&["save 1 queued @3", "ok: resumed job(s) 1", "wake hp"]));
    assert_eq!(desk.take(), lines(&["save 1 rendering @3", "render 1"]));
    assert_eq!(desk.rendered(hpgl(8), 6), lines(&["save 1 plotting @3", "read mark 1"]));
    // The mark: chunk 5 was being written, 4 confirmed (the record says 3).
    let mark = WrittenMark { mark: Written::Into(5), confirmed: 4 };
    assert_eq!(desk.mark(Some(mark)), lines(&["locate from 4 in Into(5)"]));
    // The pen rests where chunk 5 ends: it was drawn.
    assert_eq!(desk.feed(|l, p| l.located(p, Ok(Some(6)))), lines(&["save 1 plotting @6", "start mark 1", "stream 6..9 resume"]));
    assert_eq!(desk.confirm(9), lines(&["checkpoint 1 plotting @9"]));
    assert_eq!(desk.ended(Ok(Outcome::Finished)), lines(&["forget mark 1", "save 1 done @9", "run ended"]));
}

/// With `auto_resume`, the job goes on by itself once the plotter answers
/// again; the plotter is asked once more before it takes the job.
#[test]
fn unplug_with_auto_resume_goes_on_when_the_plotter_answers() {
    let mut desk = Desk::new(&plotters("hp", "auto_resume = true"), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(2);
    desk.ended(Err(offline()));
    // Still offline, now silent: the job says so again.
    assert_eq!(desk.probe(false), lines(&["announce 1 paused/offline"]));
    desk.now += BACKOFF_MIN;
    assert_eq!(desk.probe(true), lines(&["save 1 queued @2"]));
    assert_eq!(desk.take(), lines(&["save 1 rendering @2", "render 1"]));
    assert_eq!(desk.rendered(hpgl(8), 6), lines(&["save 1 plotting @2", "read mark 1"]));
    assert_eq!(desk.mark(Some(WrittenMark { mark: Written::Through(2), confirmed: 2 })), lines(&["start mark 1", "stream 2..9 resume"]));
    assert_eq!(desk.state(id), JobState::Plotting);
}

/// A plotter that does not answer keeps its job queued and is asked again
/// after 0.25, 0.5, 1, ... s, never longer than 30 s apart; a submit asks
/// at once.
#[test]
fn a_job_for_a_silent_plotter_waits_queued_and_it_is_asked_again_less_often() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit();
    let mut waits = Vec::new();
    // Offline: the job is told again once (it waits for the plotter), not
    // at each probe that finds the same.
    assert_eq!(desk.probe(false), lines(&["announce 1 queued"]));
    desk.now += BACKOFF_MIN;
    waits.push(BACKOFF_MIN);
    for _ in 1..10 {
        assert_eq!(desk.probe(false), Vec::<String>::new());
        let Step::Wait(Some(t)) = desk.poll() else { panic!("no deadline") };
        waits.push(t - desk.now);
        desk.now = t;
    }
    let ms: Vec<u128> = waits.iter().map(Duration::as_millis).collect();
    assert_eq!(ms, [250, 500, 1000, 2000, 4000, 8000, 16000, 30000, 30000, 30000]);
    assert_eq!(desk.state(id), JobState::Queued);
    assert_eq!(desk.link(), LinkState::Offline);
    // Another job: asked at once.
    desk.submit();
    assert_eq!(desk.take(), lines(&["save 1 rendering @0", "render 1"]));
}

/// A power cycle mid-job: the device lost what it held, so the mark is
/// forgotten (the pen's place cannot say how far it got), the job waits for
/// a person to confirm the pen's position (`position.rs`), and a resume
/// goes on from the checkpoint.
#[test]
fn power_cycle_forgets_the_mark_and_resumes_from_the_checkpoint() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(4);
    assert_eq!(desk.ended(Err(reset())), lines(&["forget mark 1", "save 1 paused/position-lost @4", "run ended, link lost"]));
    let reason = desk.reason(id);
    assert!(reason.starts_with("position lost: the plotter answered \"1024\" with its power-on terminator"), "{reason}");
    desk.feed(|l, _| l.resume(Some(id), true));
    desk.take();
    desk.rendered(hpgl(8), 6);
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 4..9 resume confirmed"]));
}

/// SIGKILL mid-job, then a restart: the job comes back paused
/// `interrupted` and the plotter is not even asked whether it is there (a
/// restart never moves the pen); `resume` locates the pen from the mark,
/// whose confirmation is ahead of the saved checkpoint.
#[test]
fn sigkill_and_restart_wait_for_resume_then_locate_from_the_mark() {
    let records = vec![
        record(1, "hp", JobState::Plotting, 3),
        record(2, "hp", JobState::Queued, 0),
        record(3, "hp", JobState::Rendering, 0),
        record(4, "hp", JobState::paused(PauseCause::DeviceHold, "held by the plotter: paper lever raised"), 2),
        record(5, "hp", JobState::Queued, 2),
        record(6, "hp", JobState::Done, 9),
    ];
    let mut desk = Desk::new(&plotters("hp", ""), records);
    let states: Vec<String> = desk.life.shown_jobs().map(|j| show(&Action::Announce(j.clone()))).collect();
    assert_eq!(
        states,
        [
            "announce 1 paused/interrupted",
            "announce 2 queued",
            "announce 3 queued",
            "announce 4 paused/interrupted",
            "announce 5 paused/interrupted",
            "announce 6 done"
        ]
    );
    assert_eq!(desk.reason(1), "interrupted: the daemon stopped mid-job");
    assert_eq!(desk.disk[&1].state.pause_cause(), Some(PauseCause::Interrupted), "saved");
    assert_eq!(desk.poll(), Step::Wait(None), "the pen is left alone");
    assert_eq!(desk.link(), LinkState::Unknown);
    assert_eq!(desk.feed(|l, _| l.resume(Some(1), false)), lines(&["save 1 queued @3", "ok: resumed job(s) 1", "wake hp"]));
    assert_eq!(desk.take(), lines(&["save 1 rendering @3", "render 1"]));
    assert_eq!(desk.rendered(hpgl(8), 6), lines(&["save 1 plotting @3", "read mark 1"]));
    let mark = WrittenMark { mark: Written::Into(7), confirmed: 5 };
    assert_eq!(desk.mark(Some(mark)), lines(&["locate from 5 in Into(7)"]));
    // The device cannot tell: go on from the last confirmation heard.
    assert_eq!(desk.feed(|l, p| l.located(p, Ok(None))), lines(&["save 1 plotting @5", "start mark 1", "stream 5..9 resume"]));
}

/// A restart's ids follow every id in the spool.
#[test]
fn ids_after_a_restart_follow_the_highest_in_the_spool() {
    let (mut life, _) = JobLife::new(vec![record(3, "hp", JobState::Done, 9)], 11, &plotters("hp", ""), 100);
    let job = life.new_job(NewJob {
        kind: JobKind::Hpgl,
        plotter: "hp".into(),
        class: None,
        name: None,
        uid: 0,
        pid: 0,
        submitted_at: 0,
        same_sheet: false,
        copies: 1,
        pens: BTreeMap::new(),
        occult: None,
    });
    assert_eq!((job.id, job.name.as_str()), (12, "job-12"));
}

/// The plotter's own pause button (an AxiDraw's PRG) stopped the run at a
/// stroke's end: the job is paused as by a person, saying so, and a plain
/// `resume` goes on from the checkpoint. A stop a person asked for keeps
/// its own meaning (a cancel stays a cancel).
#[test]
fn the_plotters_button_pauses_as_a_person_does() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(3);
    assert_eq!(desk.ended(Ok(Outcome::ButtonPressed)), lines(&["save 1 paused/person @3", "run ended"]));
    assert_eq!(desk.reason(id), "paused by the plotter's button");
    desk.feed(|l, _| l.resume(None, false));
    desk.take();
    desk.rendered(hpgl(8), 6);
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 3..9 resume"]));
    desk.feed(|l, _| l.cancel(id, false));
    assert_eq!(desk.ended(Ok(Outcome::ButtonPressed)), lines(&["forget mark 1", "save 1 cancelled @3", "run ended"]));
}

/// `pause` and `cancel` of a plotting job, after the stroke and now: the
/// run is asked to stop, the reply says when, and once the device has
/// stopped (nothing of the job left in it) the job is paused or cancelled.
#[test]
fn stop_after_the_stroke_and_now_while_plotting() {
    for (now, how) in [(false, "AfterStroke"), (true, "Now")] {
        let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
        let (id, _) = desk.plotting(hpgl(8), 6);
        desk.confirm(2);
        let when = if now { "now" } else { "at the next stroke boundary" };
        let stop = format!("stop hp {how}");
        assert_eq!(desk.feed(|l, _| l.pause(Some(id), now)), [stop.clone(), "wake hp".into(), format!("ok: 1 job(s) pausing {when}")]);
        assert_eq!(desk.state(id), JobState::Plotting, "still its run's until the device stopped");
        desk.confirm(3);
        assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 1", "save 1 paused/person @3", "run ended"]));
        assert_eq!(desk.reason(id), "paused by user");
        assert_eq!(desk.poll(), Step::Wait(None), "the plotter waits for the person");
        // Resumed, the run goes on from the checkpoint.
        desk.feed(|l, _| l.resume(None, false));
        desk.take();
        desk.rendered(hpgl(8), 6);
        assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 3..9 resume"]));
        // Cancelled: the same stop, and the job ends cancelled.
        let when = if now { "now" } else { "at the end of the current stroke" };
        assert_eq!(desk.feed(|l, _| l.cancel(id, now)), [stop, "wake hp".into(), format!("ok: job 1 stops {when}")]);
        assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 1", "save 1 cancelled @3", "run ended"]));
        assert_eq!(desk.feed(|l, _| l.cancel(id, now)), lines(&["refused: job 1 is already cancelled"]));
    }
}

/// A stop asked while the job renders ends the render: a cancel cancels,
/// a pause pauses, a shutdown leaves the job queued (nothing was drawn).
#[test]
fn stop_while_rendering() {
    type Ask = fn(&mut JobLife, &str) -> Vec<Action>;
    let cases: [(Ask, &[&str], &[&str]); 3] = [
        (
            |l, _| l.cancel(1, false),
            &["stop hp AfterStroke", "wake hp", "ok: job 1 stops at the end of the current stroke"],
            &["forget mark 1", "save 1 cancelled @0", "run ended"],
        ),
        (|l, _| l.pause(None, true), &["stop hp Now", "wake hp", "ok: 1 job(s) pausing now"], &["save 1 paused/person @0", "run ended"]),
        (|l, _| l.shut_down(), &["stop hp AfterStroke", "wake hp"], &["save 1 queued @0", "run ended"]),
    ];
    for (ask, asked, ended) in cases {
        let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
        desk.submit();
        desk.take();
        assert_eq!(desk.feed(ask), lines(asked));
        assert_eq!(desk.feed(|l, p| l.rendered(p, Rendered::Stopped)), lines(ended));
    }
}

/// SIGTERM while plotting: the run stops at the stroke's end and the job
/// waits `interrupted`; the plotter's task ends; no job is taken or submitted.
#[test]
fn shutdown_stops_at_the_stroke_and_the_job_waits_interrupted() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    assert_eq!(desk.feed(|l, _| l.shut_down()), lines(&["stop hp AfterStroke", "wake hp"]));
    // A pause asked after it does not change why the run stops.
    desk.feed(|l, _| l.pause(Some(id), false));
    desk.confirm(5);
    assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 1", "save 1 paused/interrupted @5", "run ended"]));
    assert_eq!(desk.reason(id), "interrupted: the daemon shut down");
    assert_eq!(desk.poll(), Step::Quit);
    assert_eq!(desk.life.admit(None), Err(SubmitError::ShuttingDown));
}

/// The paper lever raised mid-job: the job shows paused `device-hold` with
/// the device's reason but stays its run's: `resume` is refused, `pause`
/// still acts, and lowering the lever makes it plot again by itself.
#[test]
fn paper_lever_holds_the_job_and_resume_is_refused() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(3);
    let lever = |l: &mut JobLife, p: &str, up: bool| l.held(p, up.then_some(Hold::PaperLever));
    assert_eq!(desk.feed(|l, p| lever(l, p, true)), lines(&["checkpoint 1 paused/device-hold @3"]));
    assert_eq!(desk.reason(id), "held by the plotter: paper lever raised");
    assert_eq!(desk.feed(|l, p| lever(l, p, true)), Vec::<String>::new(), "still held: nothing new");
    assert_eq!(
        desk.feed(|l, _| l.resume(Some(id), false)),
        lines(&["refused: job 1 is held by the plotter and goes on by itself once the plotter does (for a paper lever: lower it)"])
    );
    assert_eq!(desk.feed(|l, _| l.resume(None, false)), lines(&["refused: no paused job"]));
    // Confirmations keep coming while it is held: the hold stays shown.
    assert_eq!(desk.confirm(4), lines(&["checkpoint 1 paused/device-hold @4"]));
    assert_eq!(desk.feed(|l, p| lever(l, p, false)), lines(&["checkpoint 1 plotting @4"]));
    // A person may pause a held job.
    assert_eq!(desk.feed(|l, p| lever(l, p, true)), lines(&["checkpoint 1 paused/device-hold @4"]));
    assert_eq!(
        desk.feed(|l, _| l.pause(Some(id), false)),
        lines(&["stop hp AfterStroke", "wake hp", "ok: 1 job(s) pausing at the next stroke boundary"])
    );
    assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 1", "save 1 paused/person @4", "run ended"]));
}

/// A one-pen board: the job streams up to the pen change, lifting the pen,
/// and pauses asking for pen 2; `pen-changed` goes on from there with pen
/// 2 taken to be in. A carousel plotter does not pause.
#[test]
fn pen_change_on_a_one_pen_plotter() {
    let mut desk = Desk::new(&plotters("cnc", ""), Vec::new());
    let program = two_pens();
    let change = program.chunks.iter().position(|c| c.draws && c.pen == Some(2)).unwrap();
    let total = program.chunks.len();
    let (id, span) = desk.plotting(program.clone(), 1);
    assert_eq!(span, ["start mark 1".to_owned(), format!("stream 0..{change} lift")]);
    desk.confirm(change);
    assert_eq!(desk.ended(Ok(Outcome::Finished)), lines(&["park at (420, 297)"]), "off the drawing first");
    assert_eq!(desk.feed(|l, p| l.parked(p, Ok(()))), [format!("save 1 paused/load @{change}"), "run ended".to_owned()]);
    let JobState::Paused { insert_pen, reason, .. } = desk.state(id) else { panic!() };
    assert_eq!((insert_pen, reason.as_str()), (Some(2), "insert pen 2"));
    assert_eq!(desk.poll(), Step::Wait(None), "the plotter waits for the pen");
    assert_eq!(desk.feed(|l, _| l.pen_changed(Some("hp"))), lines(&["refused: no job is waiting for a pen"]));
    assert_eq!(
        desk.feed(|l, _| l.pen_changed(Some("cnc"))),
        [format!("save 1 queued @{change}"), "ok: resumed job(s) 1".into(), "wake cnc".into()]
    );
    assert_eq!(desk.life.shown_job(id).unwrap().pen_loaded, Some(2));
    desk.take();
    desk.rendered(program.clone(), 1);
    assert_eq!(desk.mark(None), ["start mark 1".to_owned(), format!("stream {change}..{total} resume")]);

    // Six pens in a carousel: one span, no pause.
    let mut desk = Desk::new(&plotters("cnc", ""), Vec::new());
    let (_, span) = desk.plotting(program.clone(), 6);
    assert_eq!(span, ["start mark 1".to_owned(), format!("stream 0..{total}")]);
    // `pen_change = "pause"` pauses on any plotter.
    let mut desk = Desk::new(&plotters("cnc", "pen_change = \"pause\""), Vec::new());
    let (_, span) = desk.plotting(program, 6);
    assert_eq!(span, ["start mark 1".to_owned(), format!("stream 0..{change} lift")]);
}

/// A one-pen plotter remembers the pen in it (in the spool, per plotter):
/// a job ending with pen 2 leaves pen 2 in, and the next job, whose first
/// pen is 1, asks for pen 1 before it draws; each ask parks the head off
/// the drawing first, and the estimate counts a person's change.
#[test]
fn a_one_pen_plotter_asks_for_the_first_pen_when_another_is_in() {
    let mut desk = Desk::new(&plotters("cnc", ""), Vec::new());
    let program = two_pens();
    let first_draw = program.chunks.iter().position(|c| c.draws).unwrap();
    let change = program.chunks.iter().position(|c| c.draws && c.pen == Some(2)).unwrap();
    let total = program.chunks.len();
    let (first, _) = desk.plotting(program.clone(), 1);
    let eta = desk.life.stations[0].run.as_ref().unwrap().progress().eta_s;
    assert_eq!(eta, Some(program.seconds_from(0) + PEN_CHANGE_S), "one change ahead: {eta:?}");
    assert_eq!(desk.plotters_disk.get("cnc").and_then(|s| s.pen_loaded), Some(1), "the first job takes the pen in to be its first");
    desk.confirm(change);
    // The pen change parks the head at the reach's corner farthest from the drawing.
    assert_eq!(desk.ended(Ok(Outcome::Finished)), ["park at (420, 297)".to_owned()]);
    assert_eq!(desk.feed(|l, p| l.parked(p, Ok(()))), [format!("save 1 paused/load @{change}"), "run ended".to_owned()]);
    desk.feed(|l, _| l.pen_changed(None));
    assert_eq!(desk.plotters_disk.get("cnc").and_then(|s| s.pen_loaded), Some(2));
    desk.take();
    desk.rendered(program.clone(), 1);
    desk.mark(None);
    desk.confirm(total);
    desk.ended(Ok(Outcome::Finished));
    assert_eq!(desk.state(first), JobState::Done);

    // Pen 2 is in; the next job starts with pen 1: it asks for it, parked.
    let second = desk.submit_on(true);
    desk.take();
    desk.rendered(program.clone(), 1);
    let eta = desk.life.stations[0].run.as_ref().unwrap().progress().eta_s;
    assert_eq!(eta, Some(program.seconds_from(0) + 2.0 * PEN_CHANGE_S), "two changes ahead: {eta:?}");
    // Its first chunk draws with pen 1: nothing is streamed before the ask.
    assert_eq!(first_draw, 0);
    assert_eq!(desk.mark(None), lines(&["start mark 2", "park at (420, 297)"]));
    assert_eq!(desk.feed(|l, p| l.parked(p, Ok(()))), [format!("save 2 paused/load @{first_draw}"), "run ended".to_owned()]);
    let JobState::Paused { insert_pen, reason, .. } = desk.state(second) else { panic!() };
    assert_eq!((insert_pen, reason.as_str()), (Some(1), "insert pen 1"));
}

/// A job of two sheets (an animation's frames): it pauses to load the
/// second, and `resume` goes on with it loaded.
#[test]
fn multi_page_job_asks_for_paper() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let program = Program::paged(vec![hpgl(2), hpgl(3)]).unwrap();
    let (id, span) = desk.plotting(program.clone(), 6);
    assert_eq!(span, lines(&["start mark 1", "stream 0..3 lift"]));
    desk.confirm(3);
    assert_eq!(desk.ended(Ok(Outcome::Finished)), lines(&["save 1 paused/load @3", "run ended"]));
    let JobState::Paused { load_page, reason, .. } = desk.state(id) else { panic!() };
    assert_eq!((load_page, reason.as_str()), (Some(1), "load paper for frame 2 of 2"));
    assert_eq!(desk.feed(|l, _| l.pen_changed(None)), lines(&["refused: no job is waiting for a pen"]));
    desk.feed(|l, _| l.resume(Some(id), false));
    assert_eq!(desk.life.shown_job(id).unwrap().page_loaded, 1);
    desk.take();
    desk.rendered(program, 6);
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 3..7 resume"]));
}

/// The spool fills mid-job: the first checkpoint that cannot be saved
/// stops the run at the next stroke boundary; the job pauses `unsaved` with
/// the checkpoint in memory ahead of the disk, and goes on from that one:
/// nothing is streamed twice.
#[test]
fn spool_full_stops_at_the_next_stroke_and_nothing_is_streamed_twice() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 6);
    desk.confirm(2);
    desk.full = true;
    assert_eq!(desk.confirm(3), lines(&["checkpoint 1 plotting @3", "stop hp AfterStroke", "wake hp"]));
    assert_eq!(desk.confirm(4), lines(&["checkpoint 1 plotting @4"]), "asked to stop once");
    assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["save 1 paused/unsaved @4", "run ended"]));
    assert_eq!(
        desk.reason(id),
        format!("paused: the spool cannot be written, so plotting stopped before the record fell behind the device: {FULL}")
    );
    assert_eq!(desk.disk[&id].checkpoint, 2, "the disk is behind");
    // Still full: the resume holds in memory, and says the spool failed.
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), ["save 1 queued @4".to_owned(), format!("refused: {FULL}"), "wake hp".into()]);
    desk.full = false;
    desk.take();
    desk.rendered(hpgl(8), 6);
    assert_eq!(desk.mark(None), lines(&["start mark 1", "stream 4..9 resume"]));
    assert_eq!(desk.disk[&id].checkpoint, 4, "caught up");
}

/// A state the run must save before it goes on (here `rendering`) that
/// cannot be saved ends the run, paused `unsaved`.
#[test]
fn a_run_whose_first_state_cannot_be_saved_pauses() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit();
    desk.full = true;
    assert_eq!(desk.take(), lines(&["save 1 rendering @0", "save 1 paused/unsaved @0", "run ended"]));
    assert_eq!(desk.state(id).pause_cause(), Some(PauseCause::Unsaved));
}

/// A queued job is cancelled on a spool that cannot be written: its files
/// are deleted instead, so it cannot come back queued; when they cannot be
/// deleted either, the reply says it is cancelled until a restart.
#[test]
fn cancel_of_a_queued_job_when_its_record_cannot_be_rewritten() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let (first, _) = desk.plotting(hpgl(8), 6);
    let queued = desk.submit();
    desk.full = true;
    assert_eq!(
        desk.feed(|l, _| l.cancel(queued, false)),
        [
            "save 2 cancelled @0".to_owned(),
            "remove 2 (cancelled, unsaved)".into(),
            format!("ok: job 2 cancelled (the spool cannot be written: {FULL}; its files were deleted)"),
            "wake hp".into()
        ]
    );
    assert!(!desk.disk.contains_key(&queued));
    assert_eq!(desk.state(queued), JobState::Cancelled);
    desk.read_only = true;
    let third = desk.submit();
    let refused = desk.feed(|l, _| l.cancel(third, false));
    assert_eq!(
        refused[2],
        format!("refused: job 3 is cancelled until the daemon restarts: the spool cannot record it ({FULL}; spool /s/jobs/1.json: Read-only file system (os error 30))")
    );
    assert_eq!(desk.state(first), JobState::Plotting, "the running job is left alone");
}

/// A GRBL board that stalls (lines lost in its serial handler) is resynced
/// and the run goes on from the checkpoint by itself, once per
/// confirmation; a second stall without progress pauses the job.
#[test]
fn a_stall_resyncs_once_per_confirmation() {
    let mut desk = Desk::new(&plotters("cnc", "pen_change = \"ignore\""), Vec::new());
    let (id, _) = desk.plotting(hpgl(8), 1);
    let stall = || Err(StreamError::Stalled { unanswered: 3 });
    desk.confirm(2);
    assert_eq!(desk.ended(stall()), lines(&["stream 2..9 resume"]));
    desk.confirm(3);
    assert_eq!(desk.ended(stall()), lines(&["stream 3..9 resume"]));
    assert_eq!(desk.ended(stall()), lines(&["forget mark 1", "save 1 paused/device-error @3", "run ended"]));
    assert_eq!(desk.reason(id), "device stalled with 3 lines unanswered");
}

/// A device error keeps the link: the job pauses with the device's text,
/// or fails with `on_device_error = "fail"`, and the mark is forgotten
/// (the streamer dropped what the device held).
#[test]
fn device_errors_pause_or_fail_by_policy() {
    for (extra, line) in [("", "save 1 paused/device-error @2"), ("on_device_error = \"fail\"", "save 1 failed @2")] {
        let mut desk = Desk::new(&plotters("hp", extra), Vec::new());
        let (id, _) = desk.plotting(hpgl(8), 6);
        desk.confirm(2);
        let error = StreamError::Device(DeviceError::at(ErrorCode::Hpgl(3), ErrorAt::Stroke(2)));
        assert_eq!(desk.ended(Err(error)), ["forget mark 1".to_owned(), line.into(), "run ended".into()]);
        assert_eq!(desk.reason(id), "device error: HP-GL error 3 (out-of-range parameter) in stroke 2");
        assert_eq!(desk.link(), LinkState::Online);
    }
}

/// A job that cannot be rendered fails with the reason; the next one runs.
#[test]
fn a_render_failure_fails_the_job_and_the_next_runs() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let first = desk.submit();
    let second = desk.submit();
    desk.take();
    assert_eq!(
        desk.feed(|l, p| l.rendered(p, Rendered::Failed("scene.toml: line 3: bad".into()))),
        lines(&["forget mark 1", "save 1 failed @0", "run ended"])
    );
    assert_eq!(desk.reason(first), "scene.toml: line 3: bad");
    assert_eq!(desk.take(), [format!("save {second} rendering @0"), format!("render {second}")]);
}

/// Refusals name the job and why.
#[test]
fn requests_that_cannot_be_done_are_refused() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    assert_eq!(desk.feed(|l, _| l.cancel(9, false)), lines(&["refused: no job 9"]));
    assert_eq!(desk.feed(|l, _| l.pause(Some(9), false)), lines(&["refused: no job 9 that can be paused"]));
    assert_eq!(desk.feed(|l, _| l.pause(None, false)), lines(&["ok: 0 job(s) pausing at the next stroke boundary"]));
    let id = desk.submit();
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), lines(&["refused: job 1 is not paused"]));
    // A queued job paused by a person: its plotter waits for it.
    assert_eq!(
        desk.feed(|l, _| l.pause(Some(id), false)),
        lines(&["save 1 paused/person @0", "ok: 1 job(s) pausing at the next stroke boundary"])
    );
    assert_eq!(desk.poll(), Step::Wait(None), "not even asked whether it is there");
    assert_eq!(
        desk.life.admit(Some("cnc")),
        Err(SubmitError::NoSuchPlotter { name: "cnc".into(), configured: vec!["hp".into()], devices: vec!["hp7475a".into()] })
    );
    assert_eq!(
        desk.life.admit(Some("cnc")).unwrap_err().to_string(),
        "no plotter or device \"cnc\": name a plotter (hp), a device of one (hp7475a), or any"
    );
}

/// Finished jobs beyond `keep_finished` are removed, oldest first, once
/// their last state is saved.
#[test]
fn finished_jobs_are_pruned_oldest_first() {
    let plotters = plotters("hp", "");
    let (mut life, _) = JobLife::new(Vec::new(), 0, &plotters, 1);
    let (keep, _) = life.reload(&plotters, 1);
    assert_eq!(keep.iter().map(show).collect::<Vec<_>>(), ["wake hp"]);
    let mut desk = Desk {
        life,
        now: Instant::now(),
        disk: BTreeMap::new(),
        full: false,
        read_only: false,
        plotters_disk: BTreeMap::new(),
        plotters_announced: Vec::new(),
    };
    let a = desk.submit();
    let b = desk.submit();
    assert_eq!(desk.feed(|l, _| l.cancel(a, false)), lines(&["save 1 cancelled @0", "ok: job 1 cancelled", "wake hp"]));
    assert_eq!(
        desk.feed(|l, _| l.cancel(b, false)),
        lines(&["save 2 cancelled @0", "ok: job 2 cancelled", "remove 1 (pruned)", "wake hp"])
    );
    assert!(desk.life.shown_job(a).is_none() && desk.life.shown_job(b).is_some());
}

/// Plays a job from its take to done: `n` strokes confirmed, the actions
/// of its end.
fn plot_to_done(desk: &mut Desk, id: JobId, n: usize) -> Vec<String> {
    assert_eq!(desk.take(), [format!("save {id} rendering @0"), format!("render {id}")]);
    desk.rendered(hpgl(n), 6);
    assert_eq!(desk.mark(None), [format!("start mark {id}"), format!("stream 0..{}", n + 1)]);
    desk.confirm(n + 1);
    desk.ended(Ok(Outcome::Finished))
}

/// Two jobs back to back: the first draws and leaves the sheet used (saved
/// for the plotter before its run ends); the second waits `load-sheet`
/// without asking the device, `resume` is refused naming the way on, and
/// `sheet-loaded` marks the sheet fresh and queues it. A job for the same
/// sheet goes at once.
#[test]
fn the_next_job_waits_for_a_fresh_sheet_unless_it_is_for_the_same_sheet() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let first = desk.submit();
    let second = desk.submit();
    assert_eq!(desk.life.sheet("hp"), Some(Sheet::Fresh));
    assert_eq!(plot_to_done(&mut desk, first, 2), lines(&["forget mark 1", "save 1 done @3", "run ended"]));
    assert_eq!(desk.sheet_saved(), Some(Sheet::Used), "the sheet is saved used when the job's run ends");
    let Step::Act(actions) = desk.poll() else { panic!("the second job was not made to wait") };
    assert_eq!(desk.carry(actions), lines(&["save 2 paused/load-sheet @0"]));
    assert_eq!(desk.reason(second), "load a fresh sheet on plotter hp, then: plotd sheet-loaded hp");
    assert_eq!(desk.poll(), Step::Wait(None), "the plotter waits for a person");
    assert_eq!(
        desk.feed(|l, _| l.resume(Some(second), false)),
        lines(&["refused: job 2 waits for a fresh sheet: load one on plotter hp, then: plotd sheet-loaded hp"])
    );
    assert_eq!(desk.feed(|l, _| l.resume(None, false)), lines(&["refused: no paused job"]));
    assert_eq!(desk.feed(|l, _| l.sheet_loaded("cnc")), lines(&["refused: no plotter \"cnc\""]));
    assert_eq!(desk.feed(|l, _| l.sheet_loaded("hp")), lines(&["save 2 queued @0", "ok: resumed job(s) 2", "wake hp"]));
    assert_eq!(desk.sheet_saved(), Some(Sheet::Fresh));
    assert_eq!(plot_to_done(&mut desk, second, 1), lines(&["forget mark 2", "save 2 done @2", "run ended"]));
    assert_eq!(desk.sheet_saved(), Some(Sheet::Used));
    // An overlay: at once, on the used sheet.
    let third = desk.submit_on(true);
    assert_eq!(plot_to_done(&mut desk, third, 1), lines(&["forget mark 3", "save 3 done @2", "run ended"]));
    assert_eq!(desk.feed(|l, _| l.sheet_loaded("hp")), lines(&["ok: a fresh sheet is in plotter hp", "wake hp"]));
    assert_eq!(desk.sheet_saved(), Some(Sheet::Fresh));
}

/// A job that drew nothing (failed to render, cancelled before its first
/// stroke) leaves the sheet fresh; one paused after drawing goes on on its
/// own sheet, and leaves it used for the next.
#[test]
fn only_a_job_that_drew_uses_the_sheet() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let first = desk.submit();
    desk.take();
    desk.feed(|l, p| l.rendered(p, Rendered::Failed("bad".into())));
    assert_eq!((desk.life.sheet("hp"), desk.sheet_saved()), (Some(Sheet::Fresh), None));
    let second = desk.submit();
    desk.take();
    desk.rendered(hpgl(3), 6);
    desk.mark(None);
    desk.confirm(2);
    desk.feed(|l, _| l.pause(Some(second), false));
    assert_eq!(desk.ended(Ok(Outcome::Stopped)), lines(&["forget mark 2", "save 2 paused/person @2", "run ended"]));
    assert_eq!(desk.sheet_saved(), Some(Sheet::Used));
    desk.feed(|l, _| l.resume(Some(second), false));
    assert_eq!(desk.take(), lines(&["save 2 rendering @2", "render 2"]), "a job that drew goes on on its own sheet");
    assert!(desk.life.shown_job(first).unwrap().state.is_final());
}

/// The sheet's state survives a restart: restored used, the queued job
/// waits for `sheet-loaded`.
#[test]
fn a_used_sheet_is_still_used_after_a_restart() {
    let mut desk = Desk::new(&plotters("hp", ""), vec![record(4, "hp", JobState::Queued, 0)]);
    desk.life.restore_plotter("hp", PlotterState { sheet: Sheet::Used, ..PlotterState::default() });
    let Step::Act(actions) = desk.poll() else { panic!("the job was not made to wait") };
    assert_eq!(desk.carry(actions), lines(&["save 4 paused/load-sheet @0"]));
    // And the wait itself survives one: nothing a restart changes.
    assert_eq!(after_restart(&desk.disk[&4]), None);
}
