//! The online loop's real-time contract: when each frame's decision was due, when it was
//! made, and whether a trial kept the pace of its cameras (docs/online.md, "The deadline").
//!
//! A frame is due to arrive one frame period after the one before it (times the frames
//! the sensor's counter says were lost in between), or when it did arrive if that was
//! earlier; its decision is due `due_periods` periods after that. Counting from when the
//! frame should have come makes a link that holds frames back as late as a loop that is
//! slow: a burst of frames after a stall arrives "on time" by the host's clock, but the
//! slip they show is as old as the stall. A frame decided more than `limit_periods`
//! after it was due to arrive breaches the contract at once; so does a trial with more
//! than `max_late_share` of its frames late.
//!
//! The times are the rig's clock (the devices' [`tmo_hal::Clock`]): on a wall clock (the
//! real rig, the served simulator) they include the computer's work, on the lock-step
//! simulator they do not (simulated time waits for the computer), so a lock-step trial
//! never breaches and its outcomes do not depend on the machine. The work each frame cost
//! on this machine is measured beside them, so a lock-step trial can still say whether this
//! machine would have kept the pace.

use std::time::Instant;

use serde::{Deserialize, Serialize};
use tmo_hal::PinFrame;

/// The contract's terms, in frame periods (`[deadline]` in a protocol).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeadlineSpec {
    /// A frame's decision is due this many frame periods after the frame was due to arrive:
    /// one, so the loop finishes each frame before the next one comes.
    pub due_periods: f64,
    /// A frame decided later than this many periods after it was due to arrive faults the
    /// trial at once: two, the point at which the detector's NFr runs span frames it saw
    /// together rather than in turn.
    pub limit_periods: f64,
    /// A trial with more than this share of its frames late (after `due_periods`) faults at
    /// its end: 1 %, about 18 of a 10 s hand release's 1,800 frames, enough for the odd
    /// scheduling hiccup and too few for a loop that is behind.
    pub max_late_share: f64,
}

impl Default for DeadlineSpec {
    fn default() -> Self {
        Self {
            due_periods: 1.0,
            limit_periods: 2.0,
            max_late_share: 0.01,
        }
    }
}

impl DeadlineSpec {
    /// The field that is wrong and why.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let range = |field: &'static str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err((
                    field,
                    format!(
                        "expected a value in {lo}..={hi}, got {}",
                        crate::quote::number(v)
                    ),
                ))
            }
        };
        range("due_periods", self.due_periods, 0.1, 100.0)?;
        range("limit_periods", self.limit_periods, 0.1, 1000.0)?;
        range("max_late_share", self.max_late_share, 0.0, 1.0)?;
        if self.limit_periods < self.due_periods {
            return Err((
                "limit_periods",
                format!(
                    "expected at least due_periods ({}), got {}",
                    crate::quote::number(self.due_periods),
                    crate::quote::number(self.limit_periods)
                ),
            ));
        }
        Ok(())
    }
}

/// The contract for one rig: its terms and its cameras' frame period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deadline {
    pub spec: DeadlineSpec,
    pub period_s: f64,
}

impl Deadline {
    pub fn at_rate(spec: DeadlineSpec, frame_rate_hz: f64) -> Self {
        Self {
            spec,
            period_s: 1.0 / frame_rate_hz,
        }
    }

    /// How long after it was due to arrive a frame's decision is due, s.
    pub fn due_s(&self) -> f64 {
        self.spec.due_periods * self.period_s
    }

    /// How long after it was due to arrive a frame's decision breaches the contract, s.
    pub fn limit_s(&self) -> f64 {
        self.spec.limit_periods * self.period_s
    }
}

/// One frame's timing, as the trial log's `/timing` channel records it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameTiming {
    pub sensor: u8,
    pub seq: u64,
    /// When the frame reached the host (the simulator: when it was taken), rig clock, s.
    pub arrived_s: f64,
    /// When its decision was due, rig clock, s.
    pub due_s: f64,
    /// When the loop had acted on it (sent a command, or decided not to), rig clock, s.
    pub decided_s: f64,
    /// `decided_s - due_s`, ms: positive when late, negative the slack left.
    pub lateness_ms: f64,
    /// This machine's time from the poll that brought the frame to its decision, ms (the
    /// tick's other frames and commands included): on a wall clock part of the lateness,
    /// on the lock-step simulator what it would have added.
    pub work_ms: f64,
    /// This machine's time for the frame's classification alone, ms.
    pub classify_ms: f64,
}

impl FrameTiming {
    pub fn late(&self) -> bool {
        self.lateness_ms > 0.0
    }

    /// To the microsecond, as the log keeps it (far below a frame period, and the log
    /// stays small: a message per frame).
    pub fn to_microsecond(self) -> Self {
        let us = |s: f64| (s * 1e6).round() / 1e6;
        let ms = |m: f64| (m * 1e3).round() / 1e3;
        Self {
            arrived_s: us(self.arrived_s),
            due_s: us(self.due_s),
            decided_s: us(self.decided_s),
            lateness_ms: ms(self.lateness_ms),
            work_ms: ms(self.work_ms),
            classify_ms: ms(self.classify_ms),
            ..self
        }
    }
}

/// Why a trial broke the contract.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "breach", rename_all = "snake_case")]
pub enum DeadlineBreach {
    /// One frame decided after the limit.
    Frame {
        sensor: u8,
        seq: u64,
        /// From when it was due to arrive to its decision, ms.
        latency_ms: f64,
        limit_ms: f64,
    },
    /// Too many frames late.
    Share {
        late: u64,
        frames: u64,
        max_late_share: f64,
    },
}

impl std::fmt::Display for DeadlineBreach {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DeadlineBreach::Frame {
                sensor,
                seq,
                latency_ms,
                limit_ms,
            } => write!(
                f,
                "sensor {sensor}'s frame {seq} was decided {latency_ms:.1} ms after it was due to arrive (limit {limit_ms:.1} ms)"
            ),
            DeadlineBreach::Share {
                late,
                frames,
                max_late_share,
            } => write!(
                f,
                "{late} of {frames} frames were late (at most {:.1} % may be)",
                100.0 * max_late_share
            ),
        }
    }
}

/// A frame classified this tick, waiting for the loop's decision.
#[derive(Debug, Clone, Copy)]
struct Pending {
    sensor: u8,
    seq: u64,
    arrived_s: f64,
    due_s: f64,
    expected_s: f64,
    classify_ms: f64,
}

/// One trial's frames against the contract.
#[derive(Debug, Clone)]
pub struct DeadlineWatch {
    deadline: Deadline,
    /// Each sensor's last frame: (when it arrived, its sequence number).
    last: Vec<Option<(f64, u64)>>,
    pending: Vec<Pending>,
    /// When the tick whose frames are pending polled them, on this machine's clock.
    polled: Option<Instant>,
    /// Frames before this time (on the rig clock) came before the trial began.
    t0: f64,
    frames: u64,
    late: u64,
}

impl DeadlineWatch {
    pub fn new(deadline: Deadline, sensors: usize, t0: f64) -> Self {
        Self {
            deadline,
            last: vec![None; sensors],
            pending: Vec::new(),
            polled: None,
            t0,
            frames: 0,
            late: 0,
        }
    }

    /// A tick has just polled its frames.
    pub fn polled(&mut self, at: Instant) {
        self.polled = Some(at);
    }

    /// `frame` has been classified, taking `classify_ms`. Frames taken before the trial
    /// began wait from before the loop ran and are not held to it.
    pub fn classified(&mut self, frame: &PinFrame, classify_ms: f64) {
        let k = usize::from(frame.sensor);
        let Some(slot) = self.last.get_mut(k) else {
            return;
        };
        let expected = match *slot {
            Some((arrived, seq)) if frame.seq > seq => {
                arrived + (frame.seq - seq) as f64 * self.deadline.period_s
            }
            _ => frame.time_s,
        };
        *slot = Some((frame.time_s, frame.seq));
        if frame.time_s < self.t0 {
            return;
        }
        // nothing was due before the trial began
        let expected_s = expected.max(self.t0).min(frame.time_s);
        self.pending.push(Pending {
            sensor: frame.sensor,
            seq: frame.seq,
            arrived_s: frame.time_s,
            due_s: expected_s + self.deadline.due_s(),
            expected_s,
            classify_ms,
        });
    }

    /// The loop has acted on every pending frame by `now_s` (rig clock; `at` on this
    /// machine's): their timings, and the first that breached the limit.
    pub fn decided(
        &mut self,
        now_s: f64,
        at: Instant,
    ) -> (Vec<FrameTiming>, Option<DeadlineBreach>) {
        let work_ms = self
            .polled
            .take()
            .map_or(0.0, |p| 1e3 * at.saturating_duration_since(p).as_secs_f64());
        let mut breach = None;
        let timings: Vec<FrameTiming> = self
            .pending
            .drain(..)
            .map(|p| {
                let latency_s = now_s - p.expected_s;
                if breach.is_none() && latency_s > self.deadline.limit_s() {
                    breach = Some(DeadlineBreach::Frame {
                        sensor: p.sensor,
                        seq: p.seq,
                        latency_ms: 1e3 * latency_s,
                        limit_ms: 1e3 * self.deadline.limit_s(),
                    });
                }
                FrameTiming {
                    sensor: p.sensor,
                    seq: p.seq,
                    arrived_s: p.arrived_s,
                    due_s: p.due_s,
                    decided_s: now_s,
                    lateness_ms: 1e3 * (now_s - p.due_s),
                    work_ms,
                    classify_ms: p.classify_ms,
                }
            })
            .collect();
        self.frames += timings.len() as u64;
        self.late += timings.iter().filter(|t| t.late()).count() as u64;
        (timings, breach)
    }

    /// The breach of the late-frame budget, judged on the whole trial.
    pub fn share_breach(&self) -> Option<DeadlineBreach> {
        let allowed = self.deadline.spec.max_late_share * self.frames as f64;
        (self.late as f64 > allowed).then_some(DeadlineBreach::Share {
            late: self.late,
            frames: self.frames,
            max_late_share: self.deadline.spec.max_late_share,
        })
    }
}

/// One trial's timing, from its `/timing` channel: what `tmo run` and `tmo report` show.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TimingSummary {
    pub frames: u64,
    pub late: u64,
    pub lateness_p50_ms: f64,
    pub lateness_p99_ms: f64,
    pub lateness_max_ms: f64,
    pub work_p99_ms: f64,
    pub classify_p99_ms: f64,
    /// Frames whose lateness plus this machine's work passes their due time: on the
    /// lock-step simulator, the frames this machine would have been late on at the rig's
    /// pace (on a wall clock the work is already in the lateness: `late` is the count).
    pub late_with_work: u64,
}

impl TimingSummary {
    /// None for a trial without timings (collected, or logged before timings were).
    pub fn of(timings: &[FrameTiming]) -> Option<Self> {
        if timings.is_empty() {
            return None;
        }
        let sorted = |f: &dyn Fn(&FrameTiming) -> f64| {
            let mut v: Vec<f64> = timings.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            v
        };
        let lateness = sorted(&|t| t.lateness_ms);
        let work = sorted(&|t| t.work_ms);
        let classify = sorted(&|t| t.classify_ms);
        Some(Self {
            frames: timings.len() as u64,
            late: timings.iter().filter(|t| t.late()).count() as u64,
            lateness_p50_ms: nearest_rank(&lateness, 0.5),
            lateness_p99_ms: nearest_rank(&lateness, 0.99),
            lateness_max_ms: *lateness.last().expect("not empty"),
            work_p99_ms: nearest_rank(&work, 0.99),
            classify_p99_ms: nearest_rank(&classify, 0.99),
            late_with_work: timings
                .iter()
                .filter(|t| t.lateness_ms + t.work_ms > 0.0)
                .count() as u64,
        })
    }
}

/// The nearest-rank quantile of sorted values, as a reader counts it off a list.
pub fn nearest_rank(sorted: &[f64], q: f64) -> f64 {
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sensor: u8, seq: u64, time_s: f64) -> PinFrame {
        PinFrame {
            sensor,
            seq,
            time_s,
            pins: vec![[0.0, 0.0]],
        }
    }

    const PERIOD: f64 = 1.0 / 60.0;

    fn watch() -> DeadlineWatch {
        DeadlineWatch::new(Deadline::at_rate(DeadlineSpec::default(), 60.0), 2, 0.0)
    }

    #[test]
    fn a_frame_decided_within_a_period_is_on_time_and_one_after_the_limit_breaches() {
        let mut w = watch();
        let now = Instant::now();
        w.classified(&frame(0, 1, 1.0), 0.1);
        let (t, breach) = w.decided(1.0 + 0.5 * PERIOD, now);
        assert_eq!(breach, None);
        assert!(!t[0].late());
        assert!((t[0].lateness_ms + 1e3 * 0.5 * PERIOD).abs() < 1e-9);
        // late, but within the limit
        w.classified(&frame(0, 2, 1.0 + PERIOD), 0.1);
        let (t, breach) = w.decided(1.0 + 2.5 * PERIOD, now);
        assert_eq!(breach, None);
        assert!(t[0].late());
        // past two periods: a breach naming the frame
        w.classified(&frame(0, 3, 1.0 + 2.0 * PERIOD), 0.1);
        let (_, breach) = w.decided(1.0 + 4.5 * PERIOD, now);
        assert!(matches!(
            breach,
            Some(DeadlineBreach::Frame { sensor: 0, seq: 3, latency_ms, .. })
                if (latency_ms - 1e3 * 2.5 * PERIOD).abs() < 1e-9
        ));
    }

    #[test]
    fn a_frame_held_back_by_the_link_counts_from_when_it_was_due_to_arrive() {
        let mut w = watch();
        let now = Instant::now();
        w.classified(&frame(1, 10, 1.0), 0.0);
        w.decided(1.0, now);
        // the next frame arrives 100 ms later and is decided at once: six periods late
        w.classified(&frame(1, 11, 1.1), 0.0);
        let (t, breach) = w.decided(1.1, now);
        assert!((t[0].due_s - (1.0 + 2.0 * PERIOD)).abs() < 1e-12);
        assert!(matches!(
            breach,
            Some(DeadlineBreach::Frame { seq: 11, .. })
        ));
        // a frame the sensor's counter says was lost is not waited for
        let mut w = watch();
        w.classified(&frame(1, 10, 1.0), 0.0);
        w.decided(1.0, now);
        w.classified(&frame(1, 12, 1.0 + 2.0 * PERIOD), 0.0);
        let (t, breach) = w.decided(1.0 + 2.0 * PERIOD, now);
        assert_eq!(breach, None);
        assert!(!t[0].late());
        // sensors are apart: sensor 0's first frame waits for no one
        w.classified(&frame(0, 1, 5.0), 0.0);
        let (t, _) = w.decided(5.0, now);
        assert!(!t[0].late());
    }

    #[test]
    fn the_late_share_is_judged_on_the_whole_trial_and_frames_before_it_are_not_held() {
        let mut w = DeadlineWatch::new(Deadline::at_rate(DeadlineSpec::default(), 60.0), 1, 1.0);
        let now = Instant::now();
        // a frame taken before the trial began is not timed
        w.classified(&frame(0, 1, 0.5), 0.0);
        let (t, breach) = w.decided(1.0, now);
        assert!(t.is_empty() && breach.is_none());
        // 99 on time and one late: within 1 %
        for i in 0..100u64 {
            let at = 1.0 + i as f64 * PERIOD;
            w.classified(&frame(0, 2 + i, at), 0.0);
            let delay = if i == 50 { 1.5 * PERIOD } else { 0.0 };
            w.decided(at + delay, now);
        }
        assert_eq!(w.share_breach(), None);
        let at = 1.0 + 100.0 * PERIOD;
        w.classified(&frame(0, 102, at), 0.0);
        w.decided(at + 1.5 * PERIOD, now);
        assert_eq!(
            w.share_breach(),
            Some(DeadlineBreach::Share {
                late: 2,
                frames: 101,
                max_late_share: 0.01
            })
        );
    }

    #[test]
    fn a_summary_gives_quantiles_and_the_frames_work_would_have_made_late() {
        let t = |lateness_ms: f64, work_ms: f64| FrameTiming {
            sensor: 0,
            seq: 1,
            arrived_s: 0.0,
            due_s: 0.0,
            decided_s: 0.0,
            lateness_ms,
            work_ms,
            classify_ms: 0.5 * work_ms,
        };
        assert_eq!(TimingSummary::of(&[]), None);
        let s = TimingSummary::of(&[t(-16.0, 1.0), t(-15.0, 20.0), t(2.0, 1.0)]).unwrap();
        assert_eq!((s.frames, s.late, s.late_with_work), (3, 1, 2));
        assert_eq!(s.lateness_p50_ms, -15.0);
        assert_eq!(s.lateness_max_ms, 2.0);
        assert_eq!(s.work_p99_ms, 20.0);
    }

    #[test]
    fn the_terms_are_checked() {
        assert!(DeadlineSpec::default().check().is_ok());
        let bad = DeadlineSpec {
            limit_periods: 0.5,
            ..Default::default()
        };
        assert_eq!(bad.check().unwrap_err().0, "limit_periods");
        let bad = DeadlineSpec {
            max_late_share: 2.0,
            ..Default::default()
        };
        assert_eq!(bad.check().unwrap_err().0, "max_late_share");
    }
}
