//! Fixed-step timing: the simulation advances by the scene's step only,
//! however long frames take.

/// Turns real time into a number of fixed steps: real seconds × speed go
/// into an accumulator, and every whole step in it is taken. Frame time
/// never reaches the engine, so the simulation is the same at any frame rate.
#[derive(Clone, Debug)]
pub struct FixedStepper {
    dt: f64,
    accumulator: f64,
    max_steps: u32,
}

/// Fraction of a step forgiven when counting whole steps: 0.1 s at 60 Hz is
/// 6 steps even though 0.1 / (1/60) rounds to 5.9999….
const ROUNDING: f64 = 1e-6;

impl FixedStepper {
    /// A stepper for steps of `dt` seconds that takes at most `max_steps`
    /// per frame (after a stall, the backlog beyond that is dropped rather
    /// than simulated in one long frame that would stall again).
    pub fn new(dt: f64, max_steps: u32) -> Self {
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 1.0 / 60.0 };
        Self { dt, accumulator: 0.0, max_steps: max_steps.max(1) }
    }

    /// Adds `real_seconds` of wall time at `speed` (1 real time, 0.5 half
    /// speed) and returns how many steps to take now.
    pub fn advance(&mut self, real_seconds: f64, speed: f64) -> u32 {
        if real_seconds.is_finite() && real_seconds > 0.0 && speed.is_finite() && speed > 0.0 {
            self.accumulator += real_seconds * speed;
        }
        let whole = (self.accumulator / self.dt + ROUNDING).floor();
        if whole > self.max_steps as f64 {
            self.accumulator = 0.0;
            return self.max_steps;
        }
        self.accumulator = (self.accumulator - whole * self.dt).max(0.0);
        whole as u32
    }

    /// Forgets the time not yet simulated (on pause and restart).
    pub fn reset(&mut self) {
        self.accumulator = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tenth_of_a_second_is_six_steps_at_60_hz_and_three_at_half_speed() {
        let dt = (1.0f32 / 60.0) as f64; // scenes keep their step as f32
        assert_eq!(FixedStepper::new(dt, 100).advance(0.1, 1.0), 6);
        assert_eq!(FixedStepper::new(dt, 100).advance(0.1, 0.5), 3);
        assert_eq!(FixedStepper::new(dt, 100).advance(0.1, 0.25), 1);
    }

    #[test]
    fn steps_do_not_depend_on_the_frame_rate() {
        for frames in [7, 60, 144, 1000] {
            let mut s = FixedStepper::new(1.0 / 60.0, 100);
            let total: u32 = (0..frames).map(|_| s.advance(1.0 / frames as f64, 1.0)).sum();
            assert!((59..=60).contains(&total), "{frames} frames: {total} steps");
        }
        // The remainder carries over: 0.4 steps per frame, 10 frames, 4 steps.
        let mut s = FixedStepper::new(0.01, 100);
        assert_eq!((0..10).map(|_| s.advance(0.004, 1.0)).sum::<u32>(), 4);
    }

    #[test]
    fn a_stall_is_capped_and_bad_input_adds_nothing() {
        let mut s = FixedStepper::new(1.0 / 60.0, 8);
        assert_eq!(s.advance(5.0, 1.0), 8);
        assert_eq!(s.advance(0.0, 1.0), 0, "the backlog was dropped");
        assert_eq!(s.advance(f64::NAN, 1.0), 0);
        assert_eq!(s.advance(1.0, -1.0), 0);
        assert_eq!(FixedStepper::new(0.0, 8).advance(0.1, 1.0), 6, "a bad step falls back to 60 Hz");
    }
}
