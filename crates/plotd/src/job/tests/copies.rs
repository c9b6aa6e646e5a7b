//! `--copies N`: one job drawn on N sheets, a wait for a fresh sheet
//! between each; the record says which copy is being drawn, across a
//! restart.

use super::*;

/// Three copies: each copy's end leaves the sheet used and the job queued
/// for its next copy from its first chunk; it waits `load-sheet` naming the
/// copy, `sheet-loaded` plots it again from the start, and the third ends
/// the job done.
#[test]
fn three_copies_wait_for_a_fresh_sheet_between_each() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit_with(|j| j.copies = 3);
    for copy in 1..=3 {
        let shown = desk.life.shown_job(id).unwrap();
        assert_eq!((shown.copy, shown.copies), (copy, 3));
        let end = plot_to_done(&mut desk, id, 2);
        assert_eq!(desk.sheet_saved(), Some(Sheet::Used), "copy {copy} used the sheet");
        if copy == 3 {
            assert_eq!(end, lines(&["forget mark 1", "save 1 done @3", "run ended"]));
            break;
        }
        assert_eq!(end, lines(&["forget mark 1", "save 1 queued @0", "run ended"]), "copy {copy}");
        let next = desk.life.shown_job(id).unwrap();
        assert_eq!((next.copy, next.strokes_done), (copy + 1, 0));
        let Step::Act(actions) = desk.poll() else { panic!("copy {} did not wait for a sheet", copy + 1) };
        assert_eq!(desk.carry(actions), lines(&["save 1 paused/load-sheet @0"]));
        let want = format!("copy {} of 3: load a fresh sheet on plotter hp, then: plotd sheet-loaded hp", copy + 1);
        assert_eq!(desk.reason(id), want);
        assert_eq!(
            desk.feed(|l, _| l.resume(Some(id), false)),
            lines(&["refused: job 1 waits for a fresh sheet: load one on plotter hp, then: plotd sheet-loaded hp"])
        );
        assert_eq!(desk.feed(|l, _| l.sheet_loaded("hp")), lines(&["save 1 queued @0", "ok: resumed job(s) 1", "wake hp"]));
    }
    assert_eq!(desk.life.shown_job(id).unwrap().copy, 3);
}

/// Copies on the same sheet (passes over one drawing) go on at once.
#[test]
fn copies_on_the_same_sheet_go_on_at_once() {
    let mut desk = Desk::new(&plotters("hp", ""), Vec::new());
    let id = desk.submit_with(|j| {
        j.copies = 2;
        j.same_sheet = true;
    });
    assert_eq!(plot_to_done(&mut desk, id, 1), lines(&["forget mark 1", "save 1 queued @0", "run ended"]));
    assert_eq!(plot_to_done(&mut desk, id, 1), lines(&["forget mark 1", "save 1 done @2", "run ended"]));
    assert_eq!(desk.life.shown_job(id).unwrap().copy, 2);
}

/// A restart between copies finds the job at its copy, waiting for a
/// fresh sheet (the plotter's sheet is saved used before the record).
#[test]
fn a_restart_between_copies_keeps_the_copy() {
    let mut waiting = record(4, "hp", JobState::Queued, 0);
    (waiting.copies, waiting.copy) = (3, 2);
    assert_eq!(after_restart(&waiting), None);
    let mut desk = Desk::new(&plotters("hp", ""), vec![waiting]);
    desk.life.restore_plotter("hp", PlotterState { sheet: Sheet::Used });
    let Step::Act(actions) = desk.poll() else { panic!("the job was not made to wait") };
    assert_eq!(desk.carry(actions), lines(&["save 4 paused/load-sheet @0"]));
    assert_eq!(desk.reason(4), "copy 2 of 3: load a fresh sheet on plotter hp, then: plotd sheet-loaded hp");
    assert_eq!((desk.disk[&4].copy, desk.disk[&4].copies), (2, 3));
}

/// Copies out of range are refused, naming the field.
#[test]
fn copies_out_of_range_are_refused() {
    assert!(JobLife::check_copies(1).is_ok() && JobLife::check_copies(MAX_COPIES).is_ok());
    for n in [0, MAX_COPIES + 1] {
        let e = JobLife::check_copies(n).unwrap_err().to_string();
        assert!(e.contains(&format!("copies: {n}")) && e.contains("1 to 1000"), "{e}");
    }
}
