//! Safety limits checked before any command reaches a device: the runner drives
//! [`SafeHand`] and [`SafeArm`], which refuse (with [`ErrorKind::OutOfLimits`]) a command
//! past the limits without sending it.

use tmo_hal::{Arm, ErrorKind, ErrorType, Hand, HandPositions, Pose};

/// The limits come from the protocol's `[safety]` section (defaults there).
pub use crate::protocol::SafetyLimits;

#[derive(Debug, thiserror::Error)]
pub enum SafetyError<E: std::error::Error + 'static> {
    #[error("refused before sending: {0}")]
    Refused(String),
    #[error(transparent)]
    Device(E),
}

impl<E: tmo_hal::Error> tmo_hal::Error for SafetyError<E> {
    fn kind(&self) -> ErrorKind {
        match self {
            SafetyError::Refused(_) => ErrorKind::OutOfLimits,
            SafetyError::Device(e) => e.kind(),
        }
    }
}

pub struct SafeHand<H> {
    inner: H,
    limits: SafetyLimits,
}

impl<H> SafeHand<H> {
    pub fn new(inner: H, limits: SafetyLimits) -> Self {
        Self { inner, limits }
    }
}

impl<H: Hand> ErrorType for SafeHand<H> {
    type Error = SafetyError<H::Error>;
}

impl<H: Hand> Hand for SafeHand<H> {
    fn set_targets(&mut self, targets: HandPositions) -> Result<(), Self::Error> {
        // fingers are the first three; the coupled rotation only has the 0..1 range
        let bad = targets
            .iter()
            .enumerate()
            .find(|(i, t)| !(0.0..=1.0).contains(*t) || (*i < 3 && **t > self.limits.max_grip));
        if let Some((i, t)) = bad {
            return Err(SafetyError::Refused(format!(
                "actuator {i} target {t} is outside 0..={} ",
                if i < 3 { self.limits.max_grip } else { 1.0 }
            )));
        }
        self.inner.set_targets(targets).map_err(SafetyError::Device)
    }

    fn set_torque_limit(&mut self, fraction: f64) -> Result<(), Self::Error> {
        if !(0.0..=self.limits.max_torque).contains(&fraction) {
            return Err(SafetyError::Refused(format!(
                "torque limit {fraction} is outside 0..={}",
                self.limits.max_torque
            )));
        }
        self.inner
            .set_torque_limit(fraction)
            .map_err(SafetyError::Device)
    }

    fn present_positions(&mut self) -> Result<HandPositions, Self::Error> {
        self.inner.present_positions().map_err(SafetyError::Device)
    }
}

pub struct SafeArm<A> {
    inner: A,
    limits: SafetyLimits,
    /// Where the TCP started, read at the first motion command.
    home_mm: Option<[f64; 3]>,
}

impl<A> SafeArm<A> {
    pub fn new(inner: A, limits: SafetyLimits) -> Self {
        Self {
            inner,
            limits,
            home_mm: None,
        }
    }
}

impl<A: Arm> SafeArm<A> {
    fn check_speed(&self, speed: f64) -> Result<(), SafetyError<A::Error>> {
        if speed.is_finite() && speed >= 0.0 && speed <= self.limits.max_arm_speed_mm_s {
            Ok(())
        } else {
            Err(SafetyError::Refused(format!(
                "arm speed {speed} mm/s is outside 0..={}",
                self.limits.max_arm_speed_mm_s
            )))
        }
    }
}

impl<A: Arm> ErrorType for SafeArm<A> {
    type Error = SafetyError<A::Error>;
}

impl<A: Arm> Arm for SafeArm<A> {
    fn tcp_pose(&mut self) -> Result<Pose, Self::Error> {
        self.inner.tcp_pose().map_err(SafetyError::Device)
    }

    fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), Self::Error> {
        self.check_speed(speed_mm_s)?;
        let now = self
            .inner
            .tcp_pose()
            .map_err(SafetyError::Device)?
            .position_mm;
        let home = *self.home_mm.get_or_insert(now);
        for axis in 0..3 {
            let target = now[axis] + offset_mm[axis];
            if (target - home[axis]).abs() > self.limits.workspace_mm[axis] {
                return Err(SafetyError::Refused(format!(
                    "move to {target:.1} mm on axis {axis} leaves the workspace ({} mm from {:.1})",
                    self.limits.workspace_mm[axis], home[axis]
                )));
            }
        }
        self.inner
            .move_linear(offset_mm, speed_mm_s)
            .map_err(SafetyError::Device)
    }

    fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), Self::Error> {
        let speed = velocity_mm_s.iter().map(|v| v * v).sum::<f64>().sqrt();
        self.check_speed(speed)?;
        self.inner
            .move_velocity(velocity_mm_s)
            .map_err(SafetyError::Device)
    }

    fn stop(&mut self) -> Result<(), Self::Error> {
        // stopping is always allowed
        self.inner.stop().map_err(SafetyError::Device)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runner::mocks::{MockArm, MockHand};

    #[test]
    fn a_hand_command_past_the_limits_is_never_sent() {
        let mut inner = MockHand::new();
        inner.expect_set_targets().times(1).returning(|_| Ok(()));
        inner.expect_set_torque_limit().times(0);
        let mut hand = SafeHand::new(inner, SafetyLimits::default());
        assert!(hand.set_targets([0.5, 0.5, 0.5, 1.0]).is_ok());
        let e = hand.set_targets([0.5, 0.99, 0.5, 0.0]).unwrap_err();
        assert_eq!(tmo_hal::Error::kind(&e), ErrorKind::OutOfLimits);
        assert!(e.to_string().contains("actuator 1"), "{e}");
        assert!(hand.set_targets([f64::NAN, 0.5, 0.5, 0.0]).is_err());
        assert!(hand.set_torque_limit(1.5).is_err());
    }

    #[test]
    fn arm_moves_stay_in_the_workspace_and_under_the_speed_limit() {
        let mut inner = MockArm::new();
        inner.expect_tcp_pose().returning(|| {
            Ok(Pose {
                position_mm: [100.0, 0.0, 300.0],
                rotation_rad: [0.0; 3],
            })
        });
        inner
            .expect_move_linear()
            .withf(|o, _| *o == [0.0, 0.0, 120.0])
            .times(1)
            .returning(|_, _| Ok(()));
        inner.expect_move_velocity().times(0);
        inner.expect_stop().times(1).returning(|| Ok(()));
        let mut arm = SafeArm::new(inner, SafetyLimits::default());
        assert!(arm.move_linear([0.0, 0.0, 120.0], 40.0).is_ok());
        let e = arm.move_linear([0.0, 0.0, 300.0], 40.0).unwrap_err();
        assert!(e.to_string().contains("workspace"), "{e}");
        assert!(arm.move_linear([1.0, 0.0, 0.0], 500.0).is_err());
        assert!(arm.move_velocity([0.0, 0.0, 200.0]).is_err());
        assert!(arm.stop().is_ok());
    }
}
