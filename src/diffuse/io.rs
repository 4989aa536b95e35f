//! Diffuse particles as a file's attributes (SPlisHSPlasH FoamGenerator's names and type numbers) and back, and
//! a diffuse cache read from any particle format. In: particles or a path. Out: a file's particles or diffuse
//! particles.

use glam::Vec3;

use super::{Kind, Particle};

/// The particles as a file's attributes: `velocity`, `lifetime` (s left), `age` (s since spawned), `source` (the
/// spawning fluid particle's id), `type` (0 foam, 1 spray, 2 bubbles, as SPlisHSPlasH's FoamGenerator numbers
/// them) and `id`.
pub fn to_particles(ps: &[Particle]) -> crate::scene::Particles {
    let scalar = |name: &str, value: fn(&Particle) -> f64| crate::scene::Attribute {
        name: name.into(),
        components: 1,
        data: ps.iter().map(value).collect(),
    };
    crate::scene::Particles {
        positions: ps.iter().map(|p| p.position.to_array()).collect(),
        velocities: Some(ps.iter().map(|p| p.velocity.to_array()).collect()),
        ids: Some(ps.iter().map(|p| p.id as i64).collect()),
        extra: vec![
            scalar("lifetime", |p| p.lifetime as f64),
            scalar("source", |p| p.source as f64),
            scalar("age", |p| p.age as f64),
            scalar("type", |p| p.kind as u8 as f64),
        ],
        ..Default::default()
    }
}

/// Diffuse particles from a file: its `type` (default foam), `lifetime` (default 1 s) and `age` (default 1 s)
/// attributes, its
/// velocities (default 0) and ids (default the index).
pub fn from_particles(p: &crate::scene::Particles) -> std::result::Result<Vec<Particle>, String> {
    let attr = |name: &str| p.extra.iter().find(|a| a.name == name && a.components == 1);
    let kinds = attr("type");
    let life = attr("lifetime");
    let age = attr("age");
    let source = attr("source");
    (0..p.len())
        .map(|i| {
            let kind = match kinds {
                Some(a) => Kind::from_code(a.data[i]).ok_or_else(|| {
                    format!("particle {i}: type {} is not 0 (foam), 1 (spray) or 2 (bubbles)", a.data[i])
                })?,
                None => Kind::Foam,
            };
            Ok(Particle {
                id: p.ids.as_ref().map_or(i as u32, |ids| ids[i] as u32),
                kind,
                position: Vec3::from(p.positions[i]),
                velocity: p.velocities.as_ref().map_or(Vec3::ZERO, |v| Vec3::from(v[i])),
                lifetime: life.map_or(1.0, |a| a.data[i] as f32),
                age: age.map_or(1.0, |a| a.data[i] as f32),
                source: source.map_or(0, |a| a.data[i] as u32),
            })
        })
        .collect()
}

/// Read an exported frame of diffuse particles (`meniscus diffuse --export`, or any particle file with the
/// `type` and `lifetime` attributes of [`to_particles`]; others are refused); a file with no particles is an
/// empty frame.
pub fn load(path: &std::path::Path) -> crate::error::Result<Vec<Particle>> {
    use crate::error::Error;
    let bytes = crate::input::read(path)?;
    let format = crate::scene::detect_format(path, &bytes).ok_or_else(|| Error::Parse {
        path: path.to_path_buf(),
        offset: 0,
        reason: "unknown particle format".into(),
    })?;
    let raw = crate::scene::parse_raw(format, path, &bytes)?;
    let p = raw.into_particles(&crate::scene::LoadOptions::default());
    // A file of diffuse particles says so by its attributes: the fluid's own files (or another simulation's) are
    // refused, not drawn as foam.
    let has = |name: &str| p.extra.iter().any(|a| a.name == name && a.components == 1);
    if !p.is_empty() && (!has("type") || !has("lifetime")) {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            offset: 0,
            reason: "not a file of diffuse particles: it has no `type` and `lifetime` attributes (`meniscus \
                     diffuse --export` writes them); is this the fluid's own sequence?"
                .into(),
        });
    }
    from_particles(&p).map_err(|reason| Error::Parse { path: path.to_path_buf(), offset: 0, reason })
}
