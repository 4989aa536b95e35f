//! Graphics programs (vertex + fragment) for the passes that rasterise: the splat's measured variants and the live
//! mesh surface's draw. Built from a [`ProgramDecl`] like the compute programs (src/gpu/pipeline.rs), with dynamic
//! rendering (no render pass objects), reversed-Z depth, optional MIN blending; draws with a host-known or a
//! device-written vertex count. The barriers of the attachments and of an indirect draw's arguments are derived.
use std::sync::Arc;

use ash::vk;

use super::pipeline::{layouts, shader_module, ProgramCore, ProgramDecl, Res};
use super::{Access, Buffer, FrameCtx, Gpu, Image, Use};
use crate::error::{Error, Result};

/// What a graphics program draws into (dynamic rendering, no render pass objects).
#[derive(Clone, Copy, Debug)]
pub struct RasterTargets {
    /// Format of the colour attachment.
    pub color_format: vk::Format,
    /// `None`: no depth buffer.
    pub depth_format: Option<vk::Format>,
    /// MIN-blend the colour output (with no depth test).
    pub min_blend: bool,
    /// Points or triangles.
    pub topology: vk::PrimitiveTopology,
}

/// A graphics pipeline (vertex + fragment) built from its [`ProgramDecl`], for the rasterised splat variants:
/// reversed-Z depth (GREATER, cleared to 0) when a depth format is given, MIN blending or plain writes of one
/// red channel (`RasterTargets`).
pub struct GraphicsProgram<P> {
    /// Pipeline, layouts and slots.
    pub core: ProgramCore,
    _push: std::marker::PhantomData<P>,
}

impl<P: bytemuck::Pod> GraphicsProgram<P> {
    /// Build from the declaration (checked against both shaders' reflection) for the attachments `t`.
    pub fn new(gpu: &Arc<Gpu>, decl: &ProgramDecl<P>, t: RasterTargets) -> Result<Self> {
        decl.check()?;
        let frag = decl.fragment.ok_or_else(|| Error::Invalid(format!("{}: no fragment shader", decl.shader.file)))?;
        let d = &gpu.device;
        let stages_flags = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let (set_layout, layout) = layouts(gpu, decl.slots, stages_flags, decl.push_size())?;
        let vm = shader_module(gpu, decl.shader.spirv)?;
        let fm = shader_module(gpu, frag.spirv)?;
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
        let core = ProgramCore::new(gpu, decl, (pipeline?[0], layout, set_layout), stages_flags, None);
        Ok(GraphicsProgram { core, _push: std::marker::PhantomData })
    }

    /// Draw `vertices` non-indexed into `color` (cleared to `clear`) and `depth` (cleared to 0, reversed Z).
    /// The barriers (slots, colour and depth attachments, both overwritten) are derived here.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &self,
        ctx: &mut FrameCtx,
        res: &[Res],
        push: &P,
        color: &Image,
        clear: f32,
        depth: Option<&Image>,
        vertices: u32,
    ) {
        self.record(ctx, res, push, (color, clear, depth), DrawCount::Vertices(vertices));
    }

    /// As [`GraphicsProgram::draw`], with the vertex count read by the device from the `VkDrawIndirectCommand`
    /// at byte `offset` of `args` (an earlier dispatch wrote it; its barrier derived like any other use).
    pub fn draw_indirect(
        &self,
        ctx: &mut FrameCtx,
        res: &[Res],
        push: &P,
        (color, clear, depth): (&Image, f32, Option<&Image>),
        args: &Buffer,
        offset: u64,
    ) {
        self.record(ctx, res, push, (color, clear, depth), DrawCount::Indirect(args, offset));
    }

    fn record(
        &self,
        ctx: &mut FrameCtx,
        res: &[Res],
        push: &P,
        (color, clear, depth): (&Image, f32, Option<&Image>),
        count: DrawCount,
    ) {
        let c = &self.core;
        let mut attachments = vec![Use::Image(color, Access::ColorAttachment, true)];
        if let Some(z) = depth {
            attachments.push(Use::Image(z, Access::DepthAttachment, true));
        }
        if let DrawCount::Indirect(args, _) = count {
            attachments.push(Use::Buffer(args, Access::IndirectRead));
        }
        ctx.barrier(&attachments);
        c.bind(ctx, vk::PipelineBindPoint::GRAPHICS, res);
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
        c.push(cmd, push);
        unsafe {
            match count {
                DrawCount::Vertices(0) => {}
                DrawCount::Vertices(n) => d.cmd_draw(cmd, n, 1, 0, 0),
                DrawCount::Indirect(args, offset) => d.cmd_draw_indirect(cmd, args.raw, offset, 1, 0),
            }
            d.cmd_end_rendering(cmd);
        }
    }
}

/// How many vertices a draw has: known on the host, or written by the device.
#[derive(Clone, Copy)]
enum DrawCount<'a> {
    Vertices(u32),
    Indirect(&'a Buffer, u64),
}
