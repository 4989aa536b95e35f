//! The passes, in frame order. Each is a plain struct that owns its compute program(s) and binding table and
//! has one `record`; the name is the same everywhere: module, shader stem, debug label, timestamp key, JSON key.

pub mod background;
pub mod composite;
pub mod iso;
pub mod normals;
pub mod overlay;
pub mod particles;
pub mod smooth;
pub mod splat;
pub mod ssr;
pub mod thickness;
pub mod upsample;
pub mod view;

pub use background::Background;
pub use composite::Composite;
pub use iso::Iso;
pub use normals::Normals;
pub use smooth::Smooth;
pub use splat::Splat;
pub use ssr::Ssr;
pub use thickness::Thickness;
pub use upsample::Upsample;

/// Every pass name (timestamp keys, JSON keys, `--timings` rows); `iso` runs only with `surface = "iso"`,
/// `upsample` between `smooth` and `normals` only when the fluid is rendered at reduced resolution.
pub const PASS_NAMES: &[&str] = &[
    background::NAME,
    splat::NAME,
    iso::NAME,
    thickness::NAME,
    smooth::NAME,
    upsample::NAME,
    normals::NAME,
    ssr::NAME,
    composite::NAME,
];

pub(crate) use crate::shader_constants::{LOCAL_1D, LOCAL_2D};
