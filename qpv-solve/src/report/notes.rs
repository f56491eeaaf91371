//! The notes of a design report: typed remarks the code reacts to
//! ([`Note`]'s variants), free sentences ([`Note::Text`]), serialised as
//! their sentences so that a report reads as it always has.

use super::GammaSearchInfo;
use serde::{Deserialize, Serialize};

/// What gets a certified design without a noise bound one
/// ([`Note::NoNoiseBound`]).
pub const NOISE_MIN_ADVICE: &str =
    "a design with `noise = min` at this alpha (or at a slightly lower alpha) carries one";

/// One note of a design report: a remark on what the design did or
/// assumed. Serialised as its sentence (`Display`), so a report reads as
/// it always has; a report read back holds each note as [`Note::Text`],
/// and two notes are equal when they say the same.
#[derive(Debug, Clone)]
pub enum Note {
    /// `conditions = auto`: the conditions the size estimate chose, and why
    /// ([`crate::model::size::choose`]).
    ConditionsChosen(String),
    /// What the γ search searched ([`GammaSearchInfo::statement`]).
    GammaSearch(GammaSearchInfo),
    /// Solves that ended with an unknown status (neither feasible nor
    /// infeasible; counted as not certified).
    UnknownStatus {
        /// How many.
        count: usize,
        /// Of how many solves.
        solves: usize,
        /// The solver's names of those statuses, sorted, each once.
        kinds: Vec<String>,
    },
    /// The solver stopped with a status short of solved (`detail`, its
    /// name), but its point passes the independent certificate.
    StoppedShort {
        /// The solver's status name.
        detail: String,
    },
    /// Solved points the independent certificate rejected (not used).
    Rejected {
        /// How many.
        count: usize,
    },
    /// The global observer was solved in balanced units x = D z.
    BalancedUnits {
        /// The diagonal of D (powers of two).
        d: Vec<f64>,
        /// Where D came from ("2 pilot solves", "the first search's P").
        from: String,
    },
    /// A certified design without a noise bound: why none is certified
    /// ([`crate::certificate::noise::noise_bound_or_why`]).
    NoNoiseBound(String),
    /// Any other remark, and every note of a report read back.
    Text(String),
}

impl Note {
    /// Whether the note belongs to the search log only: routine for a
    /// design that certifies (points the certificate rejected were never
    /// used), so a text report may leave it to the JSON's `notes`.
    pub fn is_search_log(&self) -> bool {
        matches!(
            self,
            Note::UnknownStatus { .. } | Note::StoppedShort { .. } | Note::Rejected { .. }
        )
    }
}

impl std::fmt::Display for Note {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Note::ConditionsChosen(s) | Note::Text(s) => f.write_str(s),
            Note::GammaSearch(info) => f.write_str(&info.statement()),
            Note::UnknownStatus {
                count,
                solves,
                kinds,
            } => write!(
                f,
                "{count} of {solves} solver calls ended with an unknown status ({}): neither feasible nor infeasible, counted as not certified",
                kinds.join(", ")
            ),
            Note::StoppedShort { detail } => write!(
                f,
                "the solver stopped with {detail} but its point passes the independent certificate"
            ),
            Note::Rejected { count } => write!(
                f,
                "{count} point(s) returned by the solver failed the independent certificate and were rejected"
            ),
            Note::NoNoiseBound(why) => {
                write!(f, "no noise bound is certified: {why}; {NOISE_MIN_ADVICE}")
            }
            Note::BalancedUnits { d, from } => {
                let d: Vec<String> = d.iter().map(|v| format!("{v:e}")).collect();
                write!(
                    f,
                    "global observer in balanced units x = D z, D = diag({}) (powers of two, from {from}; exact)",
                    d.join(", ")
                )
            }
        }
    }
}

impl PartialEq for Note {
    fn eq(&self, other: &Note) -> bool {
        self.to_string() == other.to_string()
    }
}

impl From<String> for Note {
    fn from(s: String) -> Note {
        Note::Text(s)
    }
}

impl From<&str> for Note {
    fn from(s: &str) -> Note {
        Note::Text(s.to_string())
    }
}

impl Serialize for Note {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Note {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Note, D::Error> {
        String::deserialize(d).map(Note::Text)
    }
}

/// The notes of a design, in order (the report's `notes`: a list of
/// sentences). Anything that converts into a [`Note`] can be pushed, so a
/// plain sentence is a [`Note::Text`].
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Notes(pub Vec<Note>);

impl Notes {
    /// Appends a note.
    pub fn push(&mut self, note: impl Into<Note>) {
        self.0.push(note.into());
    }

    /// Inserts a note at `index`.
    pub fn insert(&mut self, index: usize, note: impl Into<Note>) {
        self.0.insert(index, note.into());
    }
}

impl std::ops::Deref for Notes {
    type Target = [Note];
    fn deref(&self) -> &[Note] {
        &self.0
    }
}

impl<T: Into<Note>> Extend<T> for Notes {
    fn extend<I: IntoIterator<Item = T>>(&mut self, iter: I) {
        self.0.extend(iter.into_iter().map(Into::into));
    }
}

impl<T: Into<Note>> From<Vec<T>> for Notes {
    fn from(v: Vec<T>) -> Notes {
        Notes(v.into_iter().map(Into::into).collect())
    }
}

impl<'a> IntoIterator for &'a Notes {
    type Item = &'a Note;
    type IntoIter = std::slice::Iter<'a, Note>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

impl IntoIterator for Notes {
    type Item = Note;
    type IntoIter = std::vec::IntoIter<Note>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}
