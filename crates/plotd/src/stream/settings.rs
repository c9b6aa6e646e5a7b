//! How a streamer is tuned ([`StreamSettings`]) and what it measured
//! ([`StreamStats`]).

use plotcode::Handshake;
use std::time::Duration;

/// Tuning of the handshakes.
#[derive(Clone, Debug)]
pub struct StreamSettings {
    /// Flow control.
    pub handshake: Handshake,
    /// Longest wait for an immediate answer (HP-GL's device-control
    /// queries, GRBL's status report and build info).
    pub reply_timeout: Duration,
    /// Longest wait for an answer that waits on motion (OA, `ok`).
    pub motion_timeout: Duration,
    /// Bytes of free space left unused under ESC.B, against miscounting.
    pub escb_margin: usize,
    /// Pause between polls when the device buffer is full.
    pub poll_interval: Duration,
    /// HP-GL: silence while the device holds work before it is asked for
    /// its free space (a power cycle or dead link shows within seconds).
    pub probe_after: Duration,
    /// GRBL: how long the board may report `Idle` with lines in flight and
    /// nothing answered before the run counts it stalled.
    pub stall_after: Duration,
    /// GRBL receive buffer size when the build info does not say.
    pub grbl_rx_default: usize,
    /// HP-GL: most bytes written and not yet confirmed executed. Bytes the
    /// device has run but not yet confirmed are drawn again after a power cut;
    /// this bounds them while covering the answer's round trip at the line rate.
    pub hpgl_window: usize,
}

impl StreamSettings {
    /// Defaults for `handshake`.
    #[must_use]
    pub fn new(handshake: Handshake) -> Self {
        StreamSettings {
            handshake,
            reply_timeout: Duration::from_secs(2),
            motion_timeout: Duration::from_secs(120),
            escb_margin: 16,
            poll_interval: Duration::from_millis(20),
            probe_after: Duration::from_secs(1),
            stall_after: Duration::from_secs(5),
            grbl_rx_default: 128,
            hpgl_window: 256,
        }
    }
}

/// What a streamer measured, for benchmarks and status.
#[derive(Clone, Debug, Default)]
pub struct StreamStats {
    /// Job bytes written (queries and HP-GL markers excluded).
    pub bytes: u64,
    /// Time spent in runs.
    pub busy: Duration,
    /// Device buffer size learnt from the device.
    pub buffer_size: Option<usize>,
    /// GRBL: integral of bytes in the receive buffer over time (byte-seconds).
    pub fill_integral: f64,
    /// GRBL: time over which [`Self::fill_integral`] was taken.
    pub fill_time: f64,
}

impl StreamStats {
    /// GRBL: the receive buffer's average fill, 0..=1.
    #[must_use]
    pub fn average_fill(&self) -> Option<f64> {
        let size = self.buffer_size? as f64;
        (self.fill_time > 0.0).then(|| self.fill_integral / self.fill_time / size)
    }
}
