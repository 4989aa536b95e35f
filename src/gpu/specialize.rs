//! Compute pipelines with specialization constants, and the work-counting twin: a shader that includes
//! shaders_glsl/work_count.glsl declares WORK_COUNTING (constant id [`WORK_COUNTING_ID`]); its program's own
//! pipeline has it false (the counting sums compiled out) and the twin a frame that counts binds has it true
//! (`FrameRequest::count_work`; docs/gpu-frame.md). Used by `pipeline::ComputeProgram`.

use super::Gpu;
use crate::error::{Error, Result};
use ash::vk;

/// The specialization constant id of WORK_COUNTING (shaders_glsl/work_count.glsl): past the ids the programs
/// number from 0 (`pipeline::ComputeProgram::specialized`).
pub const WORK_COUNTING_ID: u32 = 31;

/// Whether SPIR-V declares a specialization constant of id `id` (an OpDecorate … SpecId `id`).
pub(super) fn declares_spec_constant(spirv: &[u8], id: u32) -> bool {
    const OP_DECORATE: u32 = 71;
    const SPEC_ID: u32 = 1;
    let words: Vec<u32> = spirv.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let mut at = 5; // past the header
    while at < words.len() {
        let (count, op) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if count == 0 {
            return false;
        }
        if op == OP_DECORATE && count >= 4 && words.get(at + 2) == Some(&SPEC_ID) && words.get(at + 3) == Some(&id) {
            return true;
        }
        at += count;
    }
    false
}

/// A compute pipeline of `module` with the constants `constant_id = k` → `constants[k]`, and
/// WORK_COUNTING_ID → `counting` where given.
pub(super) fn compute_pipeline(
    gpu: &Gpu,
    module: vk::ShaderModule,
    layout: vk::PipelineLayout,
    constants: &[u32],
    counting: Option<bool>,
) -> Result<vk::Pipeline> {
    let mut data: Vec<u32> = constants.to_vec();
    let mut entries: Vec<vk::SpecializationMapEntry> = (0..constants.len() as u32)
        .map(|k| vk::SpecializationMapEntry::default().constant_id(k).offset(4 * k).size(4))
        .collect();
    if let Some(on) = counting {
        entries.push(
            vk::SpecializationMapEntry::default().constant_id(WORK_COUNTING_ID).offset(4 * data.len() as u32).size(4),
        );
        data.push(on as u32);
    }
    let spec = vk::SpecializationInfo::default().map_entries(&entries).data(bytemuck::cast_slice(&data));
    let mut stage =
        vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::COMPUTE).module(module).name(c"main");
    if !entries.is_empty() {
        stage = stage.specialization_info(&spec);
    }
    let ci = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
    Ok(unsafe { gpu.device.create_compute_pipelines(vk::PipelineCache::null(), &ci, None) }
        .map_err(|(_, r)| Error::Vulkan { call: "vkCreateComputePipelines", result: r })?[0])
}
