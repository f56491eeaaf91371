//! Shared vocabulary: the names under which the DSL's choices (mode, split,
//! conditions), the condition families, the search phases and the state
//! bound's source appear in reports, each in one table.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// Declares a fieldless enum whose variants each have one name: `name()`,
/// `ALL`, `from_name`, `Display`, comparison with `&str`, and serde through
/// the same names (so reports keep their strings).
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $ty:ident ($what:literal) {
            $( $(#[$vmeta:meta])* $var:ident = $name:literal, )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        $vis enum $ty {
            $( $(#[$vmeta])* $var, )+
        }

        // Ordered and hashed by name, as the strings reports used to key
        // maps by, so that a map keyed by the enum iterates in the same
        // order and can be looked up with a `&str` (`Borrow<str>`).
        impl Ord for $ty {
            fn cmp(&self, other: &Self) -> std::cmp::Ordering {
                self.name().cmp(other.name())
            }
        }

        impl PartialOrd for $ty {
            fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
                Some(self.cmp(other))
            }
        }

        impl std::hash::Hash for $ty {
            fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
                self.name().hash(h)
            }
        }

        impl std::borrow::Borrow<str> for $ty {
            fn borrow(&self) -> &str {
                self.name()
            }
        }

        impl $ty {
            /// Every variant, in table order.
            pub const ALL: &'static [$ty] = &[$($ty::$var),+];

            /// The name used in reports, messages and the CLI.
            pub fn name(self) -> &'static str {
                match self {
                    $( $ty::$var => $name, )+
                }
            }

            /// The variant with this name, if any.
            pub fn from_name(name: &str) -> Option<$ty> {
                Self::ALL.iter().copied().find(|v| v.name() == name)
            }

            /// The name as a string slice (the same as [`Self::name`]).
            pub fn as_str(&self) -> &'static str {
                self.name()
            }
        }

        impl fmt::Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.pad(self.name())
            }
        }

        impl AsRef<str> for $ty {
            fn as_ref(&self) -> &str {
                self.name()
            }
        }

        impl PartialEq<str> for $ty {
            fn eq(&self, other: &str) -> bool {
                self.name() == other
            }
        }

        impl PartialEq<&str> for $ty {
            fn eq(&self, other: &&str) -> bool {
                self.name() == *other
            }
        }

        impl Serialize for $ty {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }

        impl<'de> Deserialize<'de> for $ty {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = String::deserialize(d)?;
                $ty::from_name(&s).ok_or_else(|| {
                    let names: Vec<String> =
                        Self::ALL.iter().map(|v| format!("{:?}", v.name())).collect();
                    serde::de::Error::custom(format!(
                        "unknown {} {s:?}, expected one of {}",
                        $what,
                        names.join(", ")
                    ))
                })
            }
        }
    };
}

/// A point of the design space: the decay rate α and the region scaling
/// γ, named so that the two cannot be swapped by position, and for a
/// design at a sample period, that period (α is then still per unit time;
/// V contracts by 1 − hα per step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The decay rate α > 0 of V = eᵀPe.
    pub alpha: f64,
    /// The region scaling γ in (0, 1).
    pub gamma: f64,
    /// `sample = h`: the sample period the discrete decrease is judged at.
    pub sample: Option<f64>,
}

impl Candidate {
    /// The continuous-time candidate (α, γ).
    pub fn new(alpha: f64, gamma: f64) -> Candidate {
        Candidate {
            alpha,
            gamma,
            sample: None,
        }
    }

    /// The same candidate at the sample period `h` (None: continuous time).
    pub(crate) fn at_sample(self, h: Option<f64>) -> Candidate {
        Candidate { sample: h, ..self }
    }
}

named_enum! {
    /// A condition family or data check of the certificate and the LMIs:
    /// the sound conditions (S1)-(S5) and the paper's printed (13), (14),
    /// (26) (which share (S1), P ≻ 0, with the sound set).
    pub enum Family ("condition family") {
        /// P ≻ 0.
        S1 = "S1",
        /// Region vertices inside the ellipsoid (sound).
        S2 = "S2",
        /// Region facets: the ellipsoid inside the region (sound).
        S3 = "S3",
        /// Data check: the state bound F lies in P/γ.
        S4 = "S4",
        /// The rate conditions (sound).
        S5 = "S5",
        /// The discrete decrease of a `sample = h` design (replaces S5):
        /// [(1 − hα)P, (P + hΦ)ᵀ; P + hΦ, P] ⪰ 0 per combination and pair.
        S5d = "S5d",
        /// The global observer's rate conditions (an LPV plant, sound
        /// mode): He{P A_l − Γ_l C_m} + αP ≺ 0 per rate combination, with
        /// no region, state bound or γ.
        G5 = "G5",
        /// `poles = ...`: the pole-region blocks (disk, sector, strip) on
        /// the frozen error dynamics with the design's P, per rate
        /// combination and region-vertex pair.
        D = "D",
        /// The paper's printed vertex condition.
        Paper13 = "13",
        /// The paper's printed facet condition.
        Paper14 = "14",
        /// The paper's printed rate conditions.
        Paper26 = "26",
        /// Data check: the certified ellipsoid lies in the state bound F.
        RegionInF = "region_in_F",
        /// Data check of `max_gain = G`: every ‖L_l‖₂ ≤ G, from the gains
        /// as given.
        MaxGain = "max_gain",
    }
}

named_enum! {
    /// What a design or a re-check establishes: one of three states (a
    /// report's `verdict`; reports written before it existed said it with
    /// two booleans, `feasible` and `certifies`, which still load).
    /// The default is `NotCertified`.
    #[derive(Default)]
    pub enum Verdict ("verdict") {
        /// Sound mode, every condition family and required data check
        /// holds: V' ≤ −αV on the certified set is proven.
        Certified = "certified",
        /// Paper mode, the printed conditions hold: a reproduction, which
        /// certifies nothing.
        Reproduction = "reproduction",
        /// Some family or required data check fails, or there is no point.
        #[default]
        NotCertified = "not_certified",
    }
}

impl Verdict {
    /// The verdict of conditions that `passed` (or not) in `mode`.
    pub fn of(passed: bool, mode: qpv_dsl::Mode) -> Verdict {
        match (passed, mode) {
            (false, _) => Verdict::NotCertified,
            (true, qpv_dsl::Mode::Sound) => Verdict::Certified,
            (true, qpv_dsl::Mode::Paper) => Verdict::Reproduction,
        }
    }

    /// The verdict the two booleans of an older report say (`certifies`
    /// wins; `feasible` alone is a reproduction).
    pub fn from_flags(feasible: bool, certifies: bool) -> Verdict {
        match (feasible, certifies) {
            (_, true) => Verdict::Certified,
            (true, false) => Verdict::Reproduction,
            (false, false) => Verdict::NotCertified,
        }
    }

    /// The conditions of the mode hold (certified, or a reproduction).
    pub fn feasible(self) -> bool {
        self != Verdict::NotCertified
    }

    /// Certified: sound mode and every condition holds.
    pub fn certifies(self) -> bool {
        self == Verdict::Certified
    }
}

/// Serde of a report's verdict, flattened into the report: writes
/// `verdict`; reads `verdict`, else the two booleans `feasible` and
/// `certifies` of reports written before it existed (either may be absent,
/// as false).
pub mod verdict_serde {
    use crate::vocab::Verdict;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    struct Wire {
        #[serde(default)]
        verdict: Option<Verdict>,
        #[serde(default, skip_serializing)]
        feasible: Option<bool>,
        #[serde(default, skip_serializing)]
        certifies: Option<bool>,
    }

    /// Writes `verdict`.
    pub(crate) fn serialize<S: Serializer>(v: &Verdict, s: S) -> Result<S::Ok, S::Error> {
        Wire {
            verdict: Some(*v),
            feasible: None,
            certifies: None,
        }
        .serialize(s)
    }

    /// Reads `verdict`, else `feasible`/`certifies`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Verdict, D::Error> {
        let w = Wire::deserialize(d)?;
        Ok(w.verdict.unwrap_or_else(|| {
            Verdict::from_flags(w.feasible.unwrap_or(false), w.certifies.unwrap_or(false))
        }))
    }
}

named_enum! {
    /// What one solve of a search was for (a report's `search[].phase`).
    pub enum Phase ("search phase") {
        /// A fixed (α, γ) request.
        Fixed = "fixed",
        /// A bisection on α at one γ.
        Bisect = "bisect",
        /// The coarse γ grid.
        Grid = "grid",
        /// The γ refinement around the best grid point.
        Refine = "refine",
        /// The walk to smaller γ from a best point whose lower neighbour
        /// certified nothing (a cliff that a seeded solve may cross).
        Continue = "continue",
        /// The fine α bisection at the chosen γ.
        FinalBisect = "final-bisect",
        /// The gain-objective solve of the returned design.
        Final = "final",
        /// The regularised retry of a solve without a usable point.
        Retry = "retry",
        /// The solves that explain a failed request.
        Diagnose = "diagnose",
        /// The smallest-gain solves of the practical α = max (α at the
        /// tolerance below the certified supremum).
        Practical = "practical",
        /// The smallest-gain solves of `max_gain = G` without the SDP's
        /// gain constraint, each checked for ‖L_l‖₂ ≤ G by the certificate.
        GainWalk = "gain-walk",
        /// The noise-optimal solve at a fixed γ.
        Noise = "noise",
        /// The γ grid of the noise-optimal design.
        NoiseGrid = "noise-grid",
        /// The γ refinement of the noise-optimal design.
        NoiseRefine = "noise-refine",
        /// The margin grid of the RMS-optimal design at one γ.
        Rms = "rms",
        /// The margin refinement of the RMS-optimal design.
        RmsRefine = "rms-refine",
    }
}

named_enum! {
    /// Where a design's state bound Q came from (a report's
    /// `state_bound.source`).
    pub enum BoundSource ("state bound source") {
        /// Q from the model (`state_bound = ...`).
        Given = "given",
        /// Computed for `state_bound auto`.
        Auto = "auto",
        /// No state bound.
        None = "none",
    }
}

/// (De)serialises [`Split`] as "as_written" / "symmetric" / "skew_slack".
pub mod split_serde {
    use qpv_dsl::Split;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the split's name ([`Split::name`]).
    pub(crate) fn serialize<S: Serializer>(m: &Split, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }

    /// Reads "as_written", "symmetric" or "skew_slack".
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Split, D::Error> {
        let s = String::deserialize(d)?;
        Split::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "unknown split {s:?}, expected \"as_written\", \"symmetric\" or \"skew_slack\""
                ))
            })
    }
}

/// (De)serialises [`Conditions`] as "full" / "decoupled" / "cube".
pub mod conditions_serde {
    use qpv_dsl::Conditions;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes "full", "decoupled" or "cube".
    pub(crate) fn serialize<S: Serializer>(c: &Conditions, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(c.name())
    }

    /// Reads "full", "decoupled" or "cube".
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Conditions, D::Error> {
        let s = String::deserialize(d)?;
        Conditions::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "unknown conditions {s:?}, expected \"full\", \"decoupled\" or \"cube\""
                ))
            })
    }
}

/// (De)serialises [`Mode`] as "sound" / "paper".
pub mod mode_serde {
    use qpv_dsl::Mode;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes "sound" or "paper".
    pub(crate) fn serialize<S: Serializer>(m: &Mode, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }

    /// Reads "sound" or "paper".
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Mode, D::Error> {
        let s = String::deserialize(d)?;
        Mode::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "unknown mode {s:?}, expected \"sound\" or \"paper\""
                ))
            })
    }
}

/// (De)serialises the split of a state bound's invariance check (a
/// report's `state_bound.split`): `null`, "as_written" or "symmetric".
pub mod bound_split_serde {
    use qpv_dsl::Split;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the split's name, or `null`.
    pub(crate) fn serialize<S: Serializer>(m: &Option<Split>, s: S) -> Result<S::Ok, S::Error> {
        match m {
            Some(m) => s.serialize_str(m.name()),
            None => s.serialize_none(),
        }
    }

    /// Reads `null`, "as_written" or "symmetric" (the only representations
    /// a bound's invariance is certified with).
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Split>, D::Error> {
        let Some(s) = Option::<String>::deserialize(d)? else {
            return Ok(None);
        };
        [Split::AsWritten, Split::Symmetric]
            .into_iter()
            .find(|v| v.name() == s)
            .map(Some)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "`state_bound.split` is {s:?}: expected \"as_written\" or \"symmetric\" (the \
                     representation of N_k the bound's invariance was certified with)"
                ))
            })
    }
}
