//! What every protocol runner keeps while a trial runs, and the steps all of them take:
//! begin (the start time, a monitor of the sensors' frames, an empty recording and event
//! list), tick and judge the new frames, log an event, finish into a [`RunRecord`].

use std::sync::atomic::AtomicBool;

use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use super::devices::{Devices, InFlight, Recording, ScenarioError};
use super::monitor::{FrameMonitor, Verdict, WatchLimits};
use super::{event, Fault, Online, RunRecord};
use crate::online::classify::Reaction;
use crate::trial::TrialEvent;

pub(super) struct TrialRun<'m> {
    /// The trial's start on the devices' clock.
    pub t0: f64,
    pub monitor: FrameMonitor<'m>,
    pub rec: Recording,
    pub events: Vec<TrialEvent>,
    in_flight: Option<InFlight>,
    finished: bool,
}

impl Drop for TrialRun<'_> {
    fn drop(&mut self) {
        if self.finished {
            return;
        }
        let Some(sink) = &self.in_flight else { return };
        let ended_s = self.rec.arrivals_s.last().copied().unwrap_or(self.t0);
        let record = RunRecord {
            recording: std::mem::take(&mut self.rec),
            armed_s: None,
            reaction: None,
            fault: None,
            ended_s,
            events: std::mem::take(&mut self.events),
        };
        if let Ok(mut slot) = sink.lock() {
            *slot = Some(record);
        }
    }
}

/// One tick's outcome: the monitor's verdict on the frames that arrived, the time after
/// the tick, and where in the recording the tick's frames begin.
pub(super) struct Step {
    pub verdict: Verdict,
    pub now: f64,
    pub first_new: usize,
}

impl<'m> TrialRun<'m> {
    /// Starts a trial now on `dev`'s clock; `online` None watches without classifying.
    pub fn begin<C, H, A, M, S>(
        dev: &Devices<C, H, A, M, S>,
        online: Option<Online<'m>>,
        watch: WatchLimits,
    ) -> Self
    where
        C: Clock,
    {
        let t0 = dev.clock.now_s();
        Self {
            t0,
            monitor: FrameMonitor::new(dev.sensors.len(), online, watch, t0),
            rec: Recording::default(),
            events: Vec::new(),
            in_flight: dev.in_flight.clone(),
            finished: false,
        }
    }

    /// Logs an event on `topic` at `now`.
    pub fn log(&mut self, now: f64, topic: &str, data: serde_json::Value) {
        self.events.push(event(now, topic, data));
    }

    /// One control tick (no state sample while `waiting_for_slip`), then the monitor's
    /// verdict on the new frames, which count towards a reaction if `armed_at(now)` holds
    /// for the time after the tick.
    pub fn step<C, H, A, M, S>(
        &mut self,
        dev: &mut Devices<C, H, A, M, S>,
        waiting_for_slip: bool,
        armed_at: impl FnOnce(f64) -> bool,
        stop: &AtomicBool,
    ) -> Result<Step, ScenarioError>
    where
        C: Clock,
        H: Hand,
        A: Arm,
        M: MarkerTracker,
        S: TactileSensor,
    {
        // The last tick's frames have been acted on (a command sent, or none needed).
        let before = dev.clock.now_s();
        if let Some(fault) = self.monitor.decided(before, &mut self.events) {
            self.events
                .push(event(before, "/fault", serde_json::json!(fault)));
            return Ok(Step {
                verdict: Verdict::Abort(fault),
                now: before,
                first_new: self.rec.frames.len(),
            });
        }
        let (first_new, now) = dev.tick(&mut self.rec, &mut self.events, waiting_for_slip)?;
        let armed = armed_at(now);
        let verdict = self.monitor.feed(
            &self.rec.frames[first_new..],
            now,
            armed,
            stop,
            &mut self.events,
        );
        Ok(Step {
            verdict,
            now,
            first_new,
        })
    }

    /// The trial's record, ended at `ended_s`. A trial that kept no other fault but broke
    /// the real-time contract ends on that fault.
    pub fn finish(
        mut self,
        ended_s: f64,
        armed_s: Option<f64>,
        reaction: Option<Reaction>,
        mut fault: Option<Fault>,
    ) -> RunRecord {
        self.finished = true;
        let breach = self.monitor.decided(ended_s, &mut self.events);
        if fault.is_none() {
            fault = breach.or_else(|| self.monitor.share_breach());
            if let Some(f) = fault {
                self.events
                    .push(event(ended_s, "/fault", serde_json::json!(f)));
            }
        }
        RunRecord {
            recording: std::mem::take(&mut self.rec),
            armed_s,
            reaction,
            fault,
            ended_s,
            events: std::mem::take(&mut self.events),
        }
    }
}
