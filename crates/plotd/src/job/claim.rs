//! Jobs for a class of plotters: a submit may name `any`, or a device (a
//! profile name, the `device` of a `[[plotter]]`), instead of a plotter.
//! The daemon finds at submit which of the class's plotters can draw the
//! job (their device, paper and pens: the submit's checks, run for each);
//! the record keeps the class and those plotters
//! ([`crate::spool::PlotterClass`]) until one takes it, so a restart
//! finds it waiting for any of them still.
//!
//! The first of them to be idle takes it, in id order with its own queue:
//! idle is online, running nothing, nothing of its own waiting (a paused
//! job holds its plotter, as the sheet under it), and its sheet fresh, or
//! the job drawn on the same sheet (a plotter that waits for a fresh sheet
//! is not idle: another that is takes the job). A job for a class that a
//! person paused before any plotter took it is taken by none until
//! resumed. Once taken it is that plotter's job for good: its record names
//! the plotter, shown in `status`, `jobs` and `watch`.

use super::error::SubmitError;
use super::life::JobLife;
use super::station::Head;
use crate::config::PlotterConfig;
use crate::spool::{JobId, JobRecord, JobState, PlotterClass, Sheet};

/// The class that names every plotter.
pub const ANY: &str = "any";

/// Where a submit goes, by the name it gave.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// One plotter: named, or the first configured.
    Plotter(Box<PlotterConfig>),
    /// A class: the plotters it names, in config order; which of them can
    /// draw the job is for the submit's checks to say.
    Class {
        /// `any`, or a device profile's name.
        name: String,
        /// Its plotters.
        plotters: Vec<PlotterConfig>,
    },
}

impl JobLife {
    /// Where a new job goes: plotter `name`, the class `name` names (`any`,
    /// or the device of one or more plotters), or the first plotter. A
    /// plotter's name comes first: a plotter called `any` is that plotter.
    ///
    /// # Errors
    /// [`SubmitError`] while shutting down, or for a name that is neither a
    /// plotter, nor a configured device, nor `any`, listing those.
    pub fn admit(&self, name: Option<&str>) -> Result<Target, SubmitError> {
        if self.shutting_down {
            return Err(SubmitError::ShuttingDown);
        }
        let Some(name) = name else {
            return self.plotters().next().map(|p| Target::Plotter(Box::new(p.clone()))).ok_or(SubmitError::NoPlotter);
        };
        if let Some(p) = self.plotter(name) {
            return Ok(Target::Plotter(Box::new(p.clone())));
        }
        let plotters: Vec<PlotterConfig> = self.plotters().filter(|p| name == ANY || p.device == name).cloned().collect();
        if plotters.is_empty() {
            let mut devices: Vec<String> = self.plotters().map(|p| p.device.clone()).collect();
            devices.sort();
            devices.dedup();
            return Err(SubmitError::NoSuchPlotter {
                name: name.to_owned(),
                configured: self.plotters().map(|p| p.name.clone()).collect(),
                devices,
            });
        }
        Ok(Target::Class { name: name.to_owned(), plotters })
    }

    /// The oldest job plotter `name` (station `i`) may take: its own, or
    /// one for a class that fits it while it is idle (see the module doc).
    pub(super) fn claimable(&self, i: usize, own: Head) -> Head {
        if own.is_some_and(|(_, cause)| cause.is_some()) {
            return own;
        }
        let station = &self.stations[i];
        let fresh = station.state.sheet == Sheet::Fresh;
        let name = station.name();
        let fits = |r: &JobRecord| {
            r.unclaimed().is_some_and(|fits| fits.iter().any(|p| p == name)) && r.state == JobState::Queued && (fresh || r.same_sheet)
        };
        let class = self.jobs.values().map(|e| &e.record).find(|r| fits(r)).map(|r| r.id);
        match (own, class) {
            (Some((own_id, _)), Some(id)) if id < own_id => Some((id, None)),
            (None, Some(id)) => Some((id, None)),
            _ => own,
        }
    }

    /// Station `i` takes job `id`: a job for a class becomes its own.
    pub(super) fn claim(record: &mut JobRecord, plotter: &str) {
        if record.unclaimed().is_some() {
            record.plotter = plotter.to_owned();
            if let Some(class) = &mut record.class {
                class.fits.clear();
            }
        }
    }

    /// The plotters to wake for job `id`: its own, or while no plotter has
    /// taken it, every one its class fits.
    pub(super) fn plotters_of(&self, id: JobId) -> Vec<String> {
        match self.jobs.get(&id).map(|e| &e.record) {
            Some(r) => r.unclaimed().map_or_else(|| vec![r.plotter.clone()], <[String]>::to_vec),
            None => Vec::new(),
        }
    }
}

/// A class's record for a job the plotters `fits` can draw.
#[must_use]
pub fn class(name: &str, fits: &[PlotterConfig]) -> PlotterClass {
    PlotterClass { name: name.to_owned(), fits: fits.iter().map(|p| p.name.clone()).collect() }
}
