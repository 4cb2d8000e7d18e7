//! Keeping the simulation in pace with the wall clock ([`super::ViewerOptions::real_time`]): the fixed-step
//! accumulator of game loops ("Fix Your Timestep", Fiedler 2004). Each frame adds the wall time since the last
//! one, the simulation takes as many whole steps as fit, and the remainder waits for the next frame; a frame
//! adds at most [`super::MAX_LAG_FRAMES`] frames' worth, so a machine too slow for the scene runs it in slow
//! motion instead of falling ever further behind (the "spiral of death").

use super::MAX_LAG_FRAMES;

/// Wall time not yet simulated.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Pacer {
    lag: f64,
}

impl Pacer {
    /// The simulated time this frame advances \[s\]: a whole number of steps `dt` \[s\], for `wall` \[s\] since
    /// the last frame (capped at [`MAX_LAG_FRAMES`] × `frame_time` \[s\]).
    pub(super) fn span(&mut self, wall: f64, frame_time: f64, dt: f64) -> f64 {
        self.lag += wall.clamp(0.0, MAX_LAG_FRAMES * frame_time);
        let steps = (self.lag / dt).floor();
        self.lag -= steps * dt;
        steps * dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_steps_with_the_remainder_carried() {
        let (frame, dt) = (1.0 / 60.0, 2e-4);
        let mut p = Pacer::default();
        let mut simulated = 0.0;
        let mut wall = 0.0;
        // Uneven frames, none over the cap: over many frames the simulation keeps pace to within one step.
        for k in 0..600 {
            let w = frame * (0.5 + (k % 7) as f64 * 0.25);
            let span = p.span(w, frame, dt);
            let steps = span / dt;
            assert!((steps - steps.round()).abs() < 1e-6, "frame {k}: {steps} steps is not a whole number");
            simulated += span;
            wall += w;
            assert!(wall - simulated >= -1e-9 && wall - simulated < dt + 1e-9, "frame {k}: {wall} vs {simulated}");
        }
    }

    #[test]
    fn a_long_frame_catches_up_at_most_the_cap() {
        let (frame, dt) = (1.0 / 60.0, 1e-3);
        let mut p = Pacer::default();
        let span = p.span(1.0, frame, dt);
        assert!(span <= MAX_LAG_FRAMES * frame && span > MAX_LAG_FRAMES * frame - dt, "{span}");
        // Steps larger than a frame: no step until enough wall time has gathered.
        let mut p = Pacer::default();
        let spans: Vec<f64> = (0..4).map(|_| p.span(frame, frame, 1.0 / 30.0)).collect();
        assert_eq!(spans.iter().filter(|&&s| s > 0.0).count(), 2, "{spans:?}");
        assert!(p.span(-1.0, frame, dt) == 0.0, "a clock going back advances nothing");
    }
}
