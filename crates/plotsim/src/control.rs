//! The control socket's commands: one per line, answered `ok` or `error: ...`.
//!
//! `unplug MS`, `stall MS`, `power-cycle`, `reset`, `park` (GRBL), `lever
//! up`, `lever down`, `garbage`, `error [N]`, `alarm N` (GRBL),
//! `power-loss [MS]`, `power-restore`, `button` (EBB), `save`, and `status`
//! (answers `ok` followed by `key=value` pairs, for scripts).

use crate::simulator::{Simulator, MAX_FAULT};
use std::path::PathBuf;
use std::time::Duration;

/// A parsed control command.
#[derive(Clone, Debug, PartialEq)]
pub enum ControlCommand {
    /// Pull the adapter for this long.
    Unplug(Duration),
    /// Stop draining for this long.
    Stall(Duration),
    /// Power off and on.
    PowerCycle,
    /// The device's reset ([`Simulator::reset`]).
    Reset,
    /// GRBL: the carriage moved by hand to the paper's origin ([`Simulator::park`]).
    Park,
    /// Paper lever up (`true`) or down.
    Lever(bool),
    /// Next reply is noise.
    Garbage,
    /// GRBL: the lines in the receive buffer are lost unanswered (a stall).
    LoseInput,
    /// Next instruction fails (with this device error number, if given).
    Error(Option<u32>),
    /// GRBL: raise this alarm now.
    Alarm(u32),
    /// EBB: the motor supply fails (for this long, or until `power-restore`).
    PowerLoss(Option<Duration>),
    /// EBB: the motor supply comes back.
    PowerRestore,
    /// EBB: the PRG button is pressed.
    Button,
    /// Write the record and pictures now.
    Save,
    /// Report the simulator's state.
    Status,
}

/// A control line that is not a command.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ControlError(pub String);

fn millis(word: Option<&str>, cmd: &str) -> Result<Duration, ControlError> {
    let w = word.ok_or_else(|| ControlError(format!("{cmd} needs a duration in milliseconds")))?;
    let ms: u64 = w.parse().map_err(|_| ControlError(format!("{cmd}: '{w}' is not a whole number of milliseconds")))?;
    let d = Duration::from_millis(ms);
    if d > MAX_FAULT {
        return Err(ControlError(format!("{cmd}: {ms} ms is longer than {} ms", MAX_FAULT.as_millis())));
    }
    Ok(d)
}

impl ControlCommand {
    /// Parses one line (surrounding whitespace ignored, case-insensitive).
    ///
    /// # Errors
    /// A [`ControlError`] saying what is wrong with the line.
    pub fn parse(line: &str) -> Result<ControlCommand, ControlError> {
        let lower = line.trim().to_ascii_lowercase();
        let mut words = lower.split_whitespace();
        let cmd = words.next().ok_or_else(|| ControlError("empty command".into()))?;
        let arg = words.next();
        let parsed = match cmd {
            "unplug" => ControlCommand::Unplug(millis(arg, cmd)?),
            "stall" => ControlCommand::Stall(millis(arg, cmd)?),
            "power-cycle" => ControlCommand::PowerCycle,
            "reset" => ControlCommand::Reset,
            "park" => ControlCommand::Park,
            "lever" => match arg {
                Some("up") => ControlCommand::Lever(true),
                Some("down") => ControlCommand::Lever(false),
                _ => return Err(ControlError("lever needs 'up' or 'down'".into())),
            },
            "garbage" => ControlCommand::Garbage,
            "lose-input" => ControlCommand::LoseInput,
            "error" => match arg {
                None => ControlCommand::Error(None),
                Some(n) => {
                    ControlCommand::Error(Some(n.parse().map_err(|_| ControlError(format!("error: '{n}' is not an error number")))?))
                }
            },
            "alarm" => {
                let n = arg.ok_or_else(|| ControlError("alarm needs an alarm number".into()))?;
                ControlCommand::Alarm(n.parse().map_err(|_| ControlError(format!("alarm: '{n}' is not an alarm number")))?)
            }
            "power-loss" => ControlCommand::PowerLoss(arg.map(|a| millis(Some(a), cmd)).transpose()?),
            "power-restore" => ControlCommand::PowerRestore,
            "button" => ControlCommand::Button,
            "save" => ControlCommand::Save,
            "status" => ControlCommand::Status,
            other => return Err(ControlError(format!("unknown command '{other}'"))),
        };
        let takes_arg = matches!(cmd, "unplug" | "stall" | "lever" | "error" | "alarm" | "power-loss");
        let extra = if takes_arg { words.next() } else { arg };
        if let Some(x) = extra {
            return Err(ControlError(format!("{cmd}: unexpected '{x}'")));
        }
        Ok(parsed)
    }
}

/// Where `save` writes.
#[derive(Clone, Debug, Default)]
pub struct SaveTargets {
    /// JSON record.
    pub record: Option<PathBuf>,
    /// SVG picture.
    pub svg: Option<PathBuf>,
    /// PNG picture.
    pub png: Option<PathBuf>,
}

/// Carries out one control line; returns the answer line (without newline).
pub fn answer(sim: &Simulator, line: &str, save: &SaveTargets) -> String {
    let result = ControlCommand::parse(line).map_err(|e| e.to_string()).and_then(|cmd| {
        match cmd {
            ControlCommand::Unplug(d) => sim.unplug(d).map_err(|e| e.to_string())?,
            ControlCommand::Stall(d) => sim.stall(d).map_err(|e| e.to_string())?,
            ControlCommand::PowerCycle => sim.power_cycle(),
            ControlCommand::Reset => sim.reset(),
            ControlCommand::Park => sim.park().map_err(|e| e.to_string())?,
            ControlCommand::Lever(up) => sim.lever(up).map_err(|e| e.to_string())?,
            ControlCommand::Garbage => sim.garbage(),
            ControlCommand::LoseInput => sim.lose_input().map_err(|e| e.to_string())?,
            ControlCommand::Error(code) => sim.fail_next(code),
            ControlCommand::Alarm(code) => sim.alarm(code).map_err(|e| e.to_string())?,
            ControlCommand::PowerLoss(d) => sim.power_loss(d).map_err(|e| e.to_string())?,
            ControlCommand::PowerRestore => sim.power_restore().map_err(|e| e.to_string())?,
            ControlCommand::Button => sim.button().map_err(|e| e.to_string())?,
            ControlCommand::Save => {
                if save.record.is_none() && save.svg.is_none() && save.png.is_none() {
                    return Err("nothing to save: start plotsim with --record, --svg or --png".into());
                }
                sim.save(save.record.as_deref(), save.svg.as_deref(), save.png.as_deref()).map_err(|e| e.to_string())?;
            }
            ControlCommand::Status => {
                let s = sim.status();
                return Ok(format!(
                    "ok state={} idle={} received={} buffered={} overruns={} errors={} strokes={} pen={} pty={}",
                    s.device.state.replace(' ', "-"),
                    s.idle,
                    s.bytes_received,
                    s.device.buffer_used,
                    s.overruns,
                    s.errors,
                    sim.record().strokes.len(),
                    if s.device.pen_down { "down" } else { "up" },
                    s.slave_path.map_or("-".to_string(), |p| p.display().to_string()),
                ));
            }
        }
        Ok("ok".to_string())
    });
    result.unwrap_or_else(|e| format!("error: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_command() {
        use ControlCommand::*;
        let cases = [
            ("unplug 250", Unplug(Duration::from_millis(250))),
            ("  STALL 10 ", Stall(Duration::from_millis(10))),
            ("power-cycle", PowerCycle),
            ("reset", Reset),
            ("park", Park),
            ("lever up", Lever(true)),
            ("lever down", Lever(false)),
            ("garbage", Garbage),
            ("lose-input", LoseInput),
            ("error", Error(None)),
            ("error 3", Error(Some(3))),
            ("power-loss", PowerLoss(None)),
            ("power-loss 3000", PowerLoss(Some(Duration::from_millis(3000)))),
            ("power-restore", PowerRestore),
            ("button", Button),
            ("save", Save),
            ("status", Status),
        ];
        for (line, want) in cases {
            assert_eq!(ControlCommand::parse(line), Ok(want), "{line}");
        }
    }

    #[test]
    fn rejects_bad_lines_with_a_reason() {
        for (line, why) in [
            ("", "empty"),
            ("unplug", "needs a duration"),
            ("unplug -5", "not a whole number"),
            ("stall 99999999999", "longer than"),
            ("lever sideways", "'up' or 'down'"),
            ("save now", "unexpected"),
            ("reset 5", "unexpected"),
            ("explode", "unknown command"),
            ("error x", "not an error number"),
            ("power-loss soon", "not a whole number"),
            ("button twice", "unexpected"),
        ] {
            let e = ControlCommand::parse(line).unwrap_err();
            assert!(e.0.contains(why), "{line}: {e}");
        }
    }
}
