//! The live view of `tmo sim serve`: what the served rig's devices send, as they send it,
//! on the same channels a trial log has (pins, markers, the hand's and arm's state), so the
//! layout in `docs/foxglove/` shows a served rig as it shows a trial.

use tmo_hal::{HandPositions, MarkerSample, PinFrame, Pose};
use tmo_sim::serve::ServeTap;

use super::LiveView;
use crate::trial::state::state_events;

/// A [`ServeTap`] that publishes to a [`LiveView`], log times on the wall clock from when
/// serving began.
pub struct ServedRigView {
    view: LiveView,
    started_unix_ns: u64,
}

impl ServedRigView {
    pub fn new(view: LiveView, started_unix_ns: u64) -> Self {
        Self {
            view,
            started_unix_ns,
        }
    }

    fn at(&self, served_s: f64) -> u64 {
        self.started_unix_ns
            .saturating_add((served_s.max(0.0) * 1e9).round() as u64)
    }
}

impl ServeTap for ServedRigView {
    fn frame(&mut self, served_s: f64, frame: &PinFrame) {
        // no classifier runs in the server: the scene shows the pins uncoloured
        self.view.send_frame(frame, None, self.at(served_s));
    }

    fn marker(&mut self, served_s: f64, sample: &MarkerSample) {
        self.view.send_marker(sample, self.at(served_s));
    }

    fn state(&mut self, served_s: f64, world_s: f64, hand: HandPositions, tcp: Pose) {
        for e in state_events(world_s, hand, tcp, &[]) {
            self.view.send_event(&e, self.at(served_s));
        }
    }
}
