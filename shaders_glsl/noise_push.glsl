//! noise_push.glsl — the `noise` pass's sprite push constants (`passes::noise::SpritePush`), one declaration for
//! every shader of the splat (noise_cull, noise_args, noise, noise_bin, noise_scan, noise_fill, noise_gather).
//! NVIDIA patent US 8,947,430. Lengths in particle radii.
layout(push_constant) uniform Push {
    uint count;
    float size;      // sprite radius in particle radii
    float freq;      // noise cycles across the sprite's radius
    float falloff;   // depth below the surface (radii) over which the weight falls by 1/e
    float calm;      // amplitude (radii of height) of a particle whose velocity changes slowly
    float turbulent; // … and of one whose velocity changes faster than the threshold
    float threshold; // velocity change (world units / s²)
    uint tiles;      // tiles of every level (the tiled splat)
    uint small;      // sprites of at most this many texels are not binned (noise_bin)
    float lod;       // texels per cycle of the finer octave a level keeps ([noise] lod_samples)
    uvec2 resolve;   // noise_resolve's work groups (noise_scan: its indirect dispatch, none at level 0 alone)
} pc;
