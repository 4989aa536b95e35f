#version 460
//! sim_neighbours — every particle's neighbour list, once per step (Macklin & Müller 2013, Alg. 1 lines 5–7):
//! the particles within h of it at the predicted positions (itself excluded), found through the `grid` pass's
//! cells, at most MAX_NEIGHBOURS (a compressed particle past that keeps the nearest cells' first ones; the
//! overflow count is reported). The solver's loops then visit ~30 neighbours instead of ~200 candidates.
//! In: counts, start (grid), pred (grid order). Out: nbr_count, nbrs (MAX_NEIGHBOURS slots, slot-major: slot k of
//! particle i in word k × capacity + i; or, in a simulation of at most 65,536 particles, 16-bit slots 8q … 8q + 7
//! in the 16-byte texel q × capacity + i, word w = slot / 2 holding slots 2w and 2w + 1 as its low and high
//! halves, which the readers fetch eight at a time: sim_common.glsl's FOR_NEIGHBOURS), overflow.
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer counts;
layout(binding = 2) uniform usamplerBuffer start;
layout(binding = 3) uniform samplerBuffer pred;
layout(std430, binding = 4) writeonly buffer NbrCount { uint nbr_count[]; };
layout(std430, binding = 5) writeonly buffer Nbrs { uint nbrs[]; };
layout(std430, binding = 6) buffer Overflow { uint overflow[]; };

// Where word w of particle i's list lies: 32-bit lists, word w × capacity + i; 16-bit ones, component w mod 4 of
// texel ⌊w / 4⌋ × capacity + i.
uint slot_word(uint w, uint i) {
#ifdef NBR16
    return ((w >> 2u) * sim.counts.z + i) * 4u + (w & 3u);
#else
    return w * sim.counts.z + i;
#endif
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xi = texelFetch(pred, int(i)).xyz;
    float h2 = sim.kern.x;
    uint n = 0u;
    bool full = false;
    // 16-bit lists (compiled with NBR16: at most 65,536 particles): two indices per word, the even slot low.
#ifdef NBR16
    const bool packed = true;
#else
    const bool packed = false;
#endif
    uint low = 0u;
    // Candidates are tested 32 at a time into a bit mask, and only the mask's set bits are written. Why: a
    // store under a per-lane condition is a loop over the lanes on lavapipe, so writing inside the candidate
    // loop paid that loop for all ~200 candidates, not for the ~30 neighbours (13 of the pass's 21 ms at 59k).
    // The lists come out the same: ascending places, the nearest rows first.
    FOR_ROWS(xi, s, e)
        for (uint c = s; c < e; c += 32u) {
            uint m = 0u;
            uint ce = min(c + 32u, e);
            for (uint j = c; j < ce; ++j) {
                vec3 r = xi - texelFetch(pred, int(j)).xyz;
                m |= (dot(r, r) < h2 ? 1u : 0u) << (j - c);
            }
            // The particle itself, once per chunk rather than tested for every candidate.
            m &= (i >= c && i < ce) ? ~(1u << (i - c)) : 0xffffffffu;
            // One store site per iteration, so the lanes' stores are one loop: 32-bit lists store each index;
            // 16-bit lists store a pair per iteration (two bits taken at once, or the odd one left over from the
            // last mask completed), which halves the iterations and the stores.
            while (m != 0u) {
                uint j = c + uint(findLSB(m));
                m &= m - 1u;
                if (n >= MAX_NEIGHBOURS) {
                    full = true;
                    break;
                }
                uint at = n, word = j;
                bool store = true;
                if (!packed) {
                    n += 1u;
                } else if ((n & 1u) == 1u) {
                    at = n >> 1u;
                    word = low | (j << 16u);
                    n += 1u;
                } else if (m != 0u) {
                    at = n >> 1u;
                    word = j | ((c + uint(findLSB(m))) << 16u);
                    m &= m - 1u;
                    n += 2u;
                } else {
                    low = j;
                    n += 1u;
                    store = false;
                }
                if (store) nbrs[slot_word(at, i)] = word;
            }
        }
    END_ROWS
    if (packed && (n & 1u) == 1u) nbrs[slot_word(n >> 1u, i)] = low;
    nbr_count[i] = n;
    if (full) atomicAdd(overflow[0], 1u);
}
