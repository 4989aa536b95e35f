#version 460
//! composite — shades the fluid over the background (Moritz §3.4–3.6, eq. 3.21):
//!   c = mix(c_fluid, c_refract·(1−F), τ) + c_reflect·F + σ
//! c_fluid = I0·exp(−η·T) (Beer–Lambert per channel); c_refract = background at the pixel offset by
//! n.xy·min(T·α, β) (eq. 3.27 with the min fix), attenuated by exp(−η·T) as well; τ = exp(−γ·T) (eq. 3.28);
//! F = Schlick Fresnel; c_reflect = the `ssr` hit where there is one, else the sky in the reflected direction;
//! σ = k_s·max(0, n·h)^c (Blinn–Phong, sun). Fluid behind nearer scene geometry is hidden.
//! Layers (the effects', `crate::layer::Layer`), in the order given, at most COMPOSITE_LAYERS: each an r32ui
//! image v with a colour (rgb), a weight w and a blend. `tint` (the noise's whitecaps, NVIDIA patent
//! US 8,947,430: "a grayish color … as a function of the magnitude of the noise"): v holds a signed fixed-point
//! value (from and full come in its units); the water mixes toward the colour lit by the ambient light and the
//! sun (Lambert × s) by w·smoothstep(from, full, |v|).
//! `under` (bubbles, Ihmsen et al. 2012): coverage C = v / units mixes the water toward the colour lit by
//! ambient + s·sun by w·(1 − exp(−C)). `over` (foam and spray): the same over everything, water or background.
//! In: scene colour (sampled), scene depth, fluid depth, normals, thickness (sampled), ssr (sampled), the
//! layers' images (one variant per layer count: COMPOSITE_L0 … L4). Out: rgba8, gamma 2.2.
#define SKY_BINDING 8
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1) uniform sampler2D scene_color;
layout(set = 0, binding = 2, r32f) uniform readonly image2D scene_depth;
layout(set = 0, binding = 3, r32f) uniform readonly image2D fluid_depth;
layout(set = 0, binding = 4, r32ui) uniform readonly uimage2D normals;
layout(set = 0, binding = 5) uniform sampler2D thickness;
layout(set = 0, binding = 6, rgba8) uniform writeonly image2D out_color;
layout(set = 0, binding = 7, r32ui) uniform readonly uimage2D ssr;
// One variant per layer count (build.rs: COMPOSITE_L0 … COMPOSITE_L4): the layers' bindings, push constants and
// blends exist only where there are layers, so a frame without effects runs the composite that knows of none.
#if defined(COMPOSITE_L4)
#define LAYERS_BOUND 4
#elif defined(COMPOSITE_L3)
#define LAYERS_BOUND 3
#elif defined(COMPOSITE_L2)
#define LAYERS_BOUND 2
#elif defined(COMPOSITE_L1)
#define LAYERS_BOUND 1
#else
#define LAYERS_BOUND 0
#endif
#if COMPOSITE_LAYERS != 4
#error "one variant and one binding per layer: composite.comp declares four"
#endif
#if LAYERS_BOUND > 0
layout(set = 0, binding = 9, r32ui) uniform readonly uimage2D layer0;
#endif
#if LAYERS_BOUND > 1
layout(set = 0, binding = 10, r32ui) uniform readonly uimage2D layer1;
#endif
#if LAYERS_BOUND > 2
layout(set = 0, binding = 11, r32ui) uniform readonly uimage2D layer2;
#endif
#if LAYERS_BOUND > 3
layout(set = 0, binding = 12, r32ui) uniform readonly uimage2D layer3;
#endif

#if LAYERS_BOUND > 0
// Blends (crate::layer::Blend; their codes BLEND_TINT, BLEND_UNDER, BLEND_OVER are shader_constants).
layout(push_constant) uniform Push {
    vec4 color[COMPOSITE_LAYERS]; // rgb: colour; w: weight
    vec4 blend[COMPOSITE_LAYERS]; // x: blend; tint: y from, z full; under/over: y units; w: the sun's share s
} pc;

/// One layer over the colour `c`: its texel `raw`, (colour, weight) `cw`, blend `b`; `water`: the pixel shows
/// water; `lambert`: the sun's n·l there. The blend is the same for every pixel: its branches do not diverge.
vec3 lay(vec3 c, uint raw, vec4 cw, vec4 b, bool water, float lambert) {
    if (!water && b.x != BLEND_OVER) return c;
    float t, light;
    if (b.x == BLEND_TINT) {
        t = smoothstep(b.y, b.z, abs(float(int(raw))));
        light = lambert;
    } else {
        t = 1.0 - exp(-float(raw) / b.y);
        light = 1.0;
    }
    return mix(c, cw.rgb * (frame.fluid_color.w + b.w * frame.sun.w * light), cw.w * t);
}

#define LAY(k, img) c = lay(c, imageLoad(img, p).x, pc.color[k], pc.blend[k], water, lambert)
#endif

/// Every layer over `c`, in order.
vec3 layers(vec3 c, ivec2 p, bool water, float lambert) {
#if LAYERS_BOUND > 0
    LAY(0, layer0);
#endif
#if LAYERS_BOUND > 1
    LAY(1, layer1);
#endif
#if LAYERS_BOUND > 2
    LAY(2, layer2);
#endif
#if LAYERS_BOUND > 3
    LAY(3, layer3);
#endif
    return c;
}

vec4 encode(vec3 c) { return vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0); }

/// The water at pixel p (fluid depth d, in front of the scene): refraction, reflection and the sun's highlight
/// over the fluid's colour; `lambert`: the sun's n·l there, for the layers.
vec3 water_at(ivec2 p, ivec2 size, vec2 uv, float d, out float lambert) {
    vec3 n = unpack_normal(imageLoad(normals, p).x);
    vec3 P = d * pixel_dir(vec2(p), vec2(size), focal_for(float(size.y)));
    vec3 V = normalize(-P);
    float T = max(texture(thickness, uv).x, 0.0);
    vec3 atten = exp(-frame.extinction.rgb * T);

    // Refraction: offset in pixels along the normal's screen projection (image y grows downwards).
    vec2 off = vec2(n.x, -n.y) * min(T * frame.shading.x, frame.shading.y);
    ivec2 rp = clamp(ivec2(vec2(p) + off), ivec2(0), size - 1);
    vec2 ruv = (vec2(rp) + 0.5) / vec2(size);
    // Never refract scene geometry that lies in front of the water.
    if (imageLoad(scene_depth, rp).x < d) ruv = uv;
    vec3 c_refract = texture(scene_color, ruv).rgb * atten;
    vec3 c_fluid = frame.fluid_color.rgb * frame.fluid_color.w * atten;
    float tau = exp(-frame.shading.z * T);

    float ndv = max(dot(n, V), 0.0);
    float F0 = frame.shading2.y;
    float fres = F0 + (1.0 - F0) * pow(1.0 - ndv, 5.0);
    vec3 R = mat3(frame.inv_view) * reflect(-V, n);
    // Branch-free on purpose (see common.glsl, sky()): a uniform-dependent branch here makes lavapipe 22.3 inline
    // the uniform and recompile the shader at every dispatch, leaking host memory (issue #17).
    vec3 c_reflect = sky(R) * step(0.5, frame.shading2.z);
    uint hit = imageLoad(ssr, p).x;
    if (hit != SSR_MISS) {
        vec2 huv = unpackUnorm2x16(hit);
        // Fade towards the screen border, where the missing off-screen scene would show as a hard edge.
        vec2 edge = min(huv, 1.0 - huv);
        float fade = clamp(min(edge.x, edge.y) * 10.0, 0.0, 1.0);
        c_reflect = mix(c_reflect, texture(scene_color, huv).rgb, fade);
    }

    vec3 L = mat3(frame.view) * frame.sun.xyz;
    vec3 H = normalize(L + V);
    float spec = frame.shading.w * pow(max(dot(n, H), 0.0), frame.shading2.x) * frame.sun.w;
    lambert = max(dot(n, L), 0.0);
    return mix(c_fluid, c_refract * (1.0 - fres), tau) + c_reflect * fres + vec3(spec);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_color);
    if (any(greaterThanEqual(p, size))) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    float sd = imageLoad(scene_depth, p).x;
    float d = imageLoad(fluid_depth, p).x;
    // Fluid behind nearer scene geometry is hidden. Water and background take one path to the layers and the store:
    // lavapipe runs both sides of a branch (as masked SIMD lanes), so a path each loaded every layer's texel twice.
    bool water = is_fluid(d) && d < sd;
    vec3 c = texture(scene_color, uv).rgb;
    float lambert = 0.0;
    if (water) c = water_at(p, size, uv, d, lambert);
    imageStore(out_color, p, encode(layers(c, p, water, lambert)));
}
