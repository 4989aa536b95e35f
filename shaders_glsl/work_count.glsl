//! work_count.glsl — a pass's own work counters (bench's "Work per pass": `crate::work`), added to their global
//! buffer once per subgroup: each invocation's count is summed (or maxed) over its subgroup's active lanes and
//! one lane adds the result with one atomic. An atomic per invocation on one address serialises in the memory
//! system: on an H100 it cost the iso cast 10–60 % (2 M invocations at 1080p, all on iso_work[0]). Lanes that
//! have not reconverged make partial sums, each added once: the totals are exact either way.
//! The counts are taken only in a frame that asks for them: WORK_COUNTING is a specialization constant (id 31,
//! `gpu::WORK_COUNTING_ID`), false in a program's own pipeline and true in its counting twin, which
//! a frame requested with `FrameRequest::count_work` binds — so the sums are compiled out of the frames that
//! do not count (they cost lavapipe's noise splat 15–20 %, and a uniform branch on a frame-block flag saved
//! nothing there: docs/gpu-frame.md). A shader that defines WORK_ALWAYS counts every run (iso_volume: once per
//! particle set). WORK_MAX is for maxima a later dispatch reads (noise's coarsest level): always taken.
//! Include after the counters' buffer is declared; the including shader enables GL_KHR_shader_subgroup_basic
//! and GL_KHR_shader_subgroup_arithmetic before its first declaration.
#ifdef WORK_ALWAYS
const bool WORK_COUNTING = true;
#else
layout(constant_id = 31) const bool WORK_COUNTING = false;
#endif
#define WORK_ADD(counter, value)                                                                                \
    if (WORK_COUNTING) {                                                                                       \
        uint work_sum_ = subgroupAdd(value);                                                                   \
        if (subgroupElect() && work_sum_ > 0u) atomicAdd(counter, work_sum_);                                   \
    }
#define WORK_MAX(counter, value)                                                                                \
    {                                                                                                          \
        uint work_max_ = subgroupMax(value);                                                                   \
        if (subgroupElect() && work_max_ > 0u) atomicMax(counter, work_max_);                                   \
    }
