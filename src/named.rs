//! Enums whose variants have one name each — used everywhere a user names one: TOML (serde), the command line
//! (`FromStr` + [`Named::NAMES`], so the library needs no CLI crate), JSON and tables. The settings' enums and
//! the passes' own (a filter, a splat mode) are declared with [`named_enum!`].

use crate::error::{Error, Result};

/// An enum whose variants have one name each (settings enums, the demo's view modes).
pub trait Named: Copy + Sized + 'static {
    /// Every variant, in declaration order.
    const ALL: &'static [Self];
    /// Every name, in the same order.
    const NAMES: &'static [&'static str];
    /// This variant's name.
    fn name(self) -> &'static str;
}

/// The variant of `T` called `s`, or an error that lists the names.
pub fn from_name<T: Named>(s: &str) -> Result<T> {
    T::NAMES.iter().position(|n| *n == s).map(|i| T::ALL[i]).ok_or_else(|| {
        let kind = std::any::type_name::<T>().rsplit("::").next().unwrap_or("value");
        Error::Invalid(format!("unknown {kind} {s:?} (expected one of: {})", T::NAMES.join(", ")))
    })
}

/// Defines a settings enum whose variants have one kebab-case name each, used everywhere: TOML (serde), the
/// command line (`FromStr` + [`Named::NAMES`], so the library needs no CLI crate), JSON and tables.
macro_rules! named_enum {
    ($(#[$m:meta])* pub enum $T:ident { $($(#[$vm:meta])* $V:ident = $n:literal,)* }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum $T { $($(#[$vm])* $V,)* }
        impl $crate::named::Named for $T {
            const ALL: &'static [$T] = &[$($T::$V),*];
            const NAMES: &'static [&'static str] = &[$($n),*];
            fn name(self) -> &'static str { match self { $($T::$V => $n),* } }
        }
        impl $T {
            /// Every variant, in declaration order.
            pub const ALL: &'static [$T] = &[$($T::$V),*];
            /// The variant's name (as in TOML and on the command line).
            pub fn name(self) -> &'static str { $crate::named::Named::name(self) }
        }
        impl std::str::FromStr for $T {
            type Err = $crate::error::Error;
            fn from_str(s: &str) -> $crate::error::Result<Self> { $crate::named::from_name(s) }
        }
        impl std::fmt::Display for $T {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result { f.write_str(self.name()) }
        }
        impl serde::Serialize for $T {
            fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }
        impl<'de> serde::Deserialize<'de> for $T {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                let s = <String as serde::Deserialize>::deserialize(d)?;
                $crate::named::from_name(&s).map_err(serde::de::Error::custom)
            }
        }
    };
}
pub(crate) use named_enum;
