//! Shared vocabulary: the names under which the DSL's choices (mode, split,
//! conditions) appear in reports, in one place.

/// (De)serialises [`Split`] as "as_written" / "symmetric" / "skew_slack".
pub mod split_serde {
    use qpv_dsl::Split;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the split's name ([`Split::name`]).
    pub fn serialize<S: Serializer>(m: &Split, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }

    /// Reads "as_written", "symmetric" or "skew_slack".
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Split, D::Error> {
        let s = String::deserialize(d)?;
        [Split::AsWritten, Split::Symmetric, Split::SkewSlack]
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "unknown split {s:?}, expected \"as_written\", \"symmetric\" or \"skew_slack\""
                ))
            })
    }
}

/// (De)serialises [`Conditions`] as "full" / "decoupled".
pub mod conditions_serde {
    use qpv_dsl::Conditions;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes "full" or "decoupled".
    pub fn serialize<S: Serializer>(c: &Conditions, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match c {
            Conditions::Full => "full",
            Conditions::Decoupled => "decoupled",
        })
    }

    /// Reads "full" or "decoupled".
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Conditions, D::Error> {
        let s = String::deserialize(d)?;
        match s.as_str() {
            "full" => Ok(Conditions::Full),
            "decoupled" => Ok(Conditions::Decoupled),
            other => Err(serde::de::Error::custom(format!(
                "unknown conditions {other:?}, expected \"full\" or \"decoupled\""
            ))),
        }
    }
}

/// (De)serialises [`Mode`] as "sound" / "paper".
pub mod mode_serde {
    use qpv_dsl::Mode;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes "sound" or "paper".
    pub fn serialize<S: Serializer>(m: &Mode, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match m {
            Mode::Sound => "sound",
            Mode::Paper => "paper",
        })
    }

    /// Reads "sound" or "paper".
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Mode, D::Error> {
        let s = String::deserialize(d)?;
        match s.as_str() {
            "sound" => Ok(Mode::Sound),
            "paper" => Ok(Mode::Paper),
            other => Err(serde::de::Error::custom(format!(
                "unknown mode {other:?}, expected \"sound\" or \"paper\""
            ))),
        }
    }
}
