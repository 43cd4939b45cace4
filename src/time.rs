//! Session time in whole nanoseconds (issue 42).
//!
//! A session's clock counts whole ticks of its loop: 200,000 ns at 5 kHz,
//! 1,000,000 ns at 1 kHz, both exact. [`Time`] holds a session time, or a
//! duration, as an integer number of nanoseconds, so adding a duration to
//! a time is exact, a deadline is an integer compared with integers, and a
//! trial that starts at another moment lasts exactly as many ticks.
//! Seconds are computed from it only at the edges: [`Time::secs`] divides
//! once, so a whole number of ticks is written as the decimal it is
//! (`2.0002`, never `2.0001999999998126`).
//!
//! In files a time is a number of seconds: [`Time`] serialises as
//! [`Time::secs`] and reads a number of seconds back to the nearest
//! nanosecond (so a log of format 1, whose times were float sums, reads
//! to within a nanosecond of its ticks; [`Time::ceil_to`] puts such a time
//! on the tick grid).

use std::fmt;
use std::ops::{Add, AddAssign, Sub};

use schemars::JsonSchema;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Nanoseconds per second.
const NS_PER_S: u64 = 1_000_000_000;

/// The longest time a protocol may give, s: one day. Every duration a
/// protocol holds (an exploration, a break, a time limit) is checked
/// against it, so none comes near [`Time`]'s range (about 584 years) even
/// summed over the largest plan.
pub const MAX_PROTOCOL_S: f64 = 86_400.0;

/// A session time or a duration: whole nanoseconds (module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Time(u64);

impl Time {
    /// Zero.
    pub const ZERO: Time = Time(0);
    /// The largest time (about 584 years): what a sum saturates at.
    pub const MAX: Time = Time(u64::MAX);

    /// `ns` nanoseconds.
    #[must_use]
    pub const fn from_ns(ns: u64) -> Self {
        Time(ns)
    }

    /// Whole seconds.
    #[must_use]
    pub const fn from_whole_secs(s: u64) -> Self {
        Time(s.saturating_mul(NS_PER_S))
    }

    /// The nearest whole nanosecond to `s` seconds; `None` for a negative,
    /// not finite or too large number (the range is [`Time::MAX`]).
    #[must_use]
    pub fn from_secs(s: f64) -> Option<Self> {
        let ns = (s * 1e9).round();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "checked to be within 0..u64::MAX first"
        )]
        (ns.is_finite() && ns >= 0.0 && ns < u64::MAX as f64).then_some(Time(ns as u64))
    }

    /// [`Time::from_secs`], with a number out of range saturated: a
    /// negative or NaN one at zero, a too large one at [`Time::MAX`]. For
    /// durations already checked (protocols are, at load).
    #[must_use]
    pub fn from_secs_saturating(s: f64) -> Self {
        Time::from_secs(s).unwrap_or(if s > 0.0 { Time::MAX } else { Time::ZERO })
    }

    /// The period of a loop at `rate_hz`, to the nearest nanosecond (exact
    /// for 1 kHz, 5 kHz and 10 kHz); at least 1 ns.
    #[must_use]
    pub fn period(rate_hz: f64) -> Self {
        Time::from_secs_saturating(1.0 / rate_hz).max(Time(1))
    }

    /// Nanoseconds.
    #[must_use]
    pub const fn ns(self) -> u64 {
        self.0
    }

    /// Seconds: the nanoseconds divided once, so a whole number of
    /// nanoseconds reads as the nearest double to its decimal (exact below
    /// 2^53 ns, about 104 days).
    #[must_use]
    pub fn secs(self) -> f64 {
        self.0 as f64 / 1e9
    }

    /// `self + other`, `None` on overflow.
    #[must_use]
    pub const fn checked_add(self, other: Time) -> Option<Time> {
        match self.0.checked_add(other.0) {
            Some(ns) => Some(Time(ns)),
            None => None,
        }
    }

    /// How many whole `tick`s fit in `self` (0 for a zero tick).
    #[must_use]
    pub const fn ticks(self, tick: Time) -> u64 {
        match self.0.checked_div(tick.0) {
            Some(n) => n,
            None => 0,
        }
    }

    /// The first multiple of `tick` at or after `self` (itself for a zero
    /// tick): a time read from an old log, put on the tick grid without
    /// going back.
    #[must_use]
    pub const fn ceil_to(self, tick: Time) -> Time {
        if tick.0 == 0 {
            return self;
        }
        let rest = self.0 % tick.0;
        if rest == 0 {
            self
        } else {
            Time(self.0.saturating_add(tick.0 - rest))
        }
    }

    /// The nearest multiple of `tick` to `self` (itself for a zero tick).
    #[must_use]
    pub const fn round_to(self, tick: Time) -> Time {
        if tick.0 == 0 {
            return self;
        }
        let rest = self.0 % tick.0;
        if rest.saturating_mul(2) >= tick.0 {
            Time(self.0.saturating_add(tick.0 - rest))
        } else {
            Time(self.0 - rest)
        }
    }

    /// `self` times `n`, saturating.
    #[must_use]
    pub const fn times(self, n: u64) -> Time {
        Time(self.0.saturating_mul(n))
    }
}

/// Saturating: a sum past [`Time::MAX`] stays there (a protocol's times
/// are checked far below it, so only a deadline "never" reaches it).
impl Add for Time {
    type Output = Time;
    fn add(self, other: Time) -> Time {
        Time(self.0.saturating_add(other.0))
    }
}

impl AddAssign for Time {
    fn add_assign(&mut self, other: Time) {
        *self = *self + other;
    }
}

/// Saturating: a time before another is zero after it.
impl Sub for Time {
    type Output = Time;
    fn sub(self, other: Time) -> Time {
        Time(self.0.saturating_sub(other.0))
    }
}

impl fmt::Display for Time {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} s", self.secs())
    }
}

impl Serialize for Time {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(self.secs())
    }
}

impl<'de> Deserialize<'de> for Time {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = f64::deserialize(d)?;
        Time::from_secs(s).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "{s} is not a time: a number of seconds from 0 to about 584 years"
            ))
        })
    }
}

impl JsonSchema for Time {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Seconds".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "A time in seconds: a whole number of nanoseconds (in a format 2 log, of the session's ticks).",
            "type": "number",
            "minimum": 0.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_ticks_read_as_their_decimals() {
        let tick = Time::period(5000.0);
        assert_eq!(tick, Time::from_ns(200_000));
        assert_eq!(Time::period(1000.0), Time::from_ns(1_000_000));
        let mut t = Time::ZERO;
        for _ in 0..10_001 {
            t += tick;
        }
        assert_eq!(t.secs(), 2.0002);
        assert_eq!(t.secs().to_string(), "2.0002");
        // Every tick of an hour at 5 kHz prints as its decimal (the
        // shortest text that reads back is at most 10 digits).
        for k in (0..18_000_000_u64).step_by(7919) {
            let text = tick.times(k).secs().to_string();
            assert!(text.len() <= 11, "{text}");
        }
    }

    #[test]
    fn a_duration_lasts_as_many_ticks_wherever_it_starts() {
        let tick = Time::period(5000.0);
        let d = Time::from_secs_saturating(2.0);
        for k in [0_u64, 1, 30_001, 123_456_789] {
            let start = tick.times(k);
            let end = start + d;
            assert_eq!((end - start).ticks(tick), 10_000);
        }
    }

    #[test]
    fn seconds_read_back_to_the_nearest_nanosecond() {
        assert_eq!(
            Time::from_secs(2.000_199_999_999_812_6),
            Some(Time::from_ns(2_000_200_000))
        );
        assert_eq!(Time::from_secs(-1.0), None);
        assert_eq!(Time::from_secs(f64::NAN), None);
        assert_eq!(Time::from_secs(1e300), None);
        assert_eq!(Time::from_secs_saturating(1e300), Time::MAX);
        assert_eq!(Time::from_secs_saturating(-3.0), Time::ZERO);
        let t: Time = serde_json::from_str("25.528000000008216").unwrap_or_default();
        assert_eq!(t, Time::from_ns(25_528_000_000));
        assert_eq!(serde_json::to_string(&t).unwrap_or_default(), "25.528");
        assert!(serde_json::from_str::<Time>("-0.5").is_err());
    }

    #[test]
    fn times_go_onto_the_tick_grid_without_going_back() {
        let tick = Time::from_ns(200_000);
        assert_eq!(Time::from_ns(400_001).ceil_to(tick), Time::from_ns(600_000));
        assert_eq!(Time::from_ns(400_000).ceil_to(tick), Time::from_ns(400_000));
        assert_eq!(
            Time::from_ns(499_999).round_to(tick),
            Time::from_ns(400_000)
        );
        assert_eq!(
            Time::from_ns(500_000).round_to(tick),
            Time::from_ns(600_000)
        );
        assert_eq!(Time::MAX.ceil_to(tick), Time::MAX);
        assert_eq!(Time::ZERO - tick, Time::ZERO);
        assert_eq!(Time::MAX + tick, Time::MAX);
    }
}
