//! The model's unit of time (`time = hours;`): the unit its derivatives
//! are per, so the unit of every rate, step and sample period reported
//! for it. Nothing is rescaled: a chemostat written in hours is designed,
//! certified and simulated in hours, and its figures are printed in hours.

use serde::{Deserialize, Serialize};

/// The unit of the model's time: `der x = …` is dx/dt with t in this unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeUnit {
    /// Seconds (the default when a model declares no unit).
    #[default]
    Seconds,
    /// Milliseconds.
    Milliseconds,
    /// Minutes.
    Minutes,
    /// Hours.
    Hours,
    /// Days.
    Days,
}

impl TimeUnit {
    /// Every unit, in the order the error message lists them.
    pub const ALL: [TimeUnit; 5] = [
        TimeUnit::Seconds,
        TimeUnit::Milliseconds,
        TimeUnit::Minutes,
        TimeUnit::Hours,
        TimeUnit::Days,
    ];

    /// The unit a word of the language names (`s`, `second`, `seconds`,
    /// `ms`, `min`, `minutes`, `h`, `hours`, `d`, `days`, …).
    pub fn from_word(w: &str) -> Option<TimeUnit> {
        TimeUnit::ALL
            .into_iter()
            .find(|u| w == u.symbol() || w == u.singular() || w == u.plural())
    }

    /// Whether this is the default unit (seconds): reports leave it out.
    pub fn is_seconds(&self) -> bool {
        *self == TimeUnit::Seconds
    }

    /// The unit's symbol: s, ms, min, h, d.
    pub fn symbol(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "s",
            TimeUnit::Milliseconds => "ms",
            TimeUnit::Minutes => "min",
            TimeUnit::Hours => "h",
            TimeUnit::Days => "d",
        }
    }

    /// The unit's name in the singular: "a rate per hour".
    pub fn singular(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "second",
            TimeUnit::Milliseconds => "millisecond",
            TimeUnit::Minutes => "minute",
            TimeUnit::Hours => "hour",
            TimeUnit::Days => "day",
        }
    }

    /// The unit's name in the plural: "a period in hours".
    pub fn plural(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "seconds",
            TimeUnit::Milliseconds => "milliseconds",
            TimeUnit::Minutes => "minutes",
            TimeUnit::Hours => "hours",
            TimeUnit::Days => "days",
        }
    }

    /// A duration `t` in this unit, three significant digits: "1.52 ms",
    /// "13.9 us" in seconds (SI prefixes, as every report of a model in
    /// seconds has always printed them); "0.0933 h", "2.50e-5 h" in any
    /// other unit.
    pub fn duration(self, t: f64) -> String {
        if self != TimeUnit::Seconds {
            return format!("{} {}", crate::diagnostic::fmt_sig(t, 3), self.symbol());
        }
        let (v, unit) = if t >= 1.0 {
            (t, "s")
        } else if t >= 1e-3 {
            (t * 1e3, "ms")
        } else if t >= 1e-6 {
            (t * 1e6, "us")
        } else {
            (t * 1e9, "ns")
        };
        format!("{} {unit}", crate::diagnostic::fmt_sig(v, 3))
    }

    /// "h = 1e-4 s (10 kHz)" in seconds, "h = 1e-2 h (100 per hour)" in any
    /// other unit: a sample period and its rate, the shortest round-tripping
    /// form of h; the one wording of the solver's reports and the generated
    /// code's comments.
    pub fn describe_period(self, h: f64) -> String {
        let f = 1.0 / h;
        let (v, rate) = match self {
            TimeUnit::Seconds if f >= 1e6 => (f / 1e6, "MHz".to_string()),
            TimeUnit::Seconds if f >= 1e3 => (f / 1e3, "kHz".to_string()),
            TimeUnit::Seconds => (f, "Hz".to_string()),
            u => (f, format!("per {}", u.singular())),
        };
        // Four decimals in the usual range, four significant digits beyond it
        // (never a 300-digit number for a huge h).
        let v = if (1e-3..1e5).contains(&v) {
            let v = format!("{v:.4}");
            v.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            crate::diagnostic::fmt_sig(v, 4)
        };
        format!("h = {h:e} {} ({v} {rate})", self.symbol())
    }
}

#[cfg(test)]
mod tests {
    use super::TimeUnit;

    #[test]
    fn every_word_names_its_unit_and_seconds_keep_their_wording() {
        for u in TimeUnit::ALL {
            for w in [u.symbol(), u.singular(), u.plural()] {
                assert_eq!(TimeUnit::from_word(w), Some(u), "{w}");
            }
        }
        assert_eq!(TimeUnit::from_word("fortnights"), None);
        let s = TimeUnit::Seconds;
        assert_eq!(s.describe_period(1e-4), "h = 1e-4 s (10 kHz)");
        assert_eq!(s.describe_period(2e-3), "h = 2e-3 s (500 Hz)");
        assert_eq!(s.duration(1.52e-3), "1.52 ms");
        assert_eq!(s.duration(1.39e-5), "13.9 us");
        let h = TimeUnit::Hours;
        assert_eq!(h.describe_period(1e-2), "h = 1e-2 h (100 per hour)");
        assert_eq!(h.duration(0.0933), "0.0933 h");
        assert_eq!(h.duration(2.5e-5), "2.50e-5 h");
        assert_eq!(
            TimeUnit::Days.describe_period(0.25),
            "h = 2.5e-1 d (4 per day)"
        );
    }
}
