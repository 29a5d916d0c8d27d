//! Classifies each sensor's frames as they arrive, the way the runner does live: features
//! from the sensor's previous frame, that sensor's model (local) or the shared one (global).

use tmo_hal::PinFrame;

use super::strategy::{Detector, Strategy};
use crate::slip::features::{frame_features, mean_velocity_norm};
use crate::slip::model::ModelFile;
use crate::slip::Class;

/// Per-sensor state of the online classifier.
pub struct FrameClassifier<'m> {
    model: &'m ModelFile,
    previous: Vec<Option<PinFrame>>,
    features: Vec<f32>,
    scratch: Vec<f32>,
}

/// One classified frame: its class and the norm of its mean pin velocity (px per frame, the
/// quantity the threshold classifier and the paper's pin-speed histogram use), for logs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classified {
    pub class: Class,
    pub mean_velocity_px: f32,
}

impl<'m> FrameClassifier<'m> {
    pub fn new(model: &'m ModelFile, sensors: usize) -> Self {
        Self {
            model,
            previous: vec![None; sensors],
            features: Vec::with_capacity(model.features.len()),
            scratch: Vec::new(),
        }
    }

    /// The class of `frame`, or `None` when it cannot be classified: a sensor's first frame,
    /// a frame whose pins do not match, or a sensor the model has no classifier for.
    pub fn classify(&mut self, frame: &PinFrame) -> Option<Class> {
        let slot = self.previous.get_mut(usize::from(frame.sensor))?;
        let previous = slot.replace(frame.clone())?;
        frame_features(&self.model.features, &previous, frame, &mut self.features).ok()?;
        let model = self.model.for_sensor(frame.sensor)?;
        Some(model.predict(&self.features, &mut self.scratch))
    }

    /// Like [`Self::classify`], with the frame's mean pin velocity beside the class (from
    /// the features `classify` just computed: replays, which need only the class, do not
    /// pay for it).
    pub fn classify_frame(&mut self, frame: &PinFrame) -> Option<Classified> {
        let class = self.classify(frame)?;
        Some(Classified {
            class,
            mean_velocity_px: mean_velocity_norm(&self.features),
        })
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
    model: &ModelFile,
    sensors: usize,
    frames: &[PinFrame],
    strategy: Strategy,
) -> Option<Reaction> {
    let mut classifier = FrameClassifier::new(model, sensors);
    let mut detector = Detector::new(strategy, sensors);
    frames.iter().find_map(|f| {
        let class = classifier.classify(f)?;
        detector
            .observe(usize::from(f.sensor), class)
            .then_some(Reaction {
                time_s: f.time_s,
                sensor: f.sensor,
                seq: f.seq,
            })
    })
}
