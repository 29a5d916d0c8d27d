//! Short scripted scenarios over the HAL traits, for looking at a rig's behaviour
//! (`tmo sim trace`). They run on any backend: they only command devices and wait on the
//! clock. The protocol runner is what experiments use; these are for inspection.

use tmo_hal::{Arm, Clock, Hand, MarkerTracker, TactileSensor};

use crate::runner::devices::{device, Devices, Recording, ScenarioError};
use crate::runner::sim_presets::Script;

use crate::online::contact::ContactGauge;
use crate::slip::features::FeatureSpec;

/// Control period of the scripts, s (1 kHz, like the runner's loop).
const TICK_S: f64 = 0.001;

impl<C, H, A, M, S> Devices<C, H, A, M, S>
where
    C: Clock,
    H: Hand,
    A: Arm,
    M: MarkerTracker,
    S: TactileSensor,
{
    /// Runs `script` for `duration_s`, calling `observe` after every tick (for ground truth
    /// on the simulator).
    pub fn run(
        &mut self,
        script: Script,
        duration_s: f64,
        mut observe: impl FnMut(f64),
    ) -> Result<Recording, ScenarioError> {
        let mut rec = Recording::default();
        let start = self.hand.present_positions().map_err(device("hand"))?;
        let phase_start = self.clock.now_s();
        let mut lifting = false;
        let mut gauge = ContactGauge::new(
            self.sensors.len(),
            FeatureSpec::new(0).max_pin_step_px as f64,
        );
        let mut seen = 0;
        if let Script::Retract {
            speed_mm_s,
            distance_mm,
        } = script
        {
            self.arm
                .move_linear([-distance_mm, 0.0, 0.0], speed_mm_s)
                .map_err(device("arm"))?;
        }
        while self.clock.now_s() < duration_s {
            let now = self.clock.now_s();
            match script {
                Script::Release {
                    speed_per_s,
                    hold_s,
                } if now >= phase_start + hold_s => {
                    let q =
                        |i: usize| (start[i] - speed_per_s * (now - phase_start - hold_s)).max(0.0);
                    self.hand
                        .set_targets([q(0), q(1), q(2), start[3]])
                        .map_err(device("hand"))?;
                }
                Script::Lift {
                    deformation_px: goal,
                    close_speed_per_s,
                    lift_speed_mm_s,
                } if !lifting => {
                    // d(t) of the least deformed sensor: every finger touches.
                    for f in &rec.frames[seen..] {
                        gauge.observe(f);
                    }
                    seen = rec.frames.len();
                    let deepest = gauge.least_deformed().unwrap_or(0.0);
                    if deepest >= goal {
                        let held = self.hand.present_positions().map_err(device("hand"))?;
                        self.hand.set_targets(held).map_err(device("hand"))?;
                        self.arm
                            .move_velocity([0.0, 0.0, lift_speed_mm_s])
                            .map_err(device("arm"))?;
                        lifting = true;
                    } else {
                        let q = |i: usize| {
                            (start[i] + close_speed_per_s * (now - phase_start)).min(1.0)
                        };
                        if q(0) >= 1.0 {
                            return Err(ScenarioError::NoContact {
                                deformation_px: deepest,
                            });
                        }
                        self.hand
                            .set_targets([q(0), q(1), q(2), start[3]])
                            .map_err(device("hand"))?;
                    }
                }
                _ => {}
            }
            self.clock.sleep(TICK_S);
            self.poll(&mut rec)?;
            observe(self.clock.now_s());
        }
        self.arm.stop().map_err(device("arm"))?;
        Ok(rec)
    }
}
