//! Compute programs: a pipeline, its push-descriptor set layout built from a binding table, push constants.
//! Every pass binds through push descriptors (VK_KHR_push_descriptor), so no descriptor pools exist.

use std::sync::Arc;

use ash::vk;

use super::{Buffer, FrameCtx, Gpu, Image};
use crate::error::{Error, Result, VkContext};

/// A resource bound at the binding with the same index in the program's table.
pub enum Bind<'a> {
    /// Storage image through its main view.
    Storage(&'a Image),
    /// Storage image through its second view (e.g. R32_UINT for atomics).
    StorageAlt(&'a Image),
    /// Sampled image with the GPU's linear sampler.
    Linear(&'a Image),
    /// Sampled image with the GPU's nearest sampler.
    Nearest(&'a Image),
    /// Uniform buffer.
    Uniform(&'a Buffer),
    /// Storage buffer.
    StorageBuf(&'a Buffer),
}

/// Create a shader module from SPIR-V bytes (re-aligned to u32 by `read_spv`).
pub fn shader_module(gpu: &Gpu, spirv: &[u8]) -> Result<vk::ShaderModule> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
        .map_err(|e| Error::Invalid(format!("bad SPIR-V: {e}")))?;
    let ci = vk::ShaderModuleCreateInfo::default().code(&words);
    unsafe { gpu.device.create_shader_module(&ci, None) }.vk("vkCreateShaderModule")
}

/// Push-descriptor set layout for a binding table, visible to `stages`.
pub fn set_layout(gpu: &Gpu, bindings: &[vk::DescriptorType], stages: vk::ShaderStageFlags) -> Result<vk::DescriptorSetLayout> {
    let b: Vec<_> = bindings
        .iter()
        .enumerate()
        .map(|(i, t)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i as u32)
                .descriptor_type(*t)
                .descriptor_count(1)
                .stage_flags(stages)
        })
        .collect();
    let ci = vk::DescriptorSetLayoutCreateInfo::default()
        .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
        .bindings(&b);
    unsafe { gpu.device.create_descriptor_set_layout(&ci, None) }.vk("vkCreateDescriptorSetLayout")
}

/// A compute pipeline with its binding table.
pub struct ComputeProgram {
    gpu: Arc<Gpu>,
    pub name: &'static str,
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    pub bindings: Vec<vk::DescriptorType>,
    pub push_size: u32,
}

/// Shorthands for binding tables.
pub mod bt {
    use ash::vk::DescriptorType as D;
    pub const UBO: D = D::UNIFORM_BUFFER;
    pub const SSBO: D = D::STORAGE_BUFFER;
    pub const IMG: D = D::STORAGE_IMAGE;
    pub const TEX: D = D::COMBINED_IMAGE_SAMPLER;
}

impl ComputeProgram {
    /// Build from SPIR-V. `push_size` bytes of push constants (≤ 128: lavapipe's limit).
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &'static str,
        spirv: &[u8],
        bindings: &[vk::DescriptorType],
        push_size: u32,
    ) -> Result<ComputeProgram> {
        assert!(push_size <= 128, "push constants of {name} exceed 128 bytes");
        let d = &gpu.device;
        let module = shader_module(gpu, spirv)?;
        let set_layout = set_layout(gpu, bindings, vk::ShaderStageFlags::COMPUTE)?;
        let ranges = [vk::PushConstantRange { stage_flags: vk::ShaderStageFlags::COMPUTE, offset: 0, size: push_size }];
        let layouts = [set_layout];
        let mut lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&layouts);
        if push_size > 0 {
            lci = lci.push_constant_ranges(&ranges);
        }
        let layout = unsafe { d.create_pipeline_layout(&lci, None) }.vk("vkCreatePipelineLayout")?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let ci = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
        let pipeline = unsafe { d.create_compute_pipelines(vk::PipelineCache::null(), &ci, None) }
            .map_err(|(_, r)| Error::Vulkan { call: "vkCreateComputePipelines", result: r })?[0];
        unsafe { d.destroy_shader_module(module, None) };
        Ok(ComputeProgram { gpu: gpu.clone(), name, pipeline, layout, set_layout, bindings: bindings.to_vec(), push_size })
    }

    /// Bind `res` (in binding order), push `push`, dispatch `groups`. Barriers are the caller's `begin_pass`.
    pub fn dispatch(&self, ctx: &FrameCtx, res: &[Bind], push: &[u8], groups: [u32; 3]) {
        debug_assert_eq!(res.len(), self.bindings.len(), "{}: binding count", self.name);
        debug_assert_eq!(push.len() as u32, self.push_size, "{}: push constant size", self.name);
        let d = &self.gpu.device;
        let cmd = ctx.cmd;
        push_descriptors(&self.gpu, cmd, vk::PipelineBindPoint::COMPUTE, self.layout, &self.bindings, res);
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            if !push.is_empty() {
                d.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            }
            if groups.iter().all(|&g| g > 0) {
                d.cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
            }
        }
    }

    /// Workgroups of `local`×`local` covering a `w`×`h` image.
    pub fn groups_2d(w: u32, h: u32, local: u32) -> [u32; 3] {
        [w.div_ceil(local), h.div_ceil(local), 1]
    }
}

/// Record push-descriptor writes for `res` against the binding table `types`.
pub fn push_descriptors(
    gpu: &Gpu,
    cmd: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    types: &[vk::DescriptorType],
    res: &[Bind],
) {
    let mut images = Vec::with_capacity(res.len());
    let mut buffers = Vec::with_capacity(res.len());
    for r in res {
        match *r {
            Bind::Storage(i) => images.push(vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: i.view,
                image_layout: vk::ImageLayout::GENERAL,
            }),
            Bind::StorageAlt(i) => images.push(vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: i.alt_view.unwrap_or(i.view),
                image_layout: vk::ImageLayout::GENERAL,
            }),
            Bind::Linear(i) | Bind::Nearest(i) => images.push(vk::DescriptorImageInfo {
                sampler: if matches!(r, Bind::Linear(_)) { gpu.linear_sampler } else { gpu.nearest_sampler },
                image_view: i.view,
                image_layout: i.state.get().layout,
            }),
            Bind::Uniform(b) | Bind::StorageBuf(b) => {
                buffers.push(vk::DescriptorBufferInfo { buffer: b.raw, offset: 0, range: vk::WHOLE_SIZE })
            }
        }
    }
    let (mut ii, mut bi) = (0, 0);
    let writes: Vec<_> = res
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let w = vk::WriteDescriptorSet::default().dst_binding(k as u32).descriptor_type(types[k]);
            match r {
                Bind::Uniform(_) | Bind::StorageBuf(_) => {
                    bi += 1;
                    w.buffer_info(std::slice::from_ref(&buffers[bi - 1]))
                }
                _ => {
                    ii += 1;
                    w.image_info(std::slice::from_ref(&images[ii - 1]))
                }
            }
        })
        .collect();
    unsafe { gpu.push_descriptor.cmd_push_descriptor_set(cmd, bind_point, layout, 0, &writes) };
}

impl Drop for ComputeProgram {
    fn drop(&mut self) {
        let d = &self.gpu.device;
        unsafe {
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
