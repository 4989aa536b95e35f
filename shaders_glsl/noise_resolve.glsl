//! noise_resolve.glsl — N at one pixel from the `noise` pass's accumulator atlas (NVIDIA patent US 8,947,430,
//! eq. 15–17; method.md §8): level 0's fixed-point sum at the pixel plus every coarser level's sum interpolated
//! bilinearly at the pixel (texel i of level L sits at full-resolution position (i + ½)·2^L − ½). A coarse texel
//! whose depth pixel showed no fluid was never written: it is left out of the interpolation and the weights of
//! the others renormalised, so a close-up sprite's noise reaches the silhouette instead of fading towards it.
//! Shared by noise_resolve.comp and noise_apply.comp's RESOLVE variant. Expects, declared before it: the atlas
//! `accum` (r32ui) and the fluid depth `depth` (r32f, full resolution).

/// N (radii) at fluid pixel p of a `size` output whose splat wrote levels 0 … `levels`.
float noise_resolve(ivec2 p, ivec2 size, int levels) {
    float n = float(int(imageLoad(accum, p).x));
    for (int L = 1; L <= levels; ++L) {
        ivec2 lsize = noise_level_size(size, L);
        ivec2 base = noise_level_base(size, L);
        vec2 t = (vec2(p) + 0.5) / float(1 << L) - 0.5;
        ivec2 i0 = ivec2(floor(t));
        vec2 f = t - vec2(i0);
        float sum = 0.0, wsum = 0.0;
        for (int k = 0; k < 4; ++k) {
            ivec2 o = ivec2(k & 1, k >> 1);
            ivec2 q = clamp(i0 + o, ivec2(0), lsize - 1);
            float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
            ivec2 pick = min(q * (1 << L) + (1 << (L - 1)), size - 1);
            if (w > 0.0 && is_fluid(imageLoad(depth, pick).x)) {
                sum += w * float(int(imageLoad(accum, base + q).x));
                wsum += w;
            }
        }
        if (wsum > 0.0) n += sum / wsum;
    }
    return n * (1.0 / 65536.0);
}
