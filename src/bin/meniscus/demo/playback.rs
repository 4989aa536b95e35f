//! Playback: where the demo's frames come from (a single set of particles, or a sequence loaded on demand with
//! the last few frames kept) and how the frame counter advances.

use std::collections::HashMap;

use meniscus::scene::{self, LoadOptions, Particles};
use meniscus::Result;

/// Where frames come from.
pub enum Source {
    Static(Particles),
    Sequence { frames: Vec<scene::sequence::Frame>, cache: HashMap<usize, Particles>, order: Vec<usize> },
}

impl Source {
    pub fn len(&self) -> usize {
        match self {
            Source::Static(_) => 1,
            Source::Sequence { frames, .. } => frames.len(),
        }
    }
    /// Frame `i`, loading it (and keeping the last 8) on demand.
    pub fn get(&mut self, i: usize, o: &LoadOptions) -> Result<&Particles> {
        match self {
            Source::Static(p) => Ok(p),
            Source::Sequence { frames, cache, order } => {
                if let std::collections::hash_map::Entry::Vacant(e) = cache.entry(i) {
                    let p = scene::load_with(&frames[i].path, o)?;
                    e.insert(p);
                    order.push(i);
                    if order.len() > 8 {
                        let old = order.remove(0);
                        cache.remove(&old);
                    }
                }
                Ok(&cache[&i])
            }
        }
    }
}

/// The frame after `frame` of `n`: the next one, the first again when looping, or `None` (stop) at the end.
pub fn next_frame(frame: usize, n: usize, looping: bool) -> Option<usize> {
    if frame + 1 < n {
        Some(frame + 1)
    } else if looping {
        Some(0)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn playback_advances_loops_and_stops() {
        assert_eq!(next_frame(0, 3, false), Some(1));
        assert_eq!(next_frame(2, 3, true), Some(0));
        assert_eq!(next_frame(2, 3, false), None);
        assert_eq!(next_frame(0, 1, true), Some(0));
    }
}
