//! Contact from the pins alone (paper, "First Time Grasping", Eq. 4): the deformation
//! `d(t) = 1/N sum_p |pin_p(t) - pin_p(0)|`, with `pin_p(0)` taken before contact.
//!
//! Two guards the paper's formula does not need on clean data but a pin tracker does:
//! - the reference is the per-pin median of the first [`REFERENCE_FRAMES`] frames, so a pin
//!   mis-detected in the very first frame does not shift every later `d(t)`;
//! - a pin further than `max_pin_step_px` from its reference (a blob detector that jumped to
//!   another pin) is left out of the mean, as the feature code leaves it out of a frame.
//!   Without this one bad pin in 30 adds ~7 px / 30 = 0.2 px to `d(t)`, close to the
//!   0.5 px contact threshold (seen on the simulator, whose trackers mis-detect).

use tmo_hal::PinFrame;

/// Frames per sensor that make up the contact-free reference.
pub const REFERENCE_FRAMES: usize = 3;

/// Mean distance of the pins of `frame` from `reference`, px, leaving out pins that moved
/// more than `max_pin_step_px`; `None` when every pin was left out or the counts differ.
pub fn deformation_px(
    reference: &[[f32; 2]],
    frame: &PinFrame,
    max_pin_step_px: f64,
) -> Option<f64> {
    if reference.len() != frame.pins.len() || reference.is_empty() {
        return None;
    }
    let (mut sum, mut n) = (0.0, 0usize);
    for (a, b) in reference.iter().zip(&frame.pins) {
        let d = ((b[0] - a[0]) as f64).hypot((b[1] - a[1]) as f64);
        if d <= max_pin_step_px {
            sum += d;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// Watches every sensor's deformation against its contact-free reference.
#[derive(Debug, Clone)]
pub struct ContactGauge {
    max_pin_step_px: f64,
    warmup: Vec<Vec<Vec<[f32; 2]>>>,
    reference: Vec<Option<Vec<[f32; 2]>>>,
    latest: Vec<Option<f64>>,
}

impl ContactGauge {
    pub fn new(sensors: usize, max_pin_step_px: f64) -> Self {
        Self {
            max_pin_step_px,
            warmup: vec![Vec::new(); sensors],
            reference: vec![None; sensors],
            latest: vec![None; sensors],
        }
    }

    /// Takes one frame; frames of unknown sensors are ignored.
    pub fn observe(&mut self, frame: &PinFrame) {
        let s = frame.sensor as usize;
        if s >= self.reference.len() {
            return;
        }
        match &self.reference[s] {
            Some(r) => {
                if let Some(d) = deformation_px(r, frame, self.max_pin_step_px) {
                    self.latest[s] = Some(d);
                }
            }
            None => {
                let w = &mut self.warmup[s];
                if w.first().is_some_and(|f| f.len() != frame.pins.len()) {
                    w.clear();
                }
                w.push(frame.pins.clone());
                if w.len() == REFERENCE_FRAMES {
                    self.reference[s] = Some(median_pins(w));
                    w.clear();
                }
            }
        }
    }

    /// Latest deformation of each sensor, px (`None` until it has a reference and a frame).
    pub fn deformation(&self) -> &[Option<f64>] {
        &self.latest
    }

    /// The smallest deformation over the sensors, once every sensor has one: contact on every
    /// finger is what a grasp needs, so the least-deformed sensor decides.
    pub fn least_deformed(&self) -> Option<f64> {
        self.latest
            .iter()
            .try_fold(f64::INFINITY, |m, d| d.map(|d| m.min(d)))
    }
}

fn median_pins(frames: &[Vec<[f32; 2]>]) -> Vec<[f32; 2]> {
    let median = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    (0..frames[0].len())
        .map(|p| {
            [
                median(frames.iter().map(|f| f[p][0]).collect()),
                median(frames.iter().map(|f| f[p][1]).collect()),
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sensor: u8, pins: Vec<[f32; 2]>) -> PinFrame {
        PinFrame {
            sensor,
            seq: 0,
            time_s: 0.0,
            pins,
        }
    }

    #[test]
    fn deformation_is_the_mean_pin_distance() {
        let r = [[0.0, 0.0], [10.0, 10.0]];
        let f = frame(0, vec![[3.0, 4.0], [10.0, 10.0]]);
        assert!((deformation_px(&r, &f, 20.0).unwrap() - 2.5).abs() < 1e-12);
    }

    #[test]
    fn a_jumped_pin_is_left_out_of_the_mean() {
        let r = [[0.0, 0.0], [10.0, 10.0], [20.0, 20.0]];
        let f = frame(0, vec![[0.0, 1.0], [10.0, 11.0], [60.0, 20.0]]);
        assert!((deformation_px(&r, &f, 20.0).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(deformation_px(&r[..2], &f, 20.0), None, "pin counts differ");
    }

    #[test]
    fn the_reference_survives_a_bad_first_frame_and_contact_needs_every_sensor() {
        let rest = vec![[0.0, 0.0], [10.0, 0.0]];
        let mut bad = rest.clone();
        bad[0] = [0.0, 15.0]; // mis-detected, yet within the step limit
        let mut g = ContactGauge::new(2, 20.0);
        for pins in [bad, rest.clone(), rest.clone()] {
            g.observe(&frame(0, pins.clone()));
            g.observe(&frame(1, pins));
        }
        assert_eq!(g.least_deformed(), None, "no frame after the reference yet");
        g.observe(&frame(0, vec![[0.0, 2.0], [10.0, 2.0]]));
        assert_eq!(g.least_deformed(), None, "sensor 1 has no reading yet");
        g.observe(&frame(1, vec![[0.0, 0.5], [10.0, 0.5]]));
        assert_eq!(g.deformation(), &[Some(2.0), Some(0.5)]);
        assert_eq!(g.least_deformed(), Some(0.5));
        g.observe(&frame(7, rest));
    }
}
