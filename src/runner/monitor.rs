//! What every runner does with arriving frames: watch each sensor for silence and frozen
//! frames, classify every frame, and (when armed) feed the NFr x NSen detector.

use std::sync::atomic::{AtomicBool, Ordering};

use serde_json::json;
use tmo_hal::PinFrame;

use super::{event, Fault, Online};
use crate::online::classify::{FrameClassifier, Reaction};
use crate::online::deadline::{Deadline, DeadlineWatch};
use crate::online::strategy::Detector;
use crate::trial::TrialEvent;

/// Watchdog limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchLimits {
    /// A sensor silent this long aborts the trial, s.
    pub silent_limit_s: f64,
    /// This many identical frames in a row from one sensor abort the trial (a frozen
    /// camera repeats its last frame; noise makes real frames differ).
    pub stale_limit: u32,
    /// The real-time contract an online trial's frames are held to; `None` (replay, whose
    /// recorded times are not this loop's) times nothing.
    pub deadline: Option<Deadline>,
}

impl Default for WatchLimits {
    fn default() -> Self {
        Self {
            silent_limit_s: 0.25,
            stale_limit: 10,
            deadline: None,
        }
    }
}

/// What the latest frames call for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    Continue,
    Abort(Fault),
    React(Reaction),
}

pub struct FrameMonitor<'m> {
    limits: WatchLimits,
    classifier: Option<FrameClassifier<'m>>,
    detector: Option<Detector>,
    last_frame_s: Vec<f64>,
    repeats: Vec<u32>,
    previous_pins: Vec<Option<Vec<[f32; 2]>>>,
    /// Whether the last batch was fed armed: changes are logged, so replay arms exactly the
    /// batches the live detector saw armed.
    armed: bool,
    /// Each classified frame against the real-time contract (online trials with one).
    timing: Option<DeadlineWatch>,
}

impl<'m> FrameMonitor<'m> {
    pub fn new(sensors: usize, online: Option<Online<'m>>, limits: WatchLimits, t0: f64) -> Self {
        Self {
            limits,
            classifier: online.map(|o| FrameClassifier::new(o.model, sensors)),
            detector: online.map(|o| Detector::new(o.strategy, sensors)),
            last_frame_s: vec![t0; sensors],
            repeats: vec![0; sensors],
            previous_pins: vec![None; sensors],
            armed: false,
            timing: online
                .and(limits.deadline)
                .map(|d| DeadlineWatch::new(d, sensors, t0)),
        }
    }

    /// The loop has acted on the frames fed so far, by `now` (rig clock): their timings go
    /// to `/timing`; a frame past the contract's limit is the fault returned.
    pub fn decided(&mut self, now: f64, events: &mut Vec<TrialEvent>) -> Option<Fault> {
        let w = self.timing.as_mut()?;
        let (timings, breach) = w.decided(now, std::time::Instant::now());
        events.extend(
            timings
                .iter()
                .map(|t| event(now, "/timing", json!(t.to_microsecond()))),
        );
        breach.map(Fault::Deadline)
    }

    /// At the trial's end, after [`Self::decided`]: a late-frame budget overspent.
    pub fn share_breach(&self) -> Option<Fault> {
        self.timing.as_ref()?.share_breach().map(Fault::Deadline)
    }

    /// Forgets the detector's runs, so the next reaction needs fresh evidence.
    pub fn rearm(&mut self) {
        if let Some(d) = self.detector.as_mut() {
            d.reset();
        }
    }

    /// Takes the frames that arrived by `now`. A fault (or `stop`) wins over a reaction;
    /// only `armed` frames count towards a reaction. Classifier outputs and the reaction go
    /// to `events`.
    pub fn feed(
        &mut self,
        frames: &[PinFrame],
        now: f64,
        armed: bool,
        stop: &AtomicBool,
        events: &mut Vec<TrialEvent>,
    ) -> Verdict {
        let sensors = self.last_frame_s.len();
        let mut fault = None;
        for f in frames {
            let k = usize::from(f.sensor);
            if k >= sensors {
                continue;
            }
            self.last_frame_s[k] = now;
            let same = self.previous_pins[k].as_ref() == Some(&f.pins);
            self.repeats[k] = if same { self.repeats[k] + 1 } else { 0 };
            self.previous_pins[k] = Some(f.pins.clone());
            if self.repeats[k] >= self.limits.stale_limit {
                fault.get_or_insert(Fault::StaleFrames {
                    sensor: f.sensor,
                    repeats: self.repeats[k],
                });
            }
        }
        if let Some(k) =
            (0..sensors).find(|&k| now - self.last_frame_s[k] > self.limits.silent_limit_s)
        {
            fault.get_or_insert(Fault::SilentSensor {
                sensor: k as u8,
                last_frame_s: self.last_frame_s[k],
            });
        }
        if stop.load(Ordering::Relaxed) {
            fault.get_or_insert(Fault::Interrupted);
        }
        if let Some(f) = fault {
            events.push(event(now, "/fault", json!(f)));
            return Verdict::Abort(f);
        }
        if armed != self.armed {
            self.armed = armed;
            let what = if armed { "armed" } else { "disarmed" };
            events.push(event(now, "/detector", json!({ "event": what })));
        }
        let (Some(c), Some(d)) = (self.classifier.as_mut(), self.detector.as_mut()) else {
            return Verdict::Continue;
        };
        if let Some(w) = self.timing.as_mut() {
            w.polled(std::time::Instant::now());
        }
        for f in frames {
            // Every frame is classified so each sensor has its previous frame ready.
            // timed only where a contract holds the trial (never in replay's hot loop)
            let started = self.timing.is_some().then(std::time::Instant::now);
            let result = c.classify_frame(f);
            if let (Some(w), Some(t)) = (self.timing.as_mut(), started) {
                w.classified(f, 1e3 * t.elapsed().as_secs_f64());
            }
            let classified = match result {
                Ok(Some(classified)) => classified,
                Ok(None) => continue,
                Err(output) => {
                    let fault = Fault::ModelOutput {
                        sensor: f.sensor,
                        seq: f.seq,
                        output,
                    };
                    events.push(event(now, "/fault", json!(fault)));
                    return Verdict::Abort(fault);
                }
            };
            let class = classified.class;
            // 4 decimals (0.1 mpx/frame, far below the pins' noise): the log stays small
            let speed = (f64::from(classified.mean_velocity_px) * 1e4).round() / 1e4;
            events.push(event(
                f.time_s,
                "/classifier",
                // the class as a label and as a number a plot can draw
                json!({"sensor": f.sensor, "seq": f.seq, "class": class,
                       "slip": u8::from(class == crate::slip::Class::Slip),
                       "value": classified.value,
                       "mean_velocity_px": speed}),
            ));
            if armed && d.observe(usize::from(f.sensor), class) {
                events.push(event(
                    now,
                    "/detector",
                    json!({"event": "reaction", "frame_time_s": f.time_s, "sensor": f.sensor, "seq": f.seq, "strategy": d.strategy().to_string()}),
                ));
                return Verdict::React(Reaction {
                    time_s: f.time_s,
                    sensor: f.sensor,
                    seq: f.seq,
                });
            }
        }
        Verdict::Continue
    }
}
