//! The device-role traits. Each is small and does I/O only; constructors live on backends.

use crate::error::ErrorType;
use crate::types::{HandPositions, MarkerSample, PinFrame, Pose};

/// A tactile fingertip camera streaming pin positions asynchronously at its own rate.
pub trait TactileSensor: ErrorType {
    /// The next frame that has arrived and not yet been read, or `None` if there is none
    /// yet. Never blocks: waiting is the [`Clock`]'s job.
    fn next_frame(&mut self) -> Result<Option<PinFrame>, Self::Error>;
}

/// The hand's actuators, positions normalised to 0.0 (open) .. 1.0 (closed).
pub trait Hand: ErrorType {
    /// Sets goal positions of all four actuators at once.
    fn set_targets(&mut self, targets: HandPositions) -> Result<(), Self::Error>;
    /// Limits finger torque (current) to this fraction, 0.0..=1.0, of the servos' maximum.
    fn set_torque_limit(&mut self, fraction: f64) -> Result<(), Self::Error>;
    /// Present positions as the servos report them.
    fn present_positions(&mut self) -> Result<HandPositions, Self::Error>;
}

/// The arm carrying the hand (a UR5 on the real rig).
pub trait Arm: ErrorType {
    /// Present tool-centre-point pose.
    fn tcp_pose(&mut self) -> Result<Pose, Self::Error>;
    /// Moves the TCP in a straight line by `offset_mm` at `speed_mm_s` (URScript `movel`).
    fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), Self::Error>;
    /// Moves the TCP at a constant velocity until told otherwise (URScript `speedl`).
    fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), Self::Error>;
    /// Decelerates to a stop (URScript `stopl`).
    fn stop(&mut self) -> Result<(), Self::Error>;
}

/// The camera tracking ArUco markers on the object and the hand.
pub trait MarkerTracker: ErrorType {
    /// The next sample that has arrived and not yet been read, or `None`. Never blocks.
    fn next_sample(&mut self) -> Result<Option<MarkerSample>, Self::Error>;
}

/// The rig's clock. The runner reads time and waits only through it, so a simulator or a
/// replay can run on a virtual clock.
pub trait Clock {
    /// Seconds since the rig started.
    fn now_s(&self) -> f64;
    /// Returns once the clock reads at least `time_s`.
    fn sleep_until(&mut self, time_s: f64);
    /// Waits `duration_s` seconds.
    fn sleep(&mut self, duration_s: f64) {
        let target = self.now_s() + duration_s;
        self.sleep_until(target);
    }
    /// Returns once the clock reads at least `time_s`, or earlier as soon as a device has new
    /// input (a frame) to read. A clock that cannot tell, such as a virtual one whose devices
    /// produce input only as it advances, sleeps until `time_s`.
    fn wait_for_input_until(&mut self, time_s: f64) {
        self.sleep_until(time_s);
    }
}

impl<T: TactileSensor + ?Sized> TactileSensor for &mut T {
    fn next_frame(&mut self) -> Result<Option<PinFrame>, Self::Error> {
        T::next_frame(self)
    }
}

impl<T: Hand + ?Sized> Hand for &mut T {
    fn set_targets(&mut self, targets: HandPositions) -> Result<(), Self::Error> {
        T::set_targets(self, targets)
    }
    fn set_torque_limit(&mut self, fraction: f64) -> Result<(), Self::Error> {
        T::set_torque_limit(self, fraction)
    }
    fn present_positions(&mut self) -> Result<HandPositions, Self::Error> {
        T::present_positions(self)
    }
}

impl<T: Arm + ?Sized> Arm for &mut T {
    fn tcp_pose(&mut self) -> Result<Pose, Self::Error> {
        T::tcp_pose(self)
    }
    fn move_linear(&mut self, offset_mm: [f64; 3], speed_mm_s: f64) -> Result<(), Self::Error> {
        T::move_linear(self, offset_mm, speed_mm_s)
    }
    fn move_velocity(&mut self, velocity_mm_s: [f64; 3]) -> Result<(), Self::Error> {
        T::move_velocity(self, velocity_mm_s)
    }
    fn stop(&mut self) -> Result<(), Self::Error> {
        T::stop(self)
    }
}

impl<T: MarkerTracker + ?Sized> MarkerTracker for &mut T {
    fn next_sample(&mut self) -> Result<Option<MarkerSample>, Self::Error> {
        T::next_sample(self)
    }
}

impl<T: Clock + ?Sized> Clock for &mut T {
    fn now_s(&self) -> f64 {
        T::now_s(self)
    }
    fn sleep_until(&mut self, time_s: f64) {
        T::sleep_until(self, time_s)
    }
    fn wait_for_input_until(&mut self, time_s: f64) {
        T::wait_for_input_until(self, time_s)
    }
}
