//! Compute programs: a pipeline, its push-descriptor set layout built from a binding table, push constants.
//! Every pass binds through push descriptors (VK_KHR_push_descriptor), so no descriptor pools exist.

use std::sync::Arc;

use ash::vk;

use super::{Buffer, FrameCtx, Gpu, Image};
use crate::error::{Error, Result, VkContext};

/// A resource bound at the binding with the same index in the program's table.
#[derive(Clone, Copy)]
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
pub fn set_layout(
    gpu: &Gpu,
    bindings: &[vk::DescriptorType],
    stages: vk::ShaderStageFlags,
) -> Result<vk::DescriptorSetLayout> {
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

/// The push-descriptor set layout of a binding table and a pipeline layout with `push_size` bytes of push
/// constants for `stages`.
fn layouts(
    gpu: &Gpu,
    bindings: &[vk::DescriptorType],
    stages: vk::ShaderStageFlags,
    push_size: u32,
) -> Result<(vk::DescriptorSetLayout, vk::PipelineLayout)> {
    let set = set_layout(gpu, bindings, stages)?;
    let ranges = [vk::PushConstantRange { stage_flags: stages, offset: 0, size: push_size }];
    let sets = [set];
    let mut lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&sets);
    if push_size > 0 {
        lci = lci.push_constant_ranges(&ranges);
    }
    let layout = unsafe { gpu.device.create_pipeline_layout(&lci, None) }.vk("vkCreatePipelineLayout")?;
    Ok((set, layout))
}

/// What every program owns: the pipeline, its layouts and its binding table (destroyed on drop).
pub struct ProgramCore {
    gpu: Arc<Gpu>,
    pub name: &'static str,
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    pub bindings: Vec<vk::DescriptorType>,
    pub push_size: u32,
}

impl Drop for ProgramCore {
    fn drop(&mut self) {
        let d = &self.gpu.device;
        unsafe {
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// A compute pipeline with its binding table.
pub struct ComputeProgram {
    pub core: ProgramCore,
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
        let (set_layout, layout) = layouts(gpu, bindings, vk::ShaderStageFlags::COMPUTE, push_size)?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let ci = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
        let pipeline = unsafe { d.create_compute_pipelines(vk::PipelineCache::null(), &ci, None) }
            .map_err(|(_, r)| Error::Vulkan { call: "vkCreateComputePipelines", result: r })?[0];
        unsafe { d.destroy_shader_module(module, None) };
        Ok(ComputeProgram {
            core: ProgramCore {
                gpu: gpu.clone(),
                name,
                pipeline,
                layout,
                set_layout,
                bindings: bindings.to_vec(),
                push_size,
            },
        })
    }

    /// Bind `res` (in binding order), push `push`, dispatch `groups`. Barriers are the caller's `begin_pass`.
    pub fn dispatch(&self, ctx: &FrameCtx, res: &[Bind], push: &[u8], groups: [u32; 3]) {
        let c = &self.core;
        debug_assert_eq!(res.len(), c.bindings.len(), "{}: binding count", c.name);
        debug_assert_eq!(push.len() as u32, c.push_size, "{}: push constant size", c.name);
        let d = &c.gpu.device;
        let cmd = ctx.cmd;
        push_descriptors(&c.gpu, cmd, vk::PipelineBindPoint::COMPUTE, c.layout, &c.bindings, res);
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, c.pipeline);
            if !push.is_empty() {
                d.cmd_push_constants(cmd, c.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
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

/// What a graphics program draws into (dynamic rendering, no render pass objects).
#[derive(Clone, Copy, Debug)]
pub struct RasterTargets {
    pub color_format: vk::Format,
    /// `None`: no depth buffer.
    pub depth_format: Option<vk::Format>,
    /// MIN-blend the colour output (with no depth test).
    pub min_blend: bool,
    pub topology: vk::PrimitiveTopology,
}

/// A graphics pipeline (vertex + fragment) with its binding table, for the rasterised splat variants.
pub struct GraphicsProgram {
    pub core: ProgramCore,
}

impl GraphicsProgram {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &'static str,
        vert: &[u8],
        frag: &[u8],
        bindings: &[vk::DescriptorType],
        push_size: u32,
        t: RasterTargets,
    ) -> Result<GraphicsProgram> {
        let d = &gpu.device;
        let stages_flags = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let (set_layout, layout) = layouts(gpu, bindings, stages_flags, push_size)?;
        let vm = shader_module(gpu, vert)?;
        let fm = shader_module(gpu, frag)?;
        let stages = [
            vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::VERTEX).module(vm).name(c"main"),
            vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::FRAGMENT).module(fm).name(c"main"),
        ];
        let vi = vk::PipelineVertexInputStateCreateInfo::default();
        let ia = vk::PipelineInputAssemblyStateCreateInfo::default().topology(t.topology);
        let vp = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
        let rs = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let ms = vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let ds = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(t.depth_format.is_some())
            .depth_write_enable(t.depth_format.is_some())
            .depth_compare_op(vk::CompareOp::GREATER);
        let blend = [vk::PipelineColorBlendAttachmentState::default()
            .blend_enable(t.min_blend)
            .src_color_blend_factor(vk::BlendFactor::ONE)
            .dst_color_blend_factor(vk::BlendFactor::ONE)
            .color_blend_op(vk::BlendOp::MIN)
            .src_alpha_blend_factor(vk::BlendFactor::ONE)
            .dst_alpha_blend_factor(vk::BlendFactor::ONE)
            .alpha_blend_op(vk::BlendOp::MIN)
            .color_write_mask(vk::ColorComponentFlags::R)];
        let cb = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend);
        let dyn_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dy = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dyn_states);
        let color_formats = [t.color_format];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(t.depth_format.unwrap_or(vk::Format::UNDEFINED));
        let ci = [vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vi)
            .input_assembly_state(&ia)
            .viewport_state(&vp)
            .rasterization_state(&rs)
            .multisample_state(&ms)
            .depth_stencil_state(&ds)
            .color_blend_state(&cb)
            .dynamic_state(&dy)
            .layout(layout)
            .push_next(&mut rendering)];
        let pipeline = unsafe { d.create_graphics_pipelines(vk::PipelineCache::null(), &ci, None) }
            .map_err(|(_, r)| Error::Vulkan { call: "vkCreateGraphicsPipelines", result: r });
        unsafe {
            d.destroy_shader_module(vm, None);
            d.destroy_shader_module(fm, None);
        }
        Ok(GraphicsProgram {
            core: ProgramCore {
                gpu: gpu.clone(),
                name,
                pipeline: pipeline?[0],
                layout,
                set_layout,
                bindings: bindings.to_vec(),
                push_size,
            },
        })
    }

    /// Draw `vertices` non-indexed into `color` (cleared to `clear`) and `depth` (cleared to 0, reversed Z).
    /// Barriers are the caller's `begin_pass` (ColorAttachment / DepthAttachment accesses).
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &self,
        ctx: &FrameCtx,
        res: &[Bind],
        push: &[u8],
        color: &Image,
        clear: f32,
        depth: Option<&Image>,
        vertices: u32,
    ) {
        let c = &self.core;
        let d = &c.gpu.device;
        let cmd = ctx.cmd;
        let area = vk::Rect2D { offset: vk::Offset2D { x: 0, y: 0 }, extent: color.extent };
        let color_att = [vk::RenderingAttachmentInfo::default()
            .image_view(color.view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: [clear; 4] } })];
        let depth_att = depth.map(|z| {
            vk::RenderingAttachmentInfo::default()
                .image_view(z.view)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 0.0, stencil: 0 } })
        });
        let mut ri = vk::RenderingInfo::default().render_area(area).layer_count(1).color_attachments(&color_att);
        if let Some(z) = depth_att.as_ref() {
            ri = ri.depth_attachment(z);
        }
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: color.extent.width as f32,
            height: color.extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        unsafe {
            d.cmd_begin_rendering(cmd, &ri);
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, c.pipeline);
            d.cmd_set_viewport(cmd, 0, &[viewport]);
            d.cmd_set_scissor(cmd, 0, &[area]);
        }
        push_descriptors(&c.gpu, cmd, vk::PipelineBindPoint::GRAPHICS, c.layout, &c.bindings, res);
        unsafe {
            d.cmd_push_constants(cmd, c.layout, vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT, 0, push);
            if vertices > 0 {
                d.cmd_draw(cmd, vertices, 1, 0, 0);
            }
            d.cmd_end_rendering(cmd);
        }
    }
}
