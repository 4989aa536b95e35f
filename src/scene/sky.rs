//! Sky cube maps from six images: `DIR/{px,nx,py,ny,pz,nz}.png` (also `posx…negz`, `right,left,top,bottom,
//! front,back`), square and of one size. Without files the sky is procedural (common.glsl `sky()`).

use std::path::Path;

use crate::error::{Error, Result};

const NAMES: [[&str; 3]; 6] = [
    ["px", "posx", "right"],
    ["nx", "negx", "left"],
    ["py", "posy", "top"],
    ["ny", "negy", "bottom"],
    ["pz", "posz", "front"],
    ["nz", "negz", "back"],
];

/// The six faces as one RGBA8 buffer (face order +X −X +Y −Y +Z −Z) and the face size.
pub fn load_faces(dir: &Path) -> Result<(u32, Vec<u8>)> {
    let mut size = None;
    let mut data = vec![];
    for names in NAMES {
        let path = names.iter().map(|n| dir.join(format!("{n}.png"))).find(|p| p.exists()).ok_or_else(|| {
            Error::Invalid(format!(
                "{}: no {}.png (or {}.png / {}.png) cube face",
                dir.display(),
                names[0],
                names[1],
                names[2]
            ))
        })?;
        crate::input::check(&path)?;
        crate::input::note(&path);
        let img = image::open(&path)
            .map_err(|e| Error::Parse { path: path.clone(), offset: 0, reason: format!("cannot read the image: {e}") })?
            .to_rgba8();
        if img.width() != img.height() {
            return Err(Error::Invalid(format!(
                "{}: cube faces must be square, this one is {}×{}",
                path.display(),
                img.width(),
                img.height()
            )));
        }
        match size {
            None => size = Some(img.width()),
            Some(s) if s != img.width() => {
                return Err(Error::Invalid(format!(
                    "{}: face size {} differs from the others ({s})",
                    path.display(),
                    img.width()
                )))
            }
            _ => {}
        }
        data.extend_from_slice(img.as_raw());
    }
    Ok((size.unwrap_or(1), data))
}
