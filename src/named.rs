//! Enums whose variants have one name each — used everywhere a user names one: TOML (serde), the command line
//! (`FromStr` + [`Named::NAMES`], so the library needs no CLI crate), JSON and tables. The settings' enums and
//! the passes' own are declared with [`named_enum!`]; the passes' own that a user chooses among — the
//! screen-space filter ([`Filter`], `[filter] filter`, `--filter`) and the sphere splat's mode ([`SplatMode`],
//! `[splat] mode`, `--splat`) — are declared here, below both the passes that run them and the settings that
//! hold them, so that each has one path.

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

named_enum! {
    /// Depth smoothing filter (`--filter`).
    pub enum Filter {
        /// No smoothing: the raw spheres.
        None = "none",
        /// Separable Gaussian (a baseline: merges silhouettes).
        Gaussian = "gaussian",
        /// Separable bilateral.
        Bilateral = "bilateral",
        /// Exact 2D bilateral.
        Bilateral2d = "bilateral2d",
        /// Curvature flow (van der Laan 2009) with depth-adaptive iterations (Bagar 2010).
        CurvatureFlow = "curvature-flow",
        /// Narrow-range filter (Truong & Yuksel 2018); the default on spheres (`--preset fast`): smoothest
        /// surface at bilateral cost.
        NarrowRange = "narrow-range",
    }
}

named_enum! {
    /// How the `splat` pass draws (`--splat`): the compute splat, or a rasterised variant kept for measurement.
    pub enum SplatMode {
        /// One thread per particle, atomicMin on the depth bits (default).
        Compute = "compute",
        /// Instanced quads, exact depth through gl_FragDepth (no early depth test).
        QuadFragDepth = "quad-frag-depth",
        /// Quads with conservative depth (depth_less + GREATER test keeps early depth test valid).
        QuadConservative = "quad-conservative",
        /// Quads, no depth buffer, MIN blending of linear depth into R32F.
        QuadMin = "quad-min",
        /// Point sprites with gl_FragDepth (sizes above the device's point size limit are clipped).
        PointFragDepth = "point-frag-depth",
        /// Point sprites with MIN blending.
        PointMin = "point-min",
    }
}

impl SplatMode {
    /// Needs a D32 depth buffer.
    pub fn depth_tested(self) -> bool {
        matches!(self, SplatMode::QuadFragDepth | SplatMode::QuadConservative | SplatMode::PointFragDepth)
    }
}
