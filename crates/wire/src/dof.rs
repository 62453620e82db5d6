//! The six rigid-body degrees of freedom of a ship and their names on the wire and in CSV files.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// One of the six motions of a ship. The discriminant is the index into `[f64; 6]` arrays
/// (`MotionSample::dof`, `Forecast::mean`), so the order is part of the wire contract.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dof {
    Surge = 0,
    Sway = 1,
    Heave = 2,
    Roll = 3,
    Pitch = 4,
    Yaw = 5,
}

impl Dof {
    /// All six, in wire order.
    pub const ALL: [Dof; 6] = [
        Dof::Surge,
        Dof::Sway,
        Dof::Heave,
        Dof::Roll,
        Dof::Pitch,
        Dof::Yaw,
    ];

    /// Index into six-element arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Lower-case name used on the CLI and in JSON (`heave`).
    pub const fn name(self) -> &'static str {
        match self {
            Dof::Surge => "surge",
            Dof::Sway => "sway",
            Dof::Heave => "heave",
            Dof::Roll => "roll",
            Dof::Pitch => "pitch",
            Dof::Yaw => "yaw",
        }
    }

    /// Column name in the motion CSV, carrying the unit (`heave_m`, `roll_rad`).
    pub const fn csv_column(self) -> &'static str {
        match self {
            Dof::Surge => "surge_m",
            Dof::Sway => "sway_m",
            Dof::Heave => "heave_m",
            Dof::Roll => "roll_rad",
            Dof::Pitch => "pitch_rad",
            Dof::Yaw => "yaw_rad",
        }
    }

    /// SI unit of the value: metres for translations, radians for rotations.
    pub const fn unit(self) -> &'static str {
        if self.is_rotation() {
            "rad"
        } else {
            "m"
        }
    }

    /// True for roll, pitch and yaw.
    pub const fn is_rotation(self) -> bool {
        matches!(self, Dof::Roll | Dof::Pitch | Dof::Yaw)
    }
}

impl fmt::Display for Dof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error for a DOF name that is not one of the six.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown degree of freedom '{0}' (expected surge, sway, heave, roll, pitch or yaw)")]
pub struct UnknownDof(pub String);

impl FromStr for Dof {
    type Err = UnknownDof;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        Dof::ALL
            .into_iter()
            .find(|d| d.name() == lower || d.csv_column() == lower)
            .ok_or(UnknownDof(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_index_matches_wire_order() {
        for (i, d) in Dof::ALL.into_iter().enumerate() {
            assert_eq!(d.index(), i);
            assert_eq!(d.name().parse::<Dof>().unwrap(), d);
            assert_eq!(d.csv_column().parse::<Dof>().unwrap(), d);
        }
        assert!("heavy".parse::<Dof>().is_err());
    }
}
