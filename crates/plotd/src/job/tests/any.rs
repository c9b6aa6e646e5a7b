//! Jobs for a class of plotters (`--plotter any`, or a device): the first
//! idle plotter of those that can draw it takes it, and the record names
//! it from then on; a plotter waiting for a sheet, or with a job of its
//! own paused, is not idle; a restart keeps the class until one takes it.

use super::*;

/// Plotters `a` and `b` (HP 7475As) and `cnc` (a GRBL board).
fn three() -> Vec<crate::config::PlotterConfig> {
    let table = |name: &str, device: &str, handshake: &str| {
        format!("[[plotter]]\nname = \"{name}\"\nport = \"/dev/tty{name}\"\ndevice = \"{device}\"\nhandshake = \"{handshake}\"\n")
    };
    let text = format!(
        "socket = \"/s/plotd.sock\"\nspool = \"/s\"\n{}{}{}",
        table("a", "hp7475a", "escb"),
        table("b", "hp7475a", "escb"),
        table("cnc", "grbl-servo", "grbl")
    );
    Config::from_toml(&text, "test").expect("test config").plotters
}

/// Submits a job for class `name`, which the submit's checks found plotters
/// `fits` can draw; the wakes it caused.
fn submit_for(desk: &mut Desk, name: &str, fits: &[&str], same_sheet: bool) -> (JobId, Vec<String>) {
    let Ok(Target::Class { name: class, plotters }) = desk.life.admit(Some(name)) else { panic!("{name} is no class") };
    let fits: Vec<_> = plotters.into_iter().filter(|p| fits.contains(&p.name.as_str())).collect();
    let new = NewJob {
        kind: JobKind::Hpgl,
        plotter: class.clone(),
        class: Some(super::super::class(&class, &fits)),
        name: None,
        uid: 1000,
        pid: 7,
        submitted_at: 0,
        same_sheet,
        copies: 1,
        pens: BTreeMap::new(),
        occult: None,
    };
    let record = desk.life.new_job(new);
    desk.disk.insert(record.id, record.clone());
    let id = record.id;
    let actions = desk.life.created(record);
    let lines = desk.carry(actions);
    assert_eq!(lines[0], format!("announce {id} queued"));
    (id, lines[1..].to_vec())
}

/// Plotter `name` answers; what it does next.
fn answer(desk: &mut Desk, name: &str) -> Step {
    assert_eq!(desk.life.poll(name, desk.now), Step::Probe, "{name} asks its device first");
    let actions = desk.life.probed(name, Ok(()), desk.now);
    desk.carry(actions);
    desk.life.poll(name, desk.now)
}

/// Plotter `name` takes a job: which, with its first actions.
fn takes(desk: &mut Desk, name: &str) -> (JobId, Vec<String>) {
    match answer(desk, name) {
        Step::Run { job, actions } => (job, desk.carry(actions)),
        other => panic!("{name} took no job: {other:?}"),
    }
}

/// Plotter `name`'s run of its job draws `n` strokes and ends done.
fn finish(desk: &mut Desk, name: &str, n: usize) {
    let feed = |desk: &mut Desk, f: &dyn Fn(&mut JobLife) -> Vec<Action>| {
        let actions = f(&mut desk.life);
        desk.carry(actions)
    };
    feed(desk, &|l| l.rendered(name, Rendered::Program { program: hpgl(n), pens: 6 }));
    feed(desk, &|l| l.mark_read(name, None));
    feed(desk, &|l| l.confirmed(name, n + 1));
    let end = feed(desk, &|l| l.span_ended(name, Ok(Outcome::Finished)));
    assert!(end.iter().any(|l| l.ends_with("done @") || l.contains(" done @")), "{end:?}");
}

/// `any` names every plotter, a device its plotters, a plotter's name that
/// plotter; anything else is refused listing the choices.
#[test]
fn a_submit_names_a_plotter_a_device_or_any() {
    let desk = Desk::new(&three(), Vec::new());
    let names = |t: Result<Target, SubmitError>| match t {
        Ok(Target::Class { name, plotters }) => {
            format!("{name}: {}", plotters.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(" "))
        }
        Ok(Target::Plotter(p)) => format!("plotter {}", p.name),
        Err(e) => e.to_string(),
    };
    assert_eq!(names(desk.life.admit(Some("any"))), "any: a b cnc");
    assert_eq!(names(desk.life.admit(Some("hp7475a"))), "hp7475a: a b");
    assert_eq!(names(desk.life.admit(Some("grbl-servo"))), "grbl-servo: cnc");
    assert_eq!(names(desk.life.admit(Some("b"))), "plotter b");
    assert_eq!(names(desk.life.admit(None)), "plotter a");
    assert_eq!(
        names(desk.life.admit(Some("hp7550a"))),
        "no plotter or device \"hp7550a\": name a plotter (a, b, cnc), a device of one (grbl-servo, hp7475a), or any"
    );
}

/// Two idle plotters and jobs for `any`: every plotter that fits is woken;
/// the first to answer takes the oldest, the other the next, both at once;
/// the records name who took each, and keep the class. The plotter that
/// does not fit is never given one.
#[test]
fn jobs_for_any_go_to_the_idle_plotters_that_fit_them() {
    let mut desk = Desk::new(&three(), Vec::new());
    let (first, wakes) = submit_for(&mut desk, "any", &["a", "b"], true);
    assert_eq!(wakes, lines(&["wake a", "wake b"]));
    let (second, _) = submit_for(&mut desk, "any", &["a", "b"], true);
    let (third, _) = submit_for(&mut desk, "any", &["a", "b"], true);
    assert_eq!(desk.shown(first).plotter, "any", "no plotter took it yet");
    assert_eq!(desk.shown(first).reason.as_deref(), Some("waiting for an idle plotter of any: a, b"));
    assert_eq!(answer(&mut desk, "cnc"), Step::Wait(Some(desk.now + IDLE_CHECK)), "cnc cannot draw them");
    assert_eq!(takes(&mut desk, "b"), (first, lines(&["save 1 rendering @0", "render 1"])));
    assert_eq!(takes(&mut desk, "a"), (second, lines(&["save 2 rendering @0", "render 2"])));
    for (id, plotter) in [(first, "b"), (second, "a")] {
        let shown = desk.shown(id);
        assert_eq!((shown.plotter.as_str(), shown.class.as_deref(), shown.waiting), (plotter, Some("any"), None));
        assert_eq!(desk.disk[&id].unclaimed(), None, "saved as {plotter}'s");
    }
    assert_eq!(desk.shown(third).plotter, "any");
    assert_eq!(
        desk.life.manual(None, Manual::Frame { job: third }).map(|_| ()),
        Err(ControlError::NotTaken { id: third, class: "any".into() }),
        "no sheet to frame it on yet"
    );
    finish(&mut desk, "a", 2);
    let (job, _) = takes(&mut desk, "a");
    assert_eq!((job, desk.shown(third).plotter.as_str()), (third, "a"));
}

/// A plotter whose sheet was drawn on is not idle for a job for a class
/// (it would wait there for a sheet while another is free): the other
/// takes it; `sheet-loaded` makes it idle again. A job for the same sheet
/// goes to it at once.
#[test]
fn a_plotter_waiting_for_a_sheet_takes_no_job_for_a_class() {
    let mut desk = Desk::new(&three(), Vec::new());
    desk.life.restore_plotter("a", PlotterState { sheet: Sheet::Used, ..PlotterState::default() });
    let (fresh, _) = submit_for(&mut desk, "hp7475a", &["a", "b"], false);
    assert_eq!(answer(&mut desk, "a"), Step::Wait(Some(desk.now + IDLE_CHECK)), "a needs a fresh sheet");
    assert_eq!(desk.life.shown_job(fresh).unwrap().state, JobState::Queued, "not made to wait on a");
    assert_eq!(takes(&mut desk, "b").0, fresh);
    let (overlay, _) = submit_for(&mut desk, "hp7475a", &["a", "b"], true);
    assert_eq!(takes(&mut desk, "a").0, overlay);
    finish(&mut desk, "a", 1);
    let (next, _) = submit_for(&mut desk, "hp7475a", &["a", "b"], false);
    assert_eq!(answer(&mut desk, "a"), Step::Wait(Some(desk.now + IDLE_CHECK)));
    assert_eq!(desk.feed(|l, _| l.sheet_loaded("a")), lines(&["ok: a fresh sheet is in plotter a", "wake a"]));
    assert_eq!(takes(&mut desk, "a").0, next);
}

/// A plotter with a paused job of its own is not idle; a job for a class a
/// person paused before any plotter took it is taken by none until
/// resumed, which wakes every plotter it fits.
#[test]
fn paused_jobs_hold_their_plotter_and_a_paused_class_job_waits() {
    let mut desk = Desk::new(&three(), vec![record(1, "a", JobState::paused(PauseCause::Person, "by a person"), 0)]);
    let (id, _) = submit_for(&mut desk, "any", &["a", "b"], true);
    assert_eq!(desk.life.poll("a", desk.now), Step::Wait(None), "a waits for its paused job");
    assert_eq!(
        desk.feed(|l, _| l.pause(Some(id), false)),
        lines(&["save 2 paused/person @0", "ok: 1 job(s) pausing at the next stroke boundary"])
    );
    assert_eq!(answer(&mut desk, "b"), Step::Wait(Some(desk.now + IDLE_CHECK)), "a paused job is taken by none");
    assert_eq!(desk.feed(|l, _| l.resume(Some(id), false)), lines(&["save 2 queued @0", "ok: resumed job(s) 2", "wake a", "wake b"]));
    let (job, _) = takes(&mut desk, "b");
    assert_eq!((job, desk.shown(id).plotter.as_str()), (id, "b"));
}

/// A restart finds a job for a class still waiting for any of its
/// plotters (the record keeps them), and one taken still its plotter's.
#[test]
fn a_job_for_a_class_survives_a_restart() {
    let mut waiting = record(2, "any", JobState::Queued, 0);
    waiting.class = Some(crate::spool::PlotterClass { name: "any".into(), fits: vec!["b".into()] });
    let mut taken = record(1, "a", JobState::Queued, 0);
    taken.class = Some(crate::spool::PlotterClass { name: "any".into(), fits: Vec::new() });
    let back: JobRecord = serde_json::from_str(&serde_json::to_string(&waiting).unwrap()).unwrap();
    assert_eq!(back, waiting, "the class is kept in the spool");
    let mut desk = Desk::new(&three(), vec![taken, back]);
    assert_eq!(takes(&mut desk, "a").0, 1, "a's own");
    assert_eq!(takes(&mut desk, "b").0, 2, "b is the one it fits");
    assert_eq!(answer(&mut desk, "cnc"), Step::Wait(Some(desk.now + IDLE_CHECK)));
}
