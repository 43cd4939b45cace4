//! Wiring faults an emulator can be started with (`frictionlab
//! device-emulator --flip-encoder --flip-motor --encoder-scale X`), the
//! classic faults of a device's first contact, so the tests show that the
//! bring-up check ([`super::check`]) catches each (issue 63). Pure.

/// How an emulated device is wired wrong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Miswiring {
    /// The encoder counts the other way.
    pub flip_encoder: bool,
    /// The motor turns the other way.
    pub flip_motor: bool,
    /// The encoder counts this many times as many steps per metre (or per
    /// turn) as the device states: 1 is right.
    pub encoder_scale: f64,
}

impl Default for Miswiring {
    fn default() -> Self {
        Miswiring {
            flip_encoder: false,
            flip_motor: false,
            encoder_scale: 1.0,
        }
    }
}

impl Miswiring {
    /// What the encoder reports for a true displacement of `x` (from where
    /// it counts from).
    #[must_use]
    pub fn encoder(&self, x: f64) -> f64 {
        let sign = if self.flip_encoder { -1.0 } else { 1.0 };
        sign * self.encoder_scale * x
    }

    /// The force (or torque) the motor applies when told `f`.
    #[must_use]
    pub fn motor(&self, f: f64) -> f64 {
        if self.flip_motor { -f } else { f }
    }

    /// Why the scale cannot be, if it cannot: a scale that is not a
    /// number above 0.
    #[must_use]
    pub fn problem(&self) -> Option<&'static str> {
        (!(self.encoder_scale.is_finite() && self.encoder_scale > 0.0))
            .then_some("the encoder scale must be a number above 0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_fault_changes_only_what_it_names() {
        let right = Miswiring::default();
        assert_eq!((right.encoder(0.01), right.motor(2.0)), (0.01, 2.0));
        let flipped = Miswiring {
            flip_encoder: true,
            ..right
        };
        assert_eq!((flipped.encoder(0.01), flipped.motor(2.0)), (-0.01, 2.0));
        let motor = Miswiring {
            flip_motor: true,
            ..right
        };
        assert_eq!((motor.encoder(0.01), motor.motor(2.0)), (0.01, -2.0));
        let scaled = Miswiring {
            encoder_scale: 2.0,
            ..right
        };
        assert_eq!(scaled.encoder(0.01), 0.02);
        assert!(scaled.problem().is_none());
        assert!(
            Miswiring {
                encoder_scale: 0.0,
                ..right
            }
            .problem()
            .is_some()
        );
    }
}
