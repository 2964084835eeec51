//! Ids of robots and treasures. They key the spatial indexes, so they live in the lowest
//! layer; every layer above names things by them, never by raw indices.

macro_rules! id_type {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
        pub struct $name(u32);

        impl $name {
            /// The id with this number.
            pub const fn new(n: u32) -> Self {
                Self(n)
            }
            /// The number behind the id.
            pub const fn get(self) -> u32 {
                self.0
            }
            /// The number as an index into the run's list.
            pub const fn index(self) -> usize {
                self.0 as usize
            }
        }

        impl From<u32> for $name {
            fn from(n: u32) -> Self {
                Self(n)
            }
        }

        impl From<$name> for u32 {
            fn from(id: $name) -> u32 {
                id.0
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                self.0.fmt(f)
            }
        }
    };
}

id_type!(
    /// Identifier of a robot: its index in the run's robot list.
    RobotId
);
id_type!(
    /// Identifier of a treasure: its index in the run's treasure list (stable for the whole
    /// run, never reused).
    TreasureId
);
