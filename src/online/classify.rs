//! Classifies each sensor's frames as they arrive, the way the runner does live: features
//! from the sensor's previous frame, that sensor's model (local) or the shared one (global);
//! a windowed ONNX model reads the sensor's last K frames' features.

use tmo_hal::PinFrame;

use super::strategy::{Detector, Strategy};
use crate::slip::features::{frame_features, mean_velocity_norm};
use crate::slip::slip_model::SlipModel;
use crate::slip::Class;

/// Per-sensor state of the online classifier.
pub struct FrameClassifier<'m> {
    model: &'m SlipModel,
    previous: Vec<Option<PinFrame>>,
    /// Each sensor's last frames' features, for a model that reads a window of them.
    windows: Vec<FeatureWindow>,
    features: Vec<f32>,
    scratch: Vec<f32>,
}

/// One sensor's last K frames' features, oldest first, on consecutive frames only: as
/// offline (`OnnxModel::predict_rows`), a dropped frame or one that gave no features
/// starts the window again.
#[derive(Debug, Clone, Default)]
struct FeatureWindow {
    /// `frames * F` values.
    values: Vec<f32>,
    frames: usize,
    last_seq: Option<u64>,
}

impl FeatureWindow {
    /// Adds frame `seq`'s features; the full window when it holds `k` frames.
    fn push(&mut self, seq: u64, features: &[f32], k: usize) -> Option<&[f32]> {
        if self.last_seq.is_none_or(|last| last + 1 != seq) {
            self.values.clear();
            self.frames = 0;
        }
        self.last_seq = Some(seq);
        if self.frames == k {
            // drop the oldest frame (K * F floats moved: some hundreds, per frame)
            self.values.drain(..features.len());
            self.frames -= 1;
        }
        self.values.extend_from_slice(features);
        self.frames += 1;
        (self.frames == k).then_some(self.values.as_slice())
    }

    fn reset(&mut self) {
        self.last_seq = None;
    }
}

/// One classified frame: its class, the model's value it was read from, and the norm of its
/// mean pin velocity (px per frame, the quantity the threshold classifier and the paper's
/// pin-speed histogram use), for logs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classified {
    pub class: Class,
    /// The model's slip value: an ONNX model's output as its metadata states it, a tmo
    /// model's decision value (positive for slip; the threshold's `v - T`).
    pub value: f32,
    pub mean_velocity_px: f32,
}

/// A model's output that is no class: a non-finite value, or a run that failed. Online, it
/// faults the trial; it is never read as static.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BadOutput {
    Nan,
    PositiveInfinity,
    NegativeInfinity,
    /// The runtime failed on the frame (it ran on zeros at load, so this is not expected).
    RunFailed,
}

impl std::fmt::Display for BadOutput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BadOutput::Nan => "NaN",
            BadOutput::PositiveInfinity => "inf",
            BadOutput::NegativeInfinity => "-inf",
            BadOutput::RunFailed => "no value (the runtime failed)",
        })
    }
}

impl BadOutput {
    /// What a slip value that is not finite is.
    pub fn of(value: f32) -> Option<Self> {
        if value.is_nan() {
            Some(BadOutput::Nan)
        } else if value == f32::INFINITY {
            Some(BadOutput::PositiveInfinity)
        } else if value == f32::NEG_INFINITY {
            Some(BadOutput::NegativeInfinity)
        } else {
            None
        }
    }
}

impl<'m> FrameClassifier<'m> {
    pub fn new(model: &'m SlipModel, sensors: usize) -> Self {
        Self {
            model,
            previous: vec![None; sensors],
            windows: vec![FeatureWindow::default(); sensors],
            features: Vec::with_capacity(model.features().len()),
            scratch: Vec::new(),
        }
    }

    /// The class of `frame` and the value it was read from, or `None` when it cannot be
    /// classified: a sensor's first frame, a frame whose pins do not match, a sensor the
    /// model has no classifier for, a frame before a windowed model's window is full. A
    /// model that gives no finite value is an error.
    pub fn classify(&mut self, frame: &PinFrame) -> Result<Option<(Class, f32)>, BadOutput> {
        let sensor = usize::from(frame.sensor);
        let Some(slot) = self.previous.get_mut(sensor) else {
            return Ok(None);
        };
        let Some(previous) = slot.replace(frame.clone()) else {
            return Ok(None);
        };
        if frame_features(self.model.features(), &previous, frame, &mut self.features).is_err() {
            self.windows[sensor].reset();
            return Ok(None);
        }
        match self.model {
            SlipModel::Tmo(m) => {
                let Some(model) = m.for_sensor(frame.sensor) else {
                    return Ok(None);
                };
                let decision = model.decision(&self.features, &mut self.scratch);
                Ok(Some((model.class_of(decision), decision as f32)))
            }
            SlipModel::Onnx(m) => {
                let Some(window) =
                    self.windows[sensor].push(frame.seq, &self.features, m.meta.window)
                else {
                    return Ok(None);
                };
                match m.slip_value(window) {
                    Ok(v) => Ok(Some((m.class_of(v), v))),
                    Err(crate::slip::onnx::OnnxError::NonFinite { value, .. }) => {
                        Err(BadOutput::of(value).unwrap_or(BadOutput::RunFailed))
                    }
                    Err(_) => Err(BadOutput::RunFailed),
                }
            }
        }
    }

    /// Like [`Self::classify`], with the frame's mean pin velocity beside the class (from
    /// the features `classify` just computed: replays, which need only the class, do not
    /// pay for it).
    pub fn classify_frame(&mut self, frame: &PinFrame) -> Result<Option<Classified>, BadOutput> {
        Ok(self.classify(frame)?.map(|(class, value)| Classified {
            class,
            value,
            mean_velocity_px: mean_velocity_norm(&self.features),
        }))
    }
}

/// When the detector would first have made the hand react.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reaction {
    pub time_s: f64,
    pub sensor: u8,
    pub seq: u64,
}

/// Runs `strategy` over recorded `frames` (in arrival order): the first reaction, if any.
pub fn first_reaction(
    model: &SlipModel,
    sensors: usize,
    frames: &[PinFrame],
    strategy: Strategy,
) -> Result<Option<Reaction>, BadOutput> {
    let mut classifier = FrameClassifier::new(model, sensors);
    let mut detector = Detector::new(strategy, sensors);
    for f in frames {
        let Some((class, _)) = classifier.classify(f)? else {
            continue;
        };
        if detector.observe(usize::from(f.sensor), class) {
            return Ok(Some(Reaction {
                time_s: f.time_s,
                sensor: f.sensor,
                seq: f.seq,
            }));
        }
    }
    Ok(None)
}

/// What classifying one frame costs this machine, measured at load on frames of zeros
/// through the online loop's own classifier (features included), every sensor's in turn.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FrameCost {
    pub frames: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
}

/// Times `model` on `sensors` fingertips of `pins` pins, frame by frame, after a window
/// and a few frames of warm-up: up to 300 classified frames, or as many as half a second
/// allows (at least 5), so a slow model is found without waiting long for it.
pub fn frame_cost(model: &SlipModel, sensors: usize, pins: usize) -> FrameCost {
    let mut classifier = FrameClassifier::new(model, sensors);
    let warm_up = model.window() + 3;
    let started = std::time::Instant::now();
    let mut costs = Vec::new();
    for seq in 1u64.. {
        for sensor in 0..sensors {
            let frame = PinFrame {
                sensor: sensor as u8,
                seq,
                time_s: seq as f64 / 60.0,
                // a hair of difference between frames, as noise gives real ones
                pins: vec![[(seq % 2) as f32 * 1e-3, 0.0]; pins],
            };
            let t = std::time::Instant::now();
            // a non-finite output was refused at load; its cost is what counts here
            let _ = classifier.classify(&frame);
            if seq as usize > warm_up {
                costs.push(1e3 * t.elapsed().as_secs_f64());
            }
        }
        let enough = costs.len() >= 300
            || (costs.len() >= 5 && started.elapsed().as_secs_f64() >= 0.5)
            || seq as usize > 10_000;
        if enough {
            break;
        }
    }
    costs.sort_by(f64::total_cmp);
    let q = |q: f64| {
        if costs.is_empty() {
            0.0
        } else {
            super::deadline::nearest_rank(&costs, q)
        }
    };
    FrameCost {
        frames: costs.len(),
        p50_ms: q(0.5),
        p99_ms: q(0.99),
        max_ms: costs.last().copied().unwrap_or(0.0),
    }
}

/// One frame's slip value and class, as the online loop computed it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameValue {
    pub sensor: u8,
    pub seq: u64,
    pub time_s: f64,
    pub value: f32,
    pub class: Class,
}

/// A frame the model gave no finite value for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the slip value of sensor {sensor}'s frame {seq} is {output}, not a finite number")]
pub struct FrameOutputError {
    pub sensor: u8,
    pub seq: u64,
    pub output: BadOutput,
}

/// Every classifiable frame of recorded `frames` (in arrival order) with the model's value
/// and class, through the online loop's own classifier (`tmo replay --rows`): frames the loop
/// gives no class (a sensor's first, before a full window) are left out.
pub fn frame_values(
    model: &SlipModel,
    sensors: usize,
    frames: &[PinFrame],
) -> Result<Vec<FrameValue>, FrameOutputError> {
    let mut classifier = FrameClassifier::new(model, sensors);
    let mut out = Vec::with_capacity(frames.len());
    for f in frames {
        let classified = classifier.classify(f).map_err(|output| FrameOutputError {
            sensor: f.sensor,
            seq: f.seq,
            output,
        })?;
        if let Some((class, value)) = classified {
            out.push(FrameValue {
                sensor: f.sensor,
                seq: f.seq,
                time_s: f.time_s,
                value,
                class,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::FeatureWindow;

    #[test]
    fn a_window_fills_on_consecutive_frames_slides_and_starts_again_after_a_gap() {
        let mut w = FeatureWindow::default();
        let f = |v: f32| [v, -v];
        // K = 3: no window until three consecutive frames
        assert_eq!(w.push(1, &f(1.0), 3), None);
        assert_eq!(w.push(2, &f(2.0), 3), None);
        assert_eq!(
            w.push(3, &f(3.0), 3),
            Some(&[1.0, -1.0, 2.0, -2.0, 3.0, -3.0][..])
        );
        // it slides, oldest first
        assert_eq!(
            w.push(4, &f(4.0), 3),
            Some(&[2.0, -2.0, 3.0, -3.0, 4.0, -4.0][..])
        );
        // a dropped frame (5) starts it again
        assert_eq!(w.push(6, &f(6.0), 3), None);
        assert_eq!(w.push(7, &f(7.0), 3), None);
        assert_eq!(
            w.push(8, &f(8.0), 3),
            Some(&[6.0, -6.0, 7.0, -7.0, 8.0, -8.0][..])
        );
        // a frame without features (reset) too, even if the next one is consecutive
        w.reset();
        assert_eq!(w.push(9, &f(9.0), 3), None);
        // K = 1: every frame is a window
        let mut one = FeatureWindow::default();
        assert_eq!(one.push(5, &f(5.0), 1), Some(&[5.0, -5.0][..]));
        assert_eq!(one.push(9, &f(9.0), 1), Some(&[9.0, -9.0][..]));
    }
}
