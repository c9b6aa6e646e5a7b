//! The web page in a real browser: headless Chromium driven over WebDriver
//! (chromedriver), against the daemon driving plotsim over a pty. A job is
//! submitted through the page's file input, followed, paused and resumed
//! with its buttons; an unplug's cause shows; the pen marker stops while
//! the plotter is frozen and never runs ahead of the daemon's confirmed
//! chunk; the record equals the dry run. A screenshot taken mid-plot is
//! left in the test's output directory (`target/tmp/web-page.png`).
//!
//! Needs `chromium` and `chromedriver` (Debian `chromium`,
//! `chromium-driver`, which `.ci/run` installs): skipped without them,
//! failed under CI.

use fantoccini::{Client, ClientBuilder, Locator};
use plotd::client::{JobFile, Placing};
use plotd::protocol::State;
use plotd::spool::{JobKind, PauseCause};
use plotd_e2e::{
    assert_drawn_once, hpgl_lines, present_or_skip, program_missing, recorded, render_for, repo_root, strokes_of, wait_for, DaemonHandle,
    Rig,
};
use plotsim::SimConfig;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const LONG: Duration = Duration::from_secs(60);

/// The `[[plotter]]` table's tail that turns the page on, on a free port.
const WEB: &str = "\n[web]\nlisten = \"127.0.0.1:0\"\n";

/// Whether `test` can drive a browser: Chromium and ChromeDriver installed
/// (under CI a missing one fails the test, naming it).
fn browser_present(test: &str) -> bool {
    let missing = program_missing("chromium", "chromium").or_else(|| program_missing("chromedriver", "chromium-driver"));
    present_or_skip(test, missing)
}

/// chromedriver and a browser session, driven from synchronous test code.
struct Browser {
    rt: tokio::runtime::Runtime,
    client: Option<Client>,
    driver: Child,
    _profile: tempfile::TempDir,
}

impl Browser {
    fn start() -> Browser {
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let driver = Command::new("chromedriver")
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        wait_for("chromedriver to listen", LONG, || std::net::TcpStream::connect(("127.0.0.1", port)).is_ok());
        let profile = tempfile::tempdir().unwrap();
        // The machine's network is closed: nothing of the browser's own may reach out.
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--window-size=1280,860",
        ];
        let mut args: Vec<String> = args.iter().map(|a| (*a).to_owned()).collect();
        args.push(format!("--user-data-dir={}", profile.path().display()));
        let caps = json!({"browserName": "chrome", "goog:chromeOptions": {"args": args}});
        let Value::Object(caps) = caps else { unreachable!() };
        let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build().unwrap();
        let client = rt
            .block_on(
                ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
                    .capabilities(caps)
                    .connect(&format!("http://127.0.0.1:{port}")),
            )
            .expect("a Chromium session");
        Browser { rt, client: Some(client), driver, _profile: profile }
    }

    fn client(&self) -> &Client {
        self.client.as_ref().expect("open")
    }

    fn goto(&self, url: &str) {
        self.rt.block_on(self.client().goto(url)).unwrap();
    }

    /// Runs `script` (a function body; `return` gives the value).
    fn js(&self, script: &str) -> Value {
        self.rt.block_on(self.client().execute(script, Vec::new())).unwrap_or_else(|e| panic!("{script}: {e}"))
    }

    /// Clicks the element `css` finds. The page redraws its tables on every
    /// event, so the element found may be replaced before the click lands:
    /// then it is found again.
    fn click(&self, css: &str) {
        for _ in 0..50 {
            match self.rt.block_on(async { self.client().find(Locator::Css(css)).await?.click().await }) {
                Ok(()) => return,
                Err(e) if e.to_string().contains("stale element") => continue,
                Err(e) => panic!("{css}: {e}"),
            }
        }
        panic!("{css}: replaced before every one of 50 clicks");
    }

    fn send_keys(&self, css: &str, text: &str) {
        self.rt
            .block_on(async { self.client().find(Locator::Css(css)).await?.send_keys(text).await })
            .unwrap_or_else(|e| panic!("{css}: {e}"));
    }

    /// Waits until `script` returns something neither null nor false; returns it.
    fn until(&self, what: &str, timeout: Duration, script: &str) -> Value {
        let end = Instant::now() + timeout;
        loop {
            let v = self.js(script);
            if !(v.is_null() || v == Value::Bool(false)) {
                return v;
            }
            assert!(
                Instant::now() < end,
                "timed out waiting for the page to show {what}; it shows: {}",
                self.js("return document.body.innerText")
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn screenshot(&self) -> Vec<u8> {
        self.rt.block_on(self.client().screenshot()).unwrap()
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if let Some(c) = self.client.take() {
            let _ = self.rt.block_on(c.close());
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

#[test]
fn a_job_from_the_page_plots_pauses_resumes_and_shows_an_unplug() {
    if !browser_present("a_job_from_the_page_plots_pauses_resumes_and_shows_an_unplug") {
        return;
    }
    // Real motion speed: the job lasts long enough to pause, stall and unplug it.
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(1.0).with_baud(9600), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    // Many short strokes: a pause asked for lands before the last one.
    let text = hpgl_lines(150, 7);
    let file = rig.dir.path().join("lines.hpgl");
    std::fs::write(&file, &text).unwrap();

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    b.until("the live feed", LONG, "return document.getElementById('live').textContent === 'live'");
    b.until("the plotter", LONG, "return document.querySelector('#plotter-p .link')");

    // Submitted through the page's file input.
    b.send_keys("#file", &file.display().to_string());
    b.click("#submit-button");
    let id = b.until(
        "the job queued",
        LONG,
        "const m = /job (\\d+) queued/.exec(document.getElementById('message').textContent); return m && Number(m[1])",
    );
    let id = id.as_u64().unwrap();
    let job = rig.job(id);
    assert_eq!((job.name.as_str(), job.plotter.as_str()), ("lines.hpgl", "p"));

    // Progress, and the preview with its marker, as the device confirms chunks.
    b.until(
        "progress",
        LONG,
        &format!(
            "const r = document.getElementById('job-{id}'); return r && r.dataset.state === 'plotting' && Number(r.dataset.checkpoint) > 2"
        ),
    );
    b.until("the pen marker", LONG, "return document.getElementById('marker')");
    // The daemon refuses manual control while a job plots: the page hides it.
    assert_eq!(b.js("return document.getElementById('manual').style.display"), Value::from("none"), "manual controls offered mid-plot");
    let shot = b.screenshot();
    assert!(shot.starts_with(b"\x89PNG"), "a PNG");
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("web-page.png");
    std::fs::write(&out, &shot).unwrap();

    // Frozen plotter: the marker stops where the device last confirmed,
    // never ahead of the daemon's checkpoint.
    let marker = "const m = document.getElementById('marker'); return m && Number(m.dataset.chunk)";
    rig.sim.stall(Duration::from_secs(2)).unwrap();
    let mut caught_up = None;
    let mut after = 0;
    while rig.sim.status().stalled {
        let shown = b.js(marker).as_u64().unwrap();
        let confirmed = rig.job(id).checkpoint as u64;
        assert!(shown <= confirmed, "the marker (chunk {shown}) ran ahead of the confirmed checkpoint {confirmed}");
        match caught_up {
            None if shown == confirmed => caught_up = Some(shown),
            Some(at) => {
                assert_eq!(shown, at, "the marker moved while the plotter was frozen");
                after += 1;
            }
            None => {}
        }
    }
    assert!(after > 0, "the page never showed the confirmed chunk while the plotter was frozen");

    // Pause and resume with the page's buttons.
    b.until("the pause button", LONG, &format!("return document.querySelector('#job-{id} button[name=pause]')"));
    b.click(&format!("#job-{id} button[name=pause]"));
    b.until("the job paused", LONG, &format!("const r = document.getElementById('job-{id}'); return r && r.dataset.state === 'paused'"));
    assert_eq!(rig.job(id).state, plotd::protocol::State::Paused);
    b.until("the manual controls of the paused plotter", LONG, "return document.getElementById('manual').style.display !== 'none'");
    b.click(&format!("#job-{id} button[name=resume]"));
    b.until(
        "the job plotting again",
        LONG,
        &format!("const r = document.getElementById('job-{id}'); return r && r.dataset.state === 'plotting'"),
    );

    // An unplug: the cause is on the page within 2 s of the daemon's pause.
    rig.sim.unplug(Duration::from_secs(2)).unwrap();
    let reason = rig.paused_reason(id, LONG);
    assert!(reason.contains("offline"), "{reason}");
    b.until(
        "the unplug's cause",
        Duration::from_secs(2),
        &format!("const c = document.querySelector('#job-{id} .cause'); return c && c.textContent.includes('offline')"),
    );
    rig.sim.wait_connected(LONG).unwrap();
    rig.wait_online(LONG);
    b.click(&format!("#job-{id} button[name=resume]"));
    b.until("the job done", LONG * 3, &format!("const r = document.getElementById('job-{id}'); return r && r.dataset.state === 'done'"));

    // What plotsim drew is the dry run (a stroke cut by the unplug drawn again at most).
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    assert_drawn_once(&recorded(&rig.sim), &strokes_of(&text, "hp7475a"), 1);
    assert_eq!(rig.sim.record().overruns, 0);
}

/// A scene uploaded through the page with the files it names (the bundled
/// map: its outline and its towns, in `map/`), chosen together in the file
/// input as a person picks them: a browser gives each file's bare name, and
/// the page must send it under the name the scene writes (`map/towns.csv`),
/// or the daemon cannot find it. The job plots to the end.
#[test]
fn a_scene_uploaded_with_its_files_from_the_page_plots() {
    if !browser_present("a_scene_uploaded_with_its_files_from_the_page_plots") {
        return;
    }
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let picked: Vec<String> = ["map.toml", "map/westmark.geojson", "map/towns.csv"]
        .iter()
        .map(|f| examples.join(f).canonicalize().unwrap().display().to_string())
        .collect();

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    b.until("the plotter", LONG, "return document.querySelector('#plotter-p .link')");
    // Several files at once: WebDriver takes them one per line.
    b.send_keys("#file", &picked.join("\n"));
    b.click("#submit-button");
    let id = b.until(
        "the job queued",
        LONG,
        "const m = /job (\\d+) queued/.exec(document.getElementById('message').textContent); return m && Number(m[1])",
    );
    let id = id.as_u64().unwrap();
    let job = rig.wait_state(id, plotd::protocol::State::Done, LONG * 3);
    assert_eq!(job.name, "map.toml");
    assert!(job.total.unwrap_or(0) > 10, "{job:?}");
}

/// A job waiting for a fresh sheet (`load-sheet`, the sheet used by the job
/// before it) offers "Sheet loaded" on the page, and no plain resume, which
/// the daemon refuses for it; the button sends `sheet-loaded` for its
/// plotter and the job plots to the end.
#[test]
fn a_job_waiting_for_a_sheet_goes_on_when_the_page_confirms_one() {
    if !browser_present("a_job_waiting_for_a_sheet_goes_on_when_the_page_confirms_one") {
        return;
    }
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    let first = rig.submit(JobKind::Hpgl, "IN;SP1;PU1000,1000;PD2000,1000;PU;");
    rig.wait_state(first, State::Done, LONG);
    // Not on the same sheet (as `submit` places it): this one waits for a fresh one.
    let job = JobFile { kind: JobKind::Hpgl, content: "IN;SP1;PU1200,800;PD2400,1000;PU;".into(), files: BTreeMap::new() };
    let waiting = rig.client().submit_job(job, &Placing::default(), "second").unwrap();
    let job = rig.wait_state(waiting, State::Paused, LONG);
    assert_eq!(job.cause, Some(PauseCause::LoadSheet));

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    let row = format!("#job-{waiting}");
    b.until("the sheet-loaded button", LONG, &format!("return document.querySelector('{row} button[name=sheet-loaded]')"));
    b.until(
        "the used sheet in the plotter's row",
        LONG,
        "const c = document.querySelector('#plotter-p .sheet'); return c && c.textContent.includes('used')",
    );
    assert_eq!(
        b.js(&format!("return document.querySelector('{row} button[name=resume]') === null")),
        Value::Bool(true),
        "a plain resume is offered for a job the daemon holds for its sheet"
    );
    // Framed first from the page: the pen goes round the job's box, raised.
    rig.sim.wait_idle(LONG).unwrap();
    let (drawn, travelled) = (recorded(&rig.sim), rig.sim.record().travel.len());
    b.js("document.getElementById('message').textContent = ''; return true");
    b.click(&format!("{row} button[name=frame]"));
    let said = b.until("the frame's answer", LONG, "return document.getElementById('message').textContent || null");
    assert!(said.as_str().unwrap().starts_with(&format!("traced job {waiting}'s frame")), "{said}");
    assert_eq!(rig.sim.record().travel.len() - travelled, 5, "four corners and back");
    assert_eq!(recorded(&rig.sim), drawn, "a frame draws nothing");
    b.click(&format!("{row} button[name=sheet-loaded]"));
    b.until("the job done", LONG, &format!("const r = document.querySelector('{row}'); return r && r.dataset.state === 'done'"));
    assert_eq!(rig.job(waiting).state, State::Done);
}

/// A job paused because its device lost its position (`position-lost`)
/// offers only "Resume, position confirmed" on the page (a plain resume is
/// refused by the daemon); the button sends `resume` with
/// `position_confirmed` and the job goes on.
#[test]
fn a_position_lost_job_resumes_from_the_pages_confirm_button() {
    if !browser_present("a_position_lost_job_resumes_from_the_pages_confirm_button") {
        return;
    }
    // An alarm mid-job (a hard limit) on GRBL loses the position.
    let sim = SimConfig::grbl().with_speed_scale(0.0).with_baud(115_200);
    let rig = Rig::start(sim, "grbl-servo", "grbl", "pen_change = \"ignore\"\nauto_resume = true\n[web]\nlisten = \"127.0.0.1:0\"\n");
    let addr = rig.web_address();
    let text = render_for(&repo_root().join("examples/lattice.toml"), "grbl-servo");
    let id = rig.submit(JobKind::Gcode, &text);
    rig.sim.wait_received(text.len() as u64 / 3, LONG).unwrap();
    rig.sim.alarm(1).unwrap();
    let reason = rig.paused_reason(id, LONG);
    assert_eq!(rig.job(id).cause, Some(PauseCause::PositionLost), "{reason}");

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    let row = format!("#job-{id}");
    b.until("the confirm button", LONG, &format!("return document.querySelector('{row} button[name=resume-position-confirmed]')"));
    assert_eq!(
        b.js(&format!("return document.querySelector('{row} button[name=resume]') === null")),
        Value::Bool(true),
        "a plain resume is offered for a job whose position is lost"
    );
    b.click(&format!("{row} button[name=resume-position-confirmed]"));
    b.until("the job done", LONG * 2, &format!("const r = document.querySelector('{row}'); return r && r.dataset.state === 'done'"));
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    assert_drawn_once(&recorded(&rig.sim), &strokes_of(&text, "grbl-servo"), 1);
}

/// Copies from the page: the submit form's copies field goes in the
/// request; the job draws its first sheet, waits for a fresh one, which
/// the page's "Sheet loaded" confirms, and draws it again.
#[test]
fn a_job_submitted_with_two_copies_from_the_page_draws_two_sheets() {
    if !browser_present("a_job_submitted_with_two_copies_from_the_page_draws_two_sheets") {
        return;
    }
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    let text = "IN;SP1;PU1000,1000;PD2000,1000,2000,1800;PU;";
    let file = rig.dir.path().join("corner.hpgl");
    std::fs::write(&file, text).unwrap();

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    b.until("the plotter", LONG, "return document.querySelector('#plotter-p .link')");
    b.send_keys("#file", &file.display().to_string());
    b.js("const c = document.getElementById('copies'); c.value = '2'; return true");
    b.click("#submit-button");
    let id = b.until(
        "the job queued",
        LONG,
        "const m = /job (\\d+) queued/.exec(document.getElementById('message').textContent); return m && Number(m[1])",
    );
    let id = id.as_u64().unwrap();
    let job = rig.job(id);
    assert_eq!((job.copies, job.same_sheet), (2, false));
    let row = format!("#job-{id}");
    // Every sheet it waits for, the page confirms, until it is done.
    let end = Instant::now() + LONG;
    loop {
        let state = b.until(
            "the job waiting for a sheet or done",
            LONG,
            &format!(
                "const r = document.querySelector('{row}'); return r && (r.dataset.state === 'done' ? 'done' : r.querySelector('button[name=sheet-loaded]') ? 'sheet' : null)"
            ),
        );
        if state == "done" {
            break;
        }
        b.click(&format!("{row} button[name=sheet-loaded]"));
        b.until(
            "the sheet confirmed",
            LONG,
            &format!("const r = document.querySelector('{row}'); return r && !r.querySelector('button[name=sheet-loaded]')"),
        );
        assert!(Instant::now() < end, "job {id} never done");
    }
    rig.sim.wait_idle(Duration::from_secs(20)).unwrap();
    assert_eq!(recorded(&rig.sim).len(), 2 * strokes_of(text, "hp7475a").len(), "two sheets of one stroke each");
}

/// The page's manual controls on an idle plotter: the pen down and up,
/// the carriage to a point, then one jog of the pad's step to the right;
/// plotsim's carriage ends where they sent it, and nothing is drawn.
#[test]
fn the_pages_jog_pad_moves_the_carriage_by_its_step() {
    if !browser_present("the_pages_jog_pad_moves_the_carriage_by_its_step") {
        return;
    }
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    let u = plotcode::DeviceProfile::builtin(&rig.device).unwrap().unit_mm;
    let at = |x: f64, y: f64| {
        let p = rig.sim.status().device.position;
        (p[0] * u - x).abs() <= 0.1 && (p[1] * u - y).abs() <= 0.1
    };

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    b.until("the manual controls", LONG, "const m = document.getElementById('manual'); return m && m.style.display !== 'none' && document.getElementById('manual-plotter').value === 'p'");
    // Each control's answer shown (the daemon answers once the device has
    // done it) before the next is pressed.
    let press = |button: &str| {
        b.js("document.getElementById('message').textContent = ''; return true");
        b.click(button);
        let said = b.until(&format!("{button}'s answer"), LONG, "return document.getElementById('message').textContent || null");
        assert!(said.as_str().unwrap().contains("plotter p"), "{button}: {said}");
    };
    press("#pen-down");
    assert!(rig.sim.status().device.pen_down);
    press("#pen-up");
    assert!(!rig.sim.status().device.pen_down);

    b.js("document.getElementById('move-x').value = '40'; document.getElementById('move-y').value = '30'; return true");
    press("#move");
    assert!(at(40.0, 30.0), "at {:?}", rig.sim.status().device.position);
    b.js("document.getElementById('jog-step').value = '5'; return true");
    press("#jog-right");
    assert!(at(45.0, 30.0), "at {:?}", rig.sim.status().device.position);

    // The offset set from the page is the daemon's, and its row shows it.
    b.js("document.getElementById('offset-x').value = '3'; document.getElementById('offset-y').value = '-4.5'; return true");
    press("#set-offset");
    let Ok(plotd::protocol::Reply::Status { plotters, .. }) = rig.client().call(&plotd::protocol::Request::Status {}) else {
        panic!("no status")
    };
    assert_eq!(plotters[0].offset_mm, [3.0, -4.5]);
    b.until(
        "the offset in the plotter's row",
        LONG,
        "const c = document.querySelector('#plotter-p .offset'); return c && c.textContent === '3, -4.5 mm'",
    );
    assert!(recorded(&rig.sim).is_empty(), "nothing drawn");
}

/// The plotter's status now, as the socket's `status` gives it.
fn plotter_now(rig: &Rig) -> plotd::protocol::PlotterInfo {
    let Ok(plotd::protocol::Reply::Status { mut plotters, .. }) = rig.client().call(&plotd::protocol::Request::Status {}) else {
        panic!("no status")
    };
    plotters.remove(0)
}

/// With the page's polling turned off (`?poll=0`), what changes at the
/// plotter with no job event reaches the page by the event stream alone,
/// each within 2 s of the daemon knowing it: a sheet loaded (asked on the
/// socket, so the page's own request does not reload it), the cable
/// pulled (the cause on the plotter's row) and put back.
#[test]
fn plotter_changes_reach_the_page_by_its_event_stream_with_polling_off() {
    if !browser_present("plotter_changes_reach_the_page_by_its_event_stream_with_polling_off") {
        return;
    }
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    let drawn = rig.submit(JobKind::Hpgl, "IN;SP1;PU1000,1000;PD2000,1000;PU;");
    rig.wait_state(drawn, State::Done, LONG);
    assert_eq!(plotter_now(&rig).sheet, plotd::spool::Sheet::Used);

    let b = Browser::start();
    b.goto(&format!("http://{addr}/?poll=0"));
    b.until("the live feed", LONG, "return document.getElementById('live').textContent === 'live'");
    b.until("the used sheet", LONG, "const c = document.querySelector('#plotter-p .sheet'); return c && c.textContent.includes('used')");
    b.until("the plotter online", LONG, "const c = document.querySelector('#plotter-p .link'); return c && c.textContent === 'online'");

    rig.client().call(&plotd::protocol::Request::SheetLoaded { plotter: "p".into() }).expect("sheet-loaded answered");
    b.until(
        "the fresh sheet, from the event stream",
        Duration::from_secs(2),
        "const c = document.querySelector('#plotter-p .sheet'); return c && c.textContent.includes('fresh')",
    );

    rig.sim.unplug(Duration::from_secs(20)).unwrap();
    wait_for("the daemon to find the plotter offline", LONG, || plotter_now(&rig).link == plotd::protocol::LinkState::Offline);
    // The cause may change while the adapter is away (the port closed, then
    // no such port): the page shows the daemon's latest.
    let end = Instant::now() + Duration::from_secs(2);
    loop {
        let cause = plotter_now(&rig).cause.expect("an offline plotter says why").message;
        let shown = b.js("const c = document.querySelector('#plotter-p .link'); return c && c.textContent");
        if shown.as_str() == Some(format!("offline: {cause}").as_str()) {
            break;
        }
        assert!(Instant::now() < end, "the page shows {shown} for the plotter, 2 s after the daemon found it offline: {cause}");
        std::thread::sleep(Duration::from_millis(20));
    }
    rig.sim.wait_connected(LONG).unwrap();
    rig.wait_online(LONG);
    b.until(
        "the plotter online again, from the event stream",
        Duration::from_secs(2),
        "const c = document.querySelector('#plotter-p .link'); return c && c.textContent === 'online'",
    );
}

/// The plotter's row shows the pen in a one-pen plotter, as the daemon
/// keeps it (`status`'s `pen_loaded`), with no job on it: pen 1 before a
/// two-pen job, pen 2 once a person put it in for the job's second pen.
#[test]
fn the_plotter_row_shows_the_pen_loaded() {
    if !browser_present("the_plotter_row_shows_the_pen_loaded") {
        return;
    }
    let rig = Rig::start(SimConfig::grbl().with_speed_scale(0.0), "grbl-servo", "grbl", WEB);
    let addr = rig.web_address();
    let mut text = String::from("G21 G90\nM5\n");
    for (k, pen) in [1, 2].into_iter().enumerate() {
        let x = 20 + 30 * k;
        text += &format!("T{pen}\nG0 X{x} Y20\nM3 S1000\nG1 X{x} Y60 F3000\nM5\n");
    }
    let id = rig.submit(JobKind::Gcode, &text);
    let job = rig.wait_state(id, State::Paused, LONG);
    assert_eq!(job.insert_pen, Some(2), "{job:?}");

    let b = Browser::start();
    b.goto(&format!("http://{addr}/?poll=0"));
    b.until(
        "pen 1 in the plotter's row",
        LONG,
        "const c = document.querySelector('#plotter-p .pen'); return c && c.textContent === 'pen 1'",
    );
    b.click("#plotter-p button[name=pen-changed]");
    rig.wait_state(id, State::Done, LONG);
    assert_eq!(plotter_now(&rig).pen_loaded, Some(2));
    b.until(
        "pen 2 in the plotter's row",
        LONG,
        "const c = document.querySelector('#plotter-p .pen'); return c && c.textContent === 'pen 2'",
    );
    // The job's end and the pen's change reach the page as separate events,
    // in either order.
    b.until("no job in the plotter's row", LONG, "return document.querySelector('#plotter-p').cells[3].textContent === ''");
}

/// A pens map typed on the page (`1=3,2=1`, as `plotd submit --pens`
/// takes it) goes in the submit; the daemon reads it, keeps it in the
/// job's record, and refuses a bad one with its message on the page.
#[test]
fn a_pens_map_from_the_page_is_kept_in_the_job_and_a_bad_one_refused() {
    if !browser_present("a_pens_map_from_the_page_is_kept_in_the_job_and_a_bad_one_refused") {
        return;
    }
    let rig = Rig::start(SimConfig::hp7475a().with_speed_scale(0.0), "hp7475a", "escb", WEB);
    let addr = rig.web_address();
    let svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100mm\" height=\"100mm\" viewBox=\"0 0 100 100\">\
        <path d=\"M10 10 L60 10\" fill=\"none\" stroke=\"#000\"/><path d=\"M10 30 L60 30\" fill=\"none\" stroke=\"#c00\"/></svg>\n";
    let file = rig.dir.path().join("two.svg");
    std::fs::write(&file, svg).unwrap();

    let b = Browser::start();
    b.goto(&format!("http://{addr}/"));
    b.until("the plotter", LONG, "return document.querySelector('#plotter-p .link')");
    b.send_keys("#file", &file.display().to_string());
    let submit = |pens: &str| {
        b.js(&format!(
            "document.getElementById('message').textContent = ''; document.getElementById('pens').value = {}; return true",
            json!(pens)
        ));
        b.click("#submit-button");
        b.until("the submit's answer", LONG, "return document.getElementById('message').textContent || null")
    };
    let refused = submit("1=9");
    assert!(refused.as_str().unwrap().contains("no pen 9"), "{refused}");
    assert_eq!(b.js("return document.getElementById('message').className"), Value::from("error"));
    let refused = submit("1=x");
    assert!(refused.as_str().unwrap().contains("`1=x` is not JOB=PLOTTER"), "{refused}");
    let said = submit(" 1=3, 2=1 ");
    let id: u64 = said.as_str().unwrap().strip_prefix("job ").and_then(|s| s.strip_suffix(" queued")).unwrap().parse().unwrap();
    assert_eq!(rig.job(id).pens, BTreeMap::from([(1, 3), (2, 1)]));
    let job = rig.wait_state(id, State::Done, LONG);
    assert_eq!(job.pens, BTreeMap::from([(1, 3), (2, 1)]));
    let pens: std::collections::BTreeSet<u32> = recorded(&rig.sim).into_iter().map(|(pen, _)| pen).collect();
    assert_eq!(pens, std::collections::BTreeSet::from([3, 1]), "drawn with the plotter's pens 3 and 1");
}
