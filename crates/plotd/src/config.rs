//! The daemon's configuration file (`plotd serve --config plotd.toml`).
//!
//! The keys are a stable interface: users' scripts and packaging write such
//! files. Unknown keys and bad values are errors that name the key.

use plotcode::{DeviceProfile, Handshake};
use serde::Deserialize;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::Duration;
use thiserror::Error;

/// Default limit on one request line over the socket (a whole job's content).
pub const DEFAULT_MAX_REQUEST_BYTES: usize = 16 * 1024 * 1024;
/// Largest limit a config may set, so a typo cannot ask for unbounded memory.
pub const MAX_MAX_REQUEST_BYTES: usize = 1024 * 1024 * 1024;
/// Most plotters one daemon drives; each gets a task and a port.
pub const MAX_PLOTTERS: usize = 64;
/// Finished jobs (done, failed, cancelled) the spool keeps by default.
pub const DEFAULT_KEEP_FINISHED: usize = 100;
/// Largest `keep_finished` a config may set.
pub const MAX_KEEP_FINISHED: usize = 1_000_000;
/// Default for `max_connections`: client connections open at once, all users.
pub const DEFAULT_MAX_CONNECTIONS: usize = 256;
/// Default for `max_connections_per_uid`.
pub const DEFAULT_MAX_CONNECTIONS_PER_UID: usize = 32;
/// Default for `idle_timeout_s`: a connection that sends nothing for this
/// long (between requests, or in the middle of one) is closed; `watch` is not idle.
pub const DEFAULT_IDLE_TIMEOUT_S: f64 = 60.0;

/// Default wall-clock seconds for checking or rendering one job.
pub const DEFAULT_RENDER_SECONDS: f64 = 300.0;
/// Default address space of the job worker, MiB.
pub const DEFAULT_RENDER_MEMORY_MB: u64 = 4096;
/// Default limit of the general hidden-line engine's estimated work on one
/// job, face tests (`hiddenline::engine::estimate`, `max_face_tests`): about
/// five minutes of large triangles that all cross each other (6,500 of
/// them; 1,000 are 6.7 x 10^8 tests and 1.7 s, and time grows as n^2.7),
/// about three times what a height field of four million triangles (the
/// most faces a job may have) seen at a slant estimates to (a million:
/// 1.75 x 10^10).
pub const DEFAULT_MAX_FACE_TESTS: u64 = 200_000_000_000;
/// The line rates a plotter may be set to (`baud`): the standard ones
/// plotters and their USB adapters offer. A rate outside them is almost
/// always a typo.
pub const STANDARD_RATES: [u32; 11] = [300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115_200, 230_400];

/// Whether `baud` is one of the [`STANDARD_RATES`].
#[must_use]
pub fn is_standard_rate(baud: u32) -> bool {
    STANDARD_RATES.contains(&baud)
}

/// How much one job's check or render may take in the job worker
/// (`render_seconds`, `render_memory_mb`, `max_face_tests`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Wall-clock seconds; CPU time is limited to this times the cores.
    pub seconds: f64,
    /// Address space, MiB.
    pub memory_mb: u64,
    /// The general hidden-line engine's estimated work on a scene, face
    /// tests, at most: a scene estimated beyond it is refused by the check
    /// (`job_check::engine_work`) instead of taking the budget's time to
    /// fail.
    pub face_tests: u64,
}

impl Default for Budget {
    fn default() -> Self {
        Budget { seconds: DEFAULT_RENDER_SECONDS, memory_mb: DEFAULT_RENDER_MEMORY_MB, face_tests: DEFAULT_MAX_FACE_TESTS }
    }
}

/// Why a configuration could not be used.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: {reason}")]
    Read {
        /// The config file.
        path: PathBuf,
        /// What the OS said (in the message, not a source: said once).
        reason: std::io::Error,
    },
    /// The TOML is malformed, a key is unknown or a value has the wrong type.
    /// The message names the key and the line.
    #[error("{origin}: {message}")]
    Parse {
        /// The config file, or `<string>`.
        origin: String,
        /// The parser's message, naming key, line and column.
        message: String,
    },
    /// A value parsed but is not acceptable.
    #[error("{origin}: key `{key}`: {message}")]
    Value {
        /// The config file, or `<string>`.
        origin: String,
        /// Dotted path of the key, e.g. `plotter[1].baud`.
        key: String,
        /// What is wrong with it.
        message: String,
    },
}

/// The whole configuration.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Unix socket path the daemon listens on; default [`default_socket_path`].
    #[serde(default = "default_socket_path")]
    pub socket: PathBuf,
    /// Spool directory holding every job and its state; default [`default_spool_dir`].
    #[serde(default = "default_spool_dir")]
    pub spool: PathBuf,
    /// Largest request line accepted over the socket, bytes.
    #[serde(default = "default_max_request")]
    pub max_request_bytes: usize,
    /// How many finished jobs (done, failed, cancelled) the spool keeps, the
    /// newest by id; older ones are deleted with their content. At least 1,
    /// so the newest id survives a restart and ids are never reused.
    #[serde(default = "default_keep_finished")]
    pub keep_finished: usize,
    /// Wall-clock seconds one job's check (at submit) or render may take
    /// in the job worker; its CPU time is bounded by this times the cores.
    #[serde(default = "default_render_seconds")]
    pub render_seconds: f64,
    /// Address space of the job worker, MiB.
    #[serde(default = "default_render_memory_mb")]
    pub render_memory_mb: u64,
    /// The general hidden-line engine's estimated work on one scene, face
    /// tests, at most: beyond it the job is refused at submit.
    #[serde(default = "default_max_face_tests")]
    pub max_face_tests: u64,
    /// Client connections open at once, all users together (at most the
    /// process's file descriptor limit less a reserve).
    #[serde(default = "default_max_connections")]
    pub max_connections: usize,
    /// Client connections one uid may hold at once.
    #[serde(default = "default_max_connections_per_uid")]
    pub max_connections_per_uid: usize,
    /// Seconds a connection may stay silent before it is closed.
    #[serde(default = "default_idle_timeout")]
    pub idle_timeout_s: f64,
    /// The plotters this daemon drives.
    #[serde(default, rename = "plotter")]
    pub plotters: Vec<PlotterConfig>,
    /// The web page (`[web]`); off when the table is absent.
    #[serde(default)]
    pub web: Option<WebConfig>,
}

/// The `[web]` table: where the page listens and who may use it.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WebConfig {
    /// Address and port of the page; default [`DEFAULT_WEB_LISTEN`]. Any
    /// address but a loopback one needs `token_file`.
    #[serde(default = "default_web_listen")]
    pub listen: std::net::SocketAddr,
    /// A file holding the bearer token every API request must carry
    /// (relative to the config file's directory); made, mode 0600, with a
    /// new random token when missing. Left out: no token is asked for,
    /// which only a loopback `listen` allows.
    #[serde(default)]
    pub token_file: Option<PathBuf>,
}

/// Where the web page listens when `[web]` has no `listen`: loopback only.
pub const DEFAULT_WEB_LISTEN: &str = "127.0.0.1:8765";

fn default_web_listen() -> std::net::SocketAddr {
    DEFAULT_WEB_LISTEN.parse().expect("a socket address")
}

/// One `[[plotter]]` table.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlotterConfig {
    /// Name clients use with `--plotter`.
    pub name: String,
    /// Serial port path, e.g. `/dev/ttyUSB0` (`auto`: the one EiBotBoard
    /// plugged in); empty when `nickname` names the port.
    #[serde(default)]
    pub port: PathBuf,
    /// An EiBotBoard's nickname (`QT`, set with `ST`): the port is the
    /// board's that answers it, asked afresh at each connect. In place of
    /// `port`.
    #[serde(default)]
    pub nickname: Option<String>,
    /// Line rate in baud; left out, the rate the device's firmware runs at
    /// ([`default_baud`], filled in when the config is loaded).
    #[serde(default, rename = "baud")]
    baud_set: Option<u32>,
    /// The line rate used: `baud`, or the device's default.
    #[serde(skip)]
    pub baud: u32,
    /// Device profile: a built-in name (see `config/devices/`), e.g. `hp7475a`
    /// or `grbl-servo`, or the path of a profile TOML (relative to the config
    /// file's directory).
    pub device: String,
    /// The profile `device` names, read when the config is loaded (so a
    /// profile file is read once, and a bad one stops the config, not a job).
    #[serde(skip)]
    pub profile: Option<DeviceProfile>,
    /// Flow control on the line; left out, the device profile's (filled in
    /// when the config is loaded). See [`PlotterConfig::handshake`].
    #[serde(default)]
    pub handshake: Option<Handshake>,
    /// What to do when a job changes pens.
    #[serde(default)]
    pub pen_change: PenChangePolicy,
    /// Resume an interrupted job by itself once the port is back; default off:
    /// a plotter that starts moving on its own is a safety problem.
    #[serde(default)]
    pub auto_resume: bool,
    /// The machine has homing switches (GRBL's homing cycle): a job waiting
    /// `needs-homing` or `position-lost` goes on with a plain `resume`,
    /// which homes it first. Default off: the person parks the pen and
    /// confirms (`resume --position-confirmed`).
    #[serde(default)]
    pub homing: bool,
    /// What a device error (HP-GL OE/ESC.E, GRBL `error:`) does to the job.
    #[serde(default)]
    pub on_device_error: DeviceErrorPolicy,
    /// Seconds to wait for the device's answer to a query before calling it offline.
    #[serde(default = "default_reply_timeout")]
    pub reply_timeout_s: f64,
    /// Seconds to wait for a confirmation that depends on the plotter finishing
    /// moves (HP-GL OA round trips in `xonxoff`/`hardware` mode, GRBL `ok`s).
    #[serde(default = "default_motion_timeout")]
    pub motion_timeout_s: f64,
    /// Its pen table, `[[plotter.pen]]` ([`crate::pen_table`]).
    #[serde(default)]
    pub pen: Vec<crate::pen_table::PenEntry>,
}

/// Pen-change policy.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum PenChangePolicy {
    /// Pause with "insert pen N" when the device has a single pen (GRBL boards), else go on.
    #[default]
    Auto,
    /// Always pause at a pen change until `pen-changed`.
    Pause,
    /// Never pause (the device changes pens itself).
    Ignore,
}

/// What a device error does.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum DeviceErrorPolicy {
    /// Pause the job with the device's error text; `resume` goes on from the checkpoint.
    #[default]
    Pause,
    /// Fail the job with the device's error text.
    Fail,
}

fn default_max_request() -> usize {
    DEFAULT_MAX_REQUEST_BYTES
}
fn default_keep_finished() -> usize {
    DEFAULT_KEEP_FINISHED
}
fn default_render_seconds() -> f64 {
    DEFAULT_RENDER_SECONDS
}
fn default_render_memory_mb() -> u64 {
    DEFAULT_RENDER_MEMORY_MB
}
fn default_max_face_tests() -> u64 {
    DEFAULT_MAX_FACE_TESTS
}
fn default_max_connections() -> usize {
    DEFAULT_MAX_CONNECTIONS
}
fn default_max_connections_per_uid() -> usize {
    DEFAULT_MAX_CONNECTIONS_PER_UID
}
fn default_idle_timeout() -> f64 {
    DEFAULT_IDLE_TIMEOUT_S
}
/// The line rate a device's firmware runs at out of the box: GRBL 1.1
/// 115200, an HP-GL plotter's switches 9600; the EiBotBoard is USB, which
/// ignores the rate (any standard one does).
#[must_use]
pub fn default_baud(protocol: plotcode::Protocol) -> u32 {
    match protocol {
        plotcode::Protocol::Gcode | plotcode::Protocol::Ebb => 115_200,
        plotcode::Protocol::Hpgl => 9600,
    }
}
fn default_reply_timeout() -> f64 {
    2.0
}
fn default_motion_timeout() -> f64 {
    120.0
}

/// Whether `name` can be an EiBotBoard's nickname: 1 to 16 printable ASCII
/// characters (the most `ST` keeps), none a comma (`ST` ends its argument
/// there), the first not a space (a board shows no name starting so).
fn is_ebb_nickname(name: &str) -> bool {
    (1..=16).contains(&name.len()) && !name.starts_with(' ') && name.bytes().all(|b| (b' '..=b'~').contains(&b) && b != b',')
}

/// True when this process runs as a systemd service.
fn under_systemd() -> bool {
    std::env::var_os("INVOCATION_ID").is_some() || std::env::var_os("NOTIFY_SOCKET").is_some()
}

/// The system daemon's socket: `RuntimeDirectory=plotd` in `config/plotd.service`.
pub const SYSTEM_SOCKET: &str = "/run/plotd/plotd.sock";

/// The socket path the daemon listens on when none is given:
/// [`SYSTEM_SOCKET`] under systemd, else `$XDG_RUNTIME_DIR/plotd.sock`,
/// else `/tmp/plotd-$UID/plotd.sock`.
pub fn default_socket_path() -> PathBuf {
    if under_systemd() {
        return PathBuf::from(SYSTEM_SOCKET);
    }
    match std::env::var_os("XDG_RUNTIME_DIR") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir).join("plotd.sock"),
        _ => PathBuf::from(format!("/tmp/plotd-{}", nix::unistd::getuid())).join("plotd.sock"),
    }
}

/// The spool directory when none is given: `$STATE_DIRECTORY` (systemd's
/// `StateDirectory=`), else `$XDG_STATE_HOME/plotd/spool`, else
/// `~/.local/state/plotd/spool`; empty when none of them is set, which
/// [`Config`]'s checks refuse (there is no fallback under `/tmp`, where
/// another user could make the spool first).
pub fn default_spool_dir() -> PathBuf {
    let var = |name| std::env::var_os(name);
    spool_dir_from(var("STATE_DIRECTORY"), var("XDG_STATE_HOME"), var("HOME")).unwrap_or_default()
}

fn spool_dir_from(state: Option<OsString>, xdg_state: Option<OsString>, home: Option<OsString>) -> Option<PathBuf> {
    let set = |v: Option<OsString>| v.filter(|d| !d.is_empty()).map(PathBuf::from);
    set(state)
        .map(|d| d.join("spool"))
        .or_else(|| set(xdg_state).map(|d| d.join("plotd/spool")))
        .or_else(|| set(home).map(|d| d.join(".local/state/plotd/spool")))
}

impl Config {
    /// Reads and checks the config file at `path`.
    ///
    /// # Errors
    /// [`ConfigError`] naming the file and the offending key.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|reason| ConfigError::Read { path: path.to_owned(), reason })?;
        let dir = path.parent().unwrap_or(Path::new(""));
        Config::parse(&text, &path.display().to_string(), dir)
    }

    /// Parses and checks config text; `origin` names it in errors. Profile
    /// paths in `device` are relative to the working directory.
    ///
    /// # Errors
    /// [`ConfigError::Parse`] for malformed TOML, unknown keys and wrong types;
    /// [`ConfigError::Value`] for values out of range.
    pub fn from_toml(text: &str, origin: &str) -> Result<Config, ConfigError> {
        Config::parse(text, origin, Path::new(""))
    }

    fn parse(text: &str, origin: &str, dir: &Path) -> Result<Config, ConfigError> {
        let mut config: Config = toml::from_str(text)
            .map_err(|e| ConfigError::Parse { origin: origin.to_owned(), message: e.to_string().trim_end().to_owned() })?;
        config.validate(origin)?;
        for (i, p) in config.plotters.iter_mut().enumerate() {
            let device = load_device(&p.device, dir).map_err(|message| ConfigError::Value {
                origin: origin.to_owned(),
                key: format!("plotter[{i}].device"),
                message,
            })?;
            if p.nickname.is_some() && device.protocol != plotcode::Protocol::Ebb {
                return Err(ConfigError::Value {
                    origin: origin.to_owned(),
                    key: format!("plotter[{i}].nickname"),
                    message: format!("finds an EiBotBoard by its name, and device {:?} is not one: give `port`", p.device),
                });
            }
            check_handshake(p, &device).map_err(|message| ConfigError::Value {
                origin: origin.to_owned(),
                key: format!("plotter[{i}].handshake"),
                message,
            })?;
            crate::pen_table::check(&p.pen, &device).map_err(|(k, key, message)| ConfigError::Value {
                origin: origin.to_owned(),
                key: format!("plotter[{i}].pen[{k}].{key}"),
                message,
            })?;
            p.handshake = Some(p.handshake.unwrap_or(device.handshake));
            p.baud = p.baud_set.unwrap_or(default_baud(device.protocol));
            if device.protocol == plotcode::Protocol::Gcode && p.baud == 9600 {
                // GRBL 0.8 ran at 9600; 1.1 runs at 115200 and answers
                // 9600 with garbage, which shows only as an offline plotter.
                tracing::warn!(
                    "{origin}: plotter[{i}].baud = 9600 for GRBL device {:?}: GRBL 1.1 runs at 115200 (leave `baud` out for it)",
                    p.device
                );
            }
            p.profile = Some(device);
        }
        if let Some(token) = config.web.as_mut().and_then(|w| w.token_file.as_mut()) {
            *token = dir.join(&*token);
        }
        Ok(config)
    }

    fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        let bad = |key: String, message: String| ConfigError::Value { origin: origin.to_owned(), key, message };
        if self.spool.as_os_str().is_empty() {
            return Err(bad(
                "spool".into(),
                "not set, and there is no default: none of STATE_DIRECTORY, XDG_STATE_HOME and HOME is set (a daemon started \
                 from cron or su, say); set `spool` to a directory of the daemon's user"
                    .into(),
            ));
        }
        if self.max_request_bytes < 1024 || self.max_request_bytes > MAX_MAX_REQUEST_BYTES {
            return Err(bad("max_request_bytes".into(), format!("{} is outside 1024..={MAX_MAX_REQUEST_BYTES}", self.max_request_bytes)));
        }
        if !(1..=MAX_KEEP_FINISHED).contains(&self.keep_finished) {
            return Err(bad("keep_finished".into(), format!("{} is outside 1..={MAX_KEEP_FINISHED}", self.keep_finished)));
        }
        if !(self.render_seconds.is_finite() && self.render_seconds >= 1.0 && self.render_seconds <= 86_400.0) {
            return Err(bad("render_seconds".into(), format!("{} is not a duration in [1, 86400] seconds", self.render_seconds)));
        }
        if !(64..=1 << 20).contains(&self.render_memory_mb) {
            return Err(bad("render_memory_mb".into(), format!("{} is outside 64..={}", self.render_memory_mb, 1 << 20)));
        }
        if self.max_face_tests == 0 {
            return Err(bad("max_face_tests".into(), "must be at least 1".into()));
        }
        for (key, v) in [("max_connections", self.max_connections), ("max_connections_per_uid", self.max_connections_per_uid)] {
            if !(1..=1_000_000).contains(&v) {
                return Err(bad(key.into(), format!("{v} is outside 1..=1000000")));
            }
        }
        if !(self.idle_timeout_s.is_finite() && self.idle_timeout_s > 0.0 && self.idle_timeout_s <= 86_400.0) {
            return Err(bad("idle_timeout_s".into(), format!("{} is not a duration in (0, 86400] seconds", self.idle_timeout_s)));
        }
        if self.plotters.len() > MAX_PLOTTERS {
            return Err(bad("plotter".into(), format!("at most {MAX_PLOTTERS} plotters")));
        }
        if let Some(web) = &self.web {
            if !web.listen.ip().is_loopback() && web.token_file.is_none() {
                return Err(bad(
                    "web.token_file".into(),
                    format!(
                        "not set, and `web.listen` = {} is not a loopback address: anyone on the network could drive the \
                         plotters; set `token_file` (made with a new token when missing), or listen on 127.0.0.1",
                        web.listen
                    ),
                ));
            }
        }
        for (i, p) in self.plotters.iter().enumerate() {
            let key = |k: &str| format!("plotter[{i}].{k}");
            if p.name.is_empty() || p.name.chars().any(|c| c.is_control() || c == '/') {
                return Err(bad(key("name"), format!("{:?} is not a usable name", p.name)));
            }
            if self.plotters[..i].iter().any(|q| q.name == p.name) {
                return Err(bad(key("name"), format!("{:?} is used by an earlier plotter", p.name)));
            }
            match (&p.nickname, p.port.as_os_str().is_empty()) {
                (Some(_), false) => {
                    return Err(bad(
                        key("nickname"),
                        "set with `port`: give `port`, or `nickname` to find the EiBotBoard that answers it, not both".into(),
                    ))
                }
                (None, true) => {
                    return Err(bad(key("port"), "is empty or missing (an EiBotBoard may be found by `nickname` instead)".into()))
                }
                (Some(n), true) => {
                    if !is_ebb_nickname(n) {
                        return Err(bad(key("nickname"), format!("{n:?} is not 1 to 16 printable ASCII characters without a comma")));
                    }
                    if let Some(q) = self.plotters[..i].iter().find(|q| q.nickname.as_ref() == Some(n)) {
                        return Err(bad(
                            key("nickname"),
                            format!("{n:?} is plotter {:?}'s nickname too: one board drives one plotter", q.name),
                        ));
                    }
                }
                (None, false) => {}
            }
            if let Some(baud) = p.baud_set.filter(|&b| !is_standard_rate(b)) {
                return Err(bad(key("baud"), format!("{baud} is not a standard rate")));
            }
            if let Some(q) = self.plotters[..i].iter().find(|q| q.port == p.port && p.nickname.is_none()) {
                return Err(bad(
                    key("port"),
                    format!("{} is plotter {:?}'s port too: one port drives one plotter", p.port.display(), q.name),
                ));
            }
            for (k, v) in [("reply_timeout_s", p.reply_timeout_s), ("motion_timeout_s", p.motion_timeout_s)] {
                if !(v.is_finite() && v > 0.0 && v <= 86_400.0) {
                    return Err(bad(key(k), format!("{v} is not a duration in (0, 86400] seconds")));
                }
            }
        }
        Ok(())
    }

    /// The job worker's budget.
    #[must_use]
    pub fn render_budget(&self) -> Budget {
        Budget { seconds: self.render_seconds, memory_mb: self.render_memory_mb, face_tests: self.max_face_tests }
    }

    /// The plotter called `name`; with `None`, the first one.
    #[must_use]
    pub fn plotter(&self, name: Option<&str>) -> Option<&PlotterConfig> {
        match name {
            Some(n) => self.plotters.iter().find(|p| p.name == n),
            None => self.plotters.first(),
        }
    }
}

/// Whether a `device` setting names a profile file rather than a built-in
/// profile: it has a path separator or ends in `.toml`.
#[must_use]
pub fn names_a_profile_file(spec: &str) -> bool {
    spec.contains('/') || spec.contains('\\') || spec.ends_with(".toml")
}

/// The device `spec` names: a built-in profile, or a profile file (relative to `dir`).
fn load_device(spec: &str, dir: &Path) -> Result<DeviceProfile, String> {
    if !names_a_profile_file(spec) {
        return DeviceProfile::builtin(spec).map_err(|e| e.to_string());
    }
    let path = dir.join(spec);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("cannot read profile {}: {e}", path.display()))?;
    let profile = plotcode::DeviceProfile::from_toml(&text).map_err(|e| format!("profile {}: {e}", path.display()))?;
    Ok(profile)
}

/// A handshake the config sets must stream the device's language.
fn check_handshake(p: &PlotterConfig, device: &DeviceProfile) -> Result<(), String> {
    match p.handshake {
        Some(h) if h.protocol() != device.protocol => {
            Err(format!("handshake \"{h}\" does not fit device {:?}, which speaks {}", p.device, device.protocol))
        }
        _ => Ok(()),
    }
}

impl PlotterConfig {
    /// Where the plotter is, as `status` shows it: the port, or the
    /// nickname that finds it (`nickname "left"`), since its port is not
    /// known until the board answers.
    #[must_use]
    pub fn port_label(&self) -> String {
        match &self.nickname {
            Some(n) if self.port.as_os_str().is_empty() => format!("nickname {n:?}"),
            _ => self.port.display().to_string(),
        }
    }

    /// The device this plotter is, as loaded with the config.
    ///
    /// # Errors
    /// Only for a config not made by [`Config::load`] or [`Config::from_toml`]:
    /// the built-in profile lookup's error.
    pub fn loaded_device(&self) -> Result<DeviceProfile, String> {
        match &self.profile {
            Some(d) => Ok(d.clone()),
            None => load_device(&self.device, Path::new("")),
        }
    }

    /// The flow control on the line: the `handshake` key, else the device
    /// profile's (the config's loading fills it in).
    #[must_use]
    pub fn handshake(&self) -> Handshake {
        match (self.handshake, &self.profile) {
            (Some(h), _) => h,
            (None, Some(device)) => device.handshake,
            // A config not made by `Config::load` or `from_toml`: the
            // built-in profile's, or what every HP-GL profile offers.
            (None, None) => self.loaded_device().map_or(Handshake::XonXoff, |d| d.handshake),
        }
    }

    /// [`Self::reply_timeout_s`] as a duration.
    #[must_use]
    pub fn reply_timeout(&self) -> Duration {
        Duration::from_secs_f64(self.reply_timeout_s)
    }
    /// [`Self::motion_timeout_s`] as a duration.
    #[must_use]
    pub fn motion_timeout(&self) -> Duration {
        Duration::from_secs_f64(self.motion_timeout_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spool_has_no_default_under_tmp() {
        // Issue #42: a daemon run as root with HOME unset fell back to
        // `/tmp/.local/state/plotd/spool`, which another user can make first.
        let os = |s: &str| Some(OsString::from(s));
        assert_eq!(spool_dir_from(None, None, None), None);
        assert_eq!(spool_dir_from(os(""), os(""), os("")), None);
        assert_eq!(spool_dir_from(None, None, os("/home/a")), Some("/home/a/.local/state/plotd/spool".into()));
        assert_eq!(spool_dir_from(None, os("/s"), os("/home/a")), Some("/s/plotd/spool".into()));
        assert_eq!(spool_dir_from(os("/var/lib/plotd"), os("/s"), None), Some("/var/lib/plotd/spool".into()));
        let e = Config::from_toml("spool = \"\"", "t").unwrap_err().to_string();
        assert!(e.contains("key `spool`") && e.contains("HOME"), "{e}");
    }

    const GOOD: &str = r#"
        socket = "/tmp/x.sock"
        spool = "/tmp/spool"
        [[plotter]]
        name = "hp"
        port = "/dev/ttyUSB0"
        baud = 9600
        device = "hp7475a"
        handshake = "escb"
        [[plotter]]
        name = "cnc"
        port = "/dev/ttyACM0"
        baud = 115200
        device = "grbl-servo"
        handshake = "grbl"
        auto_resume = true
    "#;

    fn err(text: &str) -> String {
        Config::from_toml(text, "t.toml").unwrap_err().to_string()
    }

    /// A pen table per plotter: read into the plotter's config, its
    /// device's part for the emitters; a bad entry named by key.
    #[test]
    fn a_pen_table_per_plotter() {
        let table = "        [[plotter.pen]]\n        number = 2\n        name = \"fine red\"\n        colour = \"red\"\n        width = 0.3\n        speed = 15.0\n        force = 3\n        [[plotter]]\n        name = \"cnc\"";
        let c = Config::from_toml(&GOOD.replacen("        [[plotter]]\n        name = \"cnc\"", table, 1), "t.toml").unwrap();
        let pen = &c.plotters[0].pen[0];
        assert_eq!((pen.number, pen.colour.as_deref(), pen.width, pen.speed, pen.force), (2, Some("red"), Some(0.3), Some(15.0), Some(3)));
        assert!(c.plotters[1].pen.is_empty());
        let e = err(&GOOD.replacen("        [[plotter]]\n        name = \"cnc\"", &table.replace("number = 2", "number = 7"), 1));
        assert!(e.contains("plotter[0].pen[0].number") && e.contains("pens 1 to 6"), "{e}");
        let e = err(&GOOD.replacen("        [[plotter]]\n        name = \"cnc\"", &table.replace("width", "widht"), 1));
        assert!(e.contains("widht"), "{e}");
    }

    /// Issue 36: two plotters on one port were accepted (each took the
    /// other's answers); a GRBL plotter without `baud` ran at 9600.
    #[test]
    fn one_port_one_plotter_and_the_rate_from_the_device() {
        let e = err(&GOOD.replace("/dev/ttyACM0", "/dev/ttyUSB0"));
        assert!(e.contains("plotter[1].port") && e.contains("\"hp\"'s port"), "{e}");
        let c = Config::from_toml(&GOOD.replace("baud = 9600\n", "").replace("baud = 115200\n", ""), "t.toml").unwrap();
        assert_eq!((c.plotters[0].baud, c.plotters[1].baud), (9600, 115_200));
    }

    /// Issue 37: `nickname` binds a plotter to the EiBotBoard whose `QT`
    /// answers it, in place of `port`; both, neither, a name the board
    /// cannot hold, two plotters with one name, or a nickname for a device
    /// that is no EBB are refused naming the keys.
    #[test]
    fn an_ebb_plotter_may_be_named_by_its_nickname_instead_of_its_port() {
        let axi = |table: &str| format!("spool = \"/tmp/spool\"\n[[plotter]]\nname = \"axi\"\ndevice = \"axidraw\"\n{table}");
        let c = Config::from_toml(&axi("nickname = \"left\""), "t").unwrap();
        assert_eq!((c.plotters[0].nickname.as_deref(), c.plotters[0].port.as_os_str().is_empty()), (Some("left"), true));
        // `status` names how it is found, not an empty port.
        assert_eq!(c.plotters[0].port_label(), "nickname \"left\"");
        let e = err(&axi("nickname = \"left\"\nport = \"/dev/ttyACM0\""));
        assert!(e.contains("plotter[0].nickname") && e.contains("`port`") && e.contains("`nickname`"), "{e}");
        let e = err(&axi(""));
        assert!(e.contains("plotter[0].port") && e.contains("nickname"), "{e}");
        for bad in ["", "a,b", "seventeen-letters", "tab\\there"] {
            let e = err(&axi(&format!("nickname = \"{bad}\"")));
            assert!(e.contains("plotter[0].nickname") && e.contains("1 to 16"), "{bad:?}: {e}");
        }
        let two = format!("{}\n[[plotter]]\nname = \"b\"\ndevice = \"axidraw\"\nnickname = \"left\"", axi("nickname = \"left\""));
        let e = err(&two);
        assert!(e.contains("plotter[1].nickname") && e.contains("\"axi\""), "{e}");
        let e = err(&axi("nickname = \"left\"").replace("axidraw", "hp7475a"));
        assert!(e.contains("plotter[0].nickname") && e.contains("EiBotBoard"), "{e}");
    }

    #[test]
    fn parses_the_example() {
        let c = Config::from_toml(GOOD, "t.toml").unwrap();
        assert_eq!(c.plotters.len(), 2);
        assert_eq!(c.plotters[1].handshake(), Handshake::Grbl);
        assert!(c.plotters[1].auto_resume);
        assert_eq!(c.plotters[0].pen_change, PenChangePolicy::Auto);
        assert_eq!(c.plotter(None).unwrap().name, "hp");
        assert_eq!(c.plotter(Some("cnc")).unwrap().baud, 115200);
        assert!(c.plotter(Some("nope")).is_none());
    }

    /// One handshake vocabulary: a plotter without `handshake` takes its
    /// profile's; the config may override it, in the profile's spelling or
    /// the config's older `xonxoff`.
    #[test]
    fn the_handshake_is_the_profiles_unless_the_config_sets_one() {
        let without = GOOD.replace("handshake = \"escb\"\n", "").replace("handshake = \"grbl\"\n", "");
        let c = Config::from_toml(&without, "t.toml").unwrap();
        assert_eq!((c.plotters[0].handshake(), c.plotters[1].handshake()), (Handshake::XonXoff, Handshake::Grbl));
        for (written, handshake) in [("xon-xoff", Handshake::XonXoff), ("xonxoff", Handshake::XonXoff), ("hardware", Handshake::Hardware)] {
            let c = Config::from_toml(&GOOD.replace("\"escb\"", &format!("\"{written}\"")), "t.toml").unwrap();
            assert_eq!(c.plotters[0].handshake(), handshake, "{written}");
        }
    }

    #[test]
    fn shipped_example_parses() {
        let text = include_str!("../../../config/plotd.toml");
        Config::from_toml(text, "config/plotd.toml").unwrap();
    }

    #[test]
    fn unknown_key_is_named() {
        let e = err(&GOOD.replace("baud = 9600", "baud = 9600\nspeed = 3"));
        assert!(e.contains("speed"), "{e}");
        let e = err("sockett = \"/x\"");
        assert!(e.contains("sockett"), "{e}");
    }

    #[test]
    fn bad_values_are_named() {
        let e = err(&GOOD.replace("baud = 9600", "baud = 9601"));
        assert!(e.contains("plotter[0].baud"), "{e}");
        // A value of the wrong kind: the parser quotes the line, key included.
        let e = err(&GOOD.replace("handshake = \"escb\"", "handshake = \"smoke\""));
        assert!(e.contains("line 9") && e.contains("handshake = \"smoke\"") && e.contains("unknown variant"), "{e}");
        let e = err(&GOOD.replace("baud = 9600", "baud = \"fast\""));
        assert!(e.contains("line 7") && e.contains("baud = \"fast\""), "{e}");
        let e = err(&GOOD.replace("name = \"cnc\"", "name = \"hp\""));
        assert!(e.contains("plotter[1].name"), "{e}");
        let e = err(&GOOD.replace("handshake = \"grbl\"", "handshake = \"escb\""));
        assert!(e.contains("plotter[1].handshake"), "{e}");
        // In the config's words, not the code's type names.
        assert!(e.contains("handshake \"escb\" does not fit device \"grbl-servo\", which speaks G-code"), "{e}");
        assert!(!e.contains("Escb") && !e.contains("Gcode"), "{e}");
        let e = err(&GOOD.replace("device = \"hp7475a\"", "device = \"toaster\""));
        assert!(e.contains("plotter[0].device"), "{e}");
        // An AxiDraw is driven through the EBB handshake; HP-GL's is refused.
        let axidraw = GOOD.replace("device = \"hp7475a\"", "device = \"axidraw\"");
        Config::from_toml(&axidraw.replace("handshake = \"escb\"", "handshake = \"ebb\""), "t").expect("an AxiDraw plotter");
        let e = err(&axidraw);
        assert!(e.contains("does not fit device \"axidraw\""), "{e}");
        let e = err(&format!("max_request_bytes = 1\n{GOOD}"));
        assert!(e.contains("max_request_bytes"), "{e}");
        let e = err(&format!("keep_finished = 0\n{GOOD}"));
        assert!(e.contains("keep_finished") && e.contains("outside 1..="), "{e}");
        for (key, v) in [
            ("render_seconds", "0.5"),
            ("render_memory_mb", "1"),
            ("max_face_tests", "0"),
            ("max_connections", "0"),
            ("max_connections_per_uid", "0"),
            ("idle_timeout_s", "-1.0"),
        ] {
            let e = err(&format!("{key} = {v}\n{GOOD}"));
            assert!(e.contains(key), "{e}");
        }
    }

    #[test]
    fn device_may_be_a_profile_file_beside_the_config() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("devices")).unwrap();
        let builtin = include_str!("../../../config/devices/grbl-z.toml");
        std::fs::write(dir.path().join("devices/mine.toml"), builtin.replace("name = \"grbl-z\"", "name = \"mine\"")).unwrap();
        let cfg = dir.path().join("plotd.toml");
        let text = GOOD.replace("device = \"grbl-servo\"", "device = \"devices/mine.toml\"");
        std::fs::write(&cfg, &text).unwrap();
        let c = Config::load(&cfg).unwrap();
        let d = c.plotters[1].loaded_device().unwrap();
        assert_eq!((d.name.as_str(), d.protocol), ("mine", plotcode::Protocol::Gcode));
        assert_eq!(c.plotters[0].loaded_device().unwrap().name, "hp7475a");

        // Missing file, bad profile, wrong language: each names the key and the file.
        std::fs::write(&cfg, text.replace("mine.toml", "gone.toml")).unwrap();
        let e = Config::load(&cfg).unwrap_err().to_string();
        assert!(e.contains("plotter[1].device") && e.contains("gone.toml"), "{e}");
        std::fs::write(dir.path().join("devices/bad.toml"), "name = \"x\"\nspeed = 3\n").unwrap();
        std::fs::write(&cfg, text.replace("mine.toml", "bad.toml")).unwrap();
        let e = Config::load(&cfg).unwrap_err().to_string();
        assert!(e.contains("plotter[1].device") && e.contains("bad.toml"), "{e}");
        std::fs::write(&cfg, text.replace("handshake = \"grbl\"", "handshake = \"escb\"")).unwrap();
        let e = Config::load(&cfg).unwrap_err().to_string();
        assert!(e.contains("plotter[1].handshake"), "{e}");
    }

    #[test]
    fn the_web_page_off_a_loopback_address_needs_a_token() {
        let c = Config::from_toml("[web]", "t.toml").unwrap();
        assert_eq!(c.web.unwrap().listen, "127.0.0.1:8765".parse().unwrap());
        assert!(Config::from_toml("", "t.toml").unwrap().web.is_none());
        let e = err("[web]\nlisten = \"0.0.0.0:8765\"");
        assert!(e.contains("t.toml: key `web.token_file`: not set, and `web.listen` = 0.0.0.0:8765 is not a loopback"), "{e}");
        let e = err("[web]\nlisten = \"[::]:80\"");
        assert!(e.contains("web.token_file"), "{e}");
        let c = Config::from_toml("[web]\nlisten = \"0.0.0.0:8765\"\ntoken_file = \"web.token\"", "t.toml").unwrap();
        assert_eq!(c.web.unwrap().token_file, Some(PathBuf::from("web.token")));
        let c = Config::from_toml("[web]\nlisten = \"[::1]:9000\"", "t.toml").unwrap();
        assert!(c.web.unwrap().token_file.is_none());
        let e = err("[web]\nlisten = \"localhost\"");
        assert!(e.contains("listen"), "{e}");
        let e = err("[web]\nport = 1");
        assert!(e.contains("port"), "{e}");
    }

    #[test]
    fn empty_config_uses_defaults() {
        let c = Config::from_toml("", "t").unwrap();
        assert!(c.plotters.is_empty());
        assert_eq!(c.max_request_bytes, DEFAULT_MAX_REQUEST_BYTES);
        assert_eq!(c.keep_finished, DEFAULT_KEEP_FINISHED);
    }
}
