//! Servo and arm motion: latency, speed and acceleration limits, and the servos' encoder
//! counts.

use std::collections::VecDeque;

use tmo_hal::types::{HandPositions, HAND_ACTUATORS};

/// A command that reaches the servos after the bus and firmware latency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ServoCommand {
    Targets(HandPositions),
    TorqueLimit(f64),
}

/// The servos' position encoders: each reads whole counts, `counts_per_range` of them over
/// a finger's range, its grid shifted by its own fraction of a count (each servo's zero is
/// calibrated on its own).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Encoders {
    pub counts_per_range: f64,
    /// Each servo's grid offset, fraction of a count in [0, 1).
    pub phase: HandPositions,
}

impl Encoders {
    /// The position of servo `i`'s count nearest `q`, fraction of the range.
    pub fn nearest_count(&self, i: usize, q: f64) -> f64 {
        let c = self.counts_per_range;
        ((q * c + self.phase[i]).round() - self.phase[i]) / c
    }
}

/// The hand's four position-controlled servos.
#[derive(Debug, Clone)]
pub struct Servos {
    /// Where each servo's motor is (what its encoder reports): on a whole count when the
    /// servos have encoders.
    pub position: HandPositions,
    /// The proportional loop's own state: where the motor would be if it turned smoothly.
    drive: HandPositions,
    encoders: Option<Encoders>,
    /// Where each finger is: it follows its motor through a tendon with free play, so
    /// after a reversal the motor turns through the backlash before the finger moves.
    pub finger: HandPositions,
    backlash: f64,
    pub target: HandPositions,
    pub torque_limit: f64,
    pending: VecDeque<(f64, ServoCommand)>,
    latency_s: f64,
    max_speed_per_s: f64,
    position_time_s: f64,
}

impl Servos {
    pub fn new(
        start: HandPositions,
        torque_limit: f64,
        latency_s: f64,
        max_speed_per_s: f64,
        position_time_s: f64,
    ) -> Self {
        Self {
            position: start,
            drive: start,
            encoders: None,
            finger: start,
            backlash: 0.0,
            target: start,
            torque_limit,
            pending: VecDeque::new(),
            latency_s,
            max_speed_per_s,
            position_time_s,
        }
    }

    /// Free play between motor and finger, fraction of the range.
    pub fn with_backlash(mut self, backlash: f64) -> Self {
        self.backlash = backlash;
        self
    }

    /// Encoders that read whole counts: the goal is rounded to a count, as the hand's
    /// backend sends it, and the shaft moves from count to count. A proportional loop puts
    /// out torque only from its count error, and the gear train's friction holds the shaft
    /// between counts, so it sits on the count nearest the loop's smooth state: a slow move
    /// is a staircase, and a hold does not dither.
    pub fn with_encoders(mut self, encoders: Encoders) -> Self {
        for i in 0..HAND_ACTUATORS {
            self.position[i] = encoders.nearest_count(i, self.drive[i]);
            self.finger[i] = self.position[i];
        }
        self.encoders = Some(encoders);
        self
    }

    pub fn command(&mut self, now_s: f64, command: ServoCommand) {
        self.pending.push_back((now_s + self.latency_s, command));
    }

    /// Advances to `now_s`: applies commands that have arrived, then moves each servo as a
    /// proportional position loop does (speed = error / time constant), at most max speed;
    /// with encoders, the shaft then takes the count nearest the loop's state.
    pub fn step(&mut self, now_s: f64, step_s: f64) {
        while let Some(&(at, cmd)) = self.pending.front() {
            if at > now_s + 1e-12 {
                break;
            }
            self.pending.pop_front();
            match cmd {
                ServoCommand::Targets(t) => self.target = t,
                ServoCommand::TorqueLimit(l) => self.torque_limit = l,
            }
        }
        let max_move = self.max_speed_per_s * step_s;
        // Exact for the linear part: the error decays by exp(-dt / tau) per step.
        let gain = 1.0 - (-step_s / self.position_time_s).exp();
        for i in 0..HAND_ACTUATORS {
            // The driver caps a goal to the range, then sends the count nearest it (which
            // may lie a fraction of a count outside: each servo's grid has its own zero).
            let goal = match &self.encoders {
                Some(e) => e.nearest_count(i, self.target[i].clamp(0.0, 1.0)),
                None => self.target[i],
            };
            let d = goal - self.drive[i];
            self.drive[i] += (d * gain).clamp(-max_move, max_move);
            self.position[i] = match &self.encoders {
                Some(e) => e.nearest_count(i, self.drive[i]),
                None => self.drive[i],
            };
            let half = 0.5 * self.backlash;
            self.finger[i] = self.finger[i].clamp(self.position[i] - half, self.position[i] + half);
        }
    }
}

/// A motion command as the arm's controller receives it; a linear move's target is taken
/// from where the arm is when the command starts (URScript computes it on the controller).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArmCommand {
    Linear {
        offset_mm: [f64; 3],
        speed_mm_s: f64,
    },
    Velocity([f64; 3]),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArmMotion {
    Hold,
    Linear {
        target_mm: [f64; 3],
        speed_mm_s: f64,
    },
    Velocity([f64; 3]),
}

/// The arm's tool centre point, moved with bounded acceleration.
#[derive(Debug, Clone)]
pub struct ArmState {
    pub position_mm: [f64; 3],
    pub velocity_mm_s: [f64; 3],
    pub acceleration_mm_s2: [f64; 3],
    pub motion: ArmMotion,
    max_acceleration: f64,
    pending: VecDeque<(f64, ArmCommand)>,
    latency_s: f64,
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

impl ArmState {
    pub fn new(position_mm: [f64; 3], max_acceleration: f64) -> Self {
        Self {
            position_mm,
            velocity_mm_s: [0.0; 3],
            acceleration_mm_s2: [0.0; 3],
            motion: ArmMotion::Hold,
            max_acceleration,
            pending: VecDeque::new(),
            latency_s: 0.0,
        }
    }

    /// Delay from a command leaving the host to the controller acting on it, s.
    pub fn with_latency(mut self, latency_s: f64) -> Self {
        self.latency_s = latency_s;
        self
    }

    pub fn command(&mut self, now_s: f64, command: ArmCommand) {
        self.pending.push_back((now_s + self.latency_s, command));
    }

    /// Starts the commands that have reached the controller by `now_s`.
    pub fn receive(&mut self, now_s: f64) {
        while let Some(&(at, cmd)) = self.pending.front() {
            if at > now_s + 1e-12 {
                break;
            }
            self.pending.pop_front();
            self.motion = match cmd {
                ArmCommand::Linear {
                    offset_mm,
                    speed_mm_s,
                } => ArmMotion::Linear {
                    target_mm: [0, 1, 2].map(|i| self.position_mm[i] + offset_mm[i]),
                    speed_mm_s,
                },
                ArmCommand::Velocity(v) => ArmMotion::Velocity(v),
            };
        }
    }

    pub fn step(&mut self, step_s: f64) {
        let desired = match self.motion {
            ArmMotion::Hold => [0.0; 3],
            ArmMotion::Velocity(v) => v,
            ArmMotion::Linear {
                target_mm,
                speed_mm_s,
            } => {
                let d = [0, 1, 2].map(|i| target_mm[i] - self.position_mm[i]);
                let dist = norm(d);
                if dist < 1e-3 && norm(self.velocity_mm_s) < self.max_acceleration * step_s {
                    self.position_mm = target_mm;
                    self.velocity_mm_s = [0.0; 3];
                    self.acceleration_mm_s2 = [0.0; 3];
                    self.motion = ArmMotion::Hold;
                    return;
                }
                // Decelerate so as to stop at the target.
                let speed = speed_mm_s.min((2.0 * self.max_acceleration * dist).sqrt());
                d.map(|x| x / dist.max(1e-12) * speed)
            }
        };
        let dv = [0, 1, 2].map(|i| desired[i] - self.velocity_mm_s[i]);
        let dv_norm = norm(dv);
        let max_dv = self.max_acceleration * step_s;
        let scale = if dv_norm > max_dv {
            max_dv / dv_norm
        } else {
            1.0
        };
        for (i, dv) in dv.iter().enumerate() {
            let v0 = self.velocity_mm_s[i];
            let v1 = v0 + dv * scale;
            self.acceleration_mm_s2[i] = (v1 - v0) / step_s;
            self.position_mm[i] += 0.5 * (v0 + v1) * step_s;
            self.velocity_mm_s[i] = v1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn servo_waits_for_latency_then_moves_at_max_speed() {
        let mut s = Servos::new([0.0; 4], 1.0, 0.008, 2.0, 0.05);
        s.command(0.0, ServoCommand::Targets([1.0, 0.0, 0.0, 0.0]));
        let mut t = 0.0;
        for _ in 0..7 {
            t += 0.001;
            s.step(t, 0.001);
        }
        assert_eq!(s.position[0], 0.0);
        for _ in 0..11 {
            t += 0.001;
            s.step(t, 0.001);
        }
        assert!((s.position[0] - 0.022).abs() < 1e-9, "{}", s.position[0]);
    }

    #[test]
    fn after_a_reversal_the_finger_waits_for_the_backlash() {
        let mut s = Servos::new([0.5; 4], 1.0, 0.0, 1.0, 0.001).with_backlash(0.02);
        let mut t = 0.0;
        let mut go = |s: &mut Servos, q: f64| {
            s.command(t, ServoCommand::Targets([q; 4]));
            for _ in 0..100 {
                t += 0.001;
                s.step(t, 0.001);
            }
        };
        go(&mut s, 0.45);
        assert!(
            (s.finger[0] - 0.46).abs() < 1e-9,
            "opening drags the finger behind"
        );
        go(&mut s, 0.47);
        assert!(
            (s.finger[0] - 0.46).abs() < 1e-9,
            "inside the free play nothing moves"
        );
        go(&mut s, 0.50);
        assert!((s.finger[0] - 0.49).abs() < 1e-9);
    }

    #[test]
    fn servo_settles_on_a_small_step_with_its_time_constant() {
        let mut s = Servos::new([0.0; 4], 1.0, 0.0, 2.0, 0.05);
        s.command(0.0, ServoCommand::Targets([0.02, 0.0, 0.0, 0.0]));
        let mut t = 0.0;
        for _ in 0..50 {
            t += 0.001;
            s.step(t, 0.001);
        }
        let done = s.position[0] / 0.02;
        assert!((done - (1.0 - (-1f64).exp())).abs() < 0.02, "{done}");
    }

    fn ramp_down(s: &mut Servos, speed_per_s: f64, seconds: f64) -> Vec<HandPositions> {
        let (dt, start) = (0.001, s.target);
        (1..=(seconds / dt).round() as usize)
            .map(|k| {
                let t = k as f64 * dt;
                s.command(t, ServoCommand::Targets(start.map(|q| q - speed_per_s * t)));
                s.step(t, dt);
                s.position
            })
            .collect()
    }

    #[test]
    fn with_encoders_a_slow_release_is_a_staircase_of_single_counts_on_each_servos_grid() {
        let counts = 2866.5;
        let phase = [0.0, 0.25, 0.5, 0.75];
        let mut s = Servos::new([0.5; 4], 1.0, 0.0, 2.0, 0.05).with_encoders(Encoders {
            counts_per_range: counts,
            phase,
        });
        // the paper preset's release, 0.01 of the range a second: a count every 34.9 ms
        let path = ramp_down(&mut s, 0.01, 1.0);
        for i in 0..4 {
            let mut steps = Vec::new();
            for (k, w) in path.windows(2).enumerate() {
                let moved = (w[1][i] - w[0][i]) * counts;
                if moved.abs() > 1e-9 {
                    assert!(
                        (moved + 1.0).abs() < 1e-6,
                        "a step of one count down: {moved}"
                    );
                    steps.push(k);
                }
                // always on the servo's own grid
                let on_grid = w[1][i] * counts + phase[i];
                assert!((on_grid - on_grid.round()).abs() < 1e-6);
            }
            let gaps: Vec<usize> = steps.windows(2).map(|g| g[1] - g[0]).collect();
            assert!(gaps.len() > 20, "{gaps:?}");
            // once the loop's lag has built up (a few time constants), one count every
            // 1 / (0.01 x 2866.5) = 34.9 ms
            let steady = &gaps[5..];
            assert!(steady.iter().all(|&g| (34..=36).contains(&g)), "{gaps:?}");
            let mean = steady.iter().sum::<usize>() as f64 / steady.len() as f64;
            assert!((mean - 34.9).abs() < 0.3, "{mean}");
        }
        // each servo's steps come at its own phase
        let first_step = |i: usize| {
            path.windows(2)
                .position(|w| (w[1][i] - w[0][i]).abs() > 1e-9)
                .unwrap()
        };
        let firsts: Vec<usize> = (0..4).map(first_step).collect();
        assert!(firsts.windows(2).all(|w| w[0] != w[1]), "{firsts:?}");
    }

    #[test]
    fn without_encoders_the_same_release_is_smooth_and_with_them_a_hold_is_still() {
        let mut smooth = Servos::new([0.5; 4], 1.0, 0.0, 2.0, 0.05);
        let path = ramp_down(&mut smooth, 0.01, 0.5);
        assert!(path.windows(2).skip(100).all(|w| w[1][0] < w[0][0]));
        let encoders = Encoders {
            counts_per_range: 2866.5,
            phase: [0.3; 4],
        };
        let mut held = Servos::new([0.5; 4], 1.0, 0.0, 2.0, 0.05).with_encoders(encoders);
        let start = held.position;
        let mut t = 0.0;
        for _ in 0..2000 {
            t += 0.001;
            held.step(t, 0.001);
            assert_eq!(held.position, start, "no dither while holding");
        }
        assert!((start[0] - 0.5).abs() <= 0.5 / 2866.5 + 1e-12);
    }

    #[test]
    fn linear_move_ends_on_target() {
        let mut a = ArmState::new([0.0; 3], 1000.0);
        a.motion = ArmMotion::Linear {
            target_mm: [0.0, 0.0, 10.0],
            speed_mm_s: 20.0,
        };
        for _ in 0..2000 {
            a.step(0.001);
        }
        assert_eq!(a.motion, ArmMotion::Hold);
        assert_eq!(a.position_mm, [0.0, 0.0, 10.0]);
    }

    #[test]
    fn arm_waits_for_its_latency_and_moves_from_where_it_is_then() {
        let mut a = ArmState::new([0.0; 3], 1000.0).with_latency(0.05);
        a.motion = ArmMotion::Velocity([0.0, 0.0, -5.0]);
        let mut t = 0.0;
        let mut run = |a: &mut ArmState, steps: usize| {
            for _ in 0..steps {
                t += 0.001;
                a.receive(t);
                a.step(0.001);
            }
        };
        run(&mut a, 100);
        a.command(
            0.1,
            ArmCommand::Linear {
                offset_mm: [0.0, 0.0, 1.5],
                speed_mm_s: 20.0,
            },
        );
        run(&mut a, 49);
        // still retracting: the command has not reached the controller
        assert_eq!(a.velocity_mm_s[2], -5.0);
        let started_at = a.position_mm[2];
        run(&mut a, 1);
        assert!(matches!(a.motion, ArmMotion::Linear { .. }));
        run(&mut a, 2000);
        assert!(
            (a.position_mm[2] - (started_at + 1.5)).abs() < 0.02,
            "{:?}",
            a.position_mm
        );
    }

    #[test]
    fn velocity_move_ramps_up_with_bounded_acceleration() {
        let mut a = ArmState::new([0.0; 3], 1000.0);
        a.motion = ArmMotion::Velocity([0.0, 0.0, 17.0]);
        a.step(0.001);
        assert!((a.velocity_mm_s[2] - 1.0).abs() < 1e-9);
        for _ in 0..100 {
            a.step(0.001);
        }
        assert!((a.velocity_mm_s[2] - 17.0).abs() < 1e-9);
    }
}
