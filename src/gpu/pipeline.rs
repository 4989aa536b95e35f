//! Compute programs: a pipeline, its push-descriptor set layout built from a binding table, push constants.
//! Every pass binds through push descriptors (VK_KHR_push_descriptor), so no descriptor pools exist.

use std::sync::Arc;

use ash::vk;

use super::specialize::{compute_pipeline, declares_spec_constant, WORK_COUNTING_ID};
use super::{Access, Buffer, FrameCtx, Gpu, Image, Use};
use crate::error::{Error, Result, VkContext};

/// A compiled shader as build.rs generates it (`crate::shaders::X`): file name, SPIR-V and what reflection of
/// the SPIR-V found in it (rspirv-reflect, at build time).
pub struct Shader {
    /// `ssr.comp`, `splat_quad.vert`, …
    pub file: &'static str,
    /// The compiled SPIR-V.
    pub spirv: &'static [u8],
    /// Descriptor bindings of set 0 as (binding, `VkDescriptorType` raw value), sorted by binding. Bindings the
    /// optimizer removed because the shader never reads them are absent.
    pub bindings: &'static [(u32, i32)],
    /// Bytes of the push-constant block (0: none).
    pub push: u32,
    /// Work-group size (compute shaders; 0 otherwise).
    pub local: [u32; 3],
}

/// One binding of a program, declared once per pass: its descriptor type AND how the pass accesses the
/// resource. The slot list drives the set layout, the barrier (from the resource's last access) and the
/// descriptor write; binding number = position in the list, checked against the shader's reflection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Uniform buffer, read (binding 0 is always the frame's uniform block, common.glsl).
    Uniform,
    /// Storage buffer, read.
    BufRead,
    /// Storage buffer, read and written.
    BufWrite,
    /// Uniform texel buffer (`samplerBuffer`, read with `texelFetch`), through the buffer's texel view
    /// ([`Buffer::with_texel_view`]).
    TexelRead,
    /// Storage image, read.
    ImgRead,
    /// Storage image, read and written (keeps what was there).
    ImgWrite,
    /// Storage image, all of it written: its old contents are dropped.
    ImgOverwrite,
    /// Storage image through its second view (R32_UINT over R32_SFLOAT, for atomics), read and written.
    ImgAltWrite,
    /// Storage image through its second view, read.
    ImgAltRead,
    /// Sampled image with the GPU's linear sampler.
    Sampled,
    /// Sampled image with the GPU's nearest sampler.
    SampledNearest,
}

impl Slot {
    /// The descriptor type of the binding.
    pub const fn descriptor_type(self) -> vk::DescriptorType {
        match self {
            Slot::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
            Slot::BufRead | Slot::BufWrite => vk::DescriptorType::STORAGE_BUFFER,
            Slot::TexelRead => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            Slot::ImgRead | Slot::ImgWrite | Slot::ImgOverwrite | Slot::ImgAltWrite | Slot::ImgAltRead => {
                vk::DescriptorType::STORAGE_IMAGE
            }
            Slot::Sampled | Slot::SampledNearest => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
        }
    }

    /// Whether the slot takes a buffer (else an image).
    pub const fn is_buffer(self) -> bool {
        matches!(self, Slot::Uniform | Slot::BufRead | Slot::BufWrite | Slot::TexelRead)
    }

    /// The access (and whether old contents are dropped) for a compute or a graphics program.
    pub fn access(self, graphics: bool) -> (Access, bool) {
        match self {
            Slot::Uniform | Slot::BufRead | Slot::TexelRead | Slot::ImgRead | Slot::ImgAltRead if graphics => {
                (Access::GraphicsRead, false)
            }
            Slot::Uniform | Slot::BufRead | Slot::ImgRead | Slot::ImgAltRead => (Access::ComputeRead, false),
            Slot::TexelRead => (Access::ComputeSampled, false),
            Slot::BufWrite | Slot::ImgWrite | Slot::ImgAltWrite => (Access::ComputeWrite, false),
            Slot::ImgOverwrite => (Access::ComputeWrite, true),
            Slot::Sampled | Slot::SampledNearest => (Access::ComputeSampled, false),
        }
    }
}

/// A resource given for a slot.
#[derive(Clone, Copy)]
pub enum Res<'a> {
    /// An image.
    Img(&'a Image),
    /// A buffer.
    Buf(&'a Buffer),
}

impl<'a> From<&'a Image> for Res<'a> {
    fn from(i: &'a Image) -> Self {
        Res::Img(i)
    }
}

impl<'a> From<&'a Buffer> for Res<'a> {
    fn from(b: &'a Buffer) -> Self {
        Res::Buf(b)
    }
}

/// A program declared once: its shader(s), its slot list and its push-constant type `P` (size derived).
pub struct ProgramDecl<P> {
    /// Compute: the shader; graphics: the vertex shader.
    pub shader: &'static Shader,
    /// Graphics: the fragment shader.
    pub fragment: Option<&'static Shader>,
    /// The slot list: binding i is slot i.
    pub slots: &'static [Slot],
    _push: std::marker::PhantomData<P>,
}

impl<P: bytemuck::Pod> ProgramDecl<P> {
    /// A compute program.
    pub const fn compute(shader: &'static Shader, slots: &'static [Slot]) -> Self {
        ProgramDecl { shader, fragment: None, slots, _push: std::marker::PhantomData }
    }

    /// A graphics program (vertex + fragment share the slot list and the push constants).
    pub const fn graphics(vert: &'static Shader, frag: &'static Shader, slots: &'static [Slot]) -> Self {
        ProgramDecl { shader: vert, fragment: Some(frag), slots, _push: std::marker::PhantomData }
    }

    /// Push-constant bytes: the size of `P`, never a literal.
    pub const fn push_size(&self) -> u32 {
        std::mem::size_of::<P>() as u32
    }

    /// `None` when the slot list, the push type and the shader(s) agree; else what disagrees. A `const`
    /// evaluation of this in each pass module turns a mismatch into a build error (see [`declare_program!`]).
    pub const fn mismatch(&self) -> Option<&'static str> {
        if let Some(e) = shader_mismatch(self.shader, self.slots, self.push_size()) {
            return Some(e);
        }
        if let Some(f) = self.fragment {
            // A fragment shader without push constants is fine (the vertex stage reads them).
            let push = if f.push == 0 { 0 } else { self.push_size() };
            if let Some(e) = shader_mismatch(f, self.slots, push) {
                return Some(e);
            }
        }
        // Every declared slot is in some stage (binding 0, the frame's uniform block, may be in none).
        let mut i = 1;
        while i < self.slots.len() {
            if !has_binding(self.shader, i) && !matches!(self.fragment, Some(f) if has_binding(f, i)) {
                return Some("the pass declares a binding the shader does not have");
            }
            i += 1;
        }
        None
    }

    /// The same check with the binding numbers and types spelled out (runtime and tests).
    pub fn check(&self) -> Result<()> {
        for sh in std::iter::once(self.shader).chain(self.fragment) {
            let push =
                if self.fragment.is_some_and(|f| std::ptr::eq(f, sh)) && sh.push == 0 { 0 } else { self.push_size() };
            if let Some(e) = shader_mismatch(sh, self.slots, push).or(self.mismatch()) {
                let declared: Vec<String> =
                    self.slots.iter().enumerate().map(|(i, s)| format!("{i}={:?}", s.descriptor_type())).collect();
                let reflected: Vec<String> =
                    sh.bindings.iter().map(|(b, t)| format!("{b}={:?}", vk::DescriptorType::from_raw(*t))).collect();
                return Err(Error::Invalid(format!(
                    "shaders_glsl/{}: {e}: the pass declares [{}] and {} push bytes, the SPIR-V has [{}] and {} push bytes",
                    sh.file,
                    declared.join(", "),
                    self.push_size(),
                    reflected.join(", "),
                    sh.push
                )));
            }
        }
        Ok(())
    }
}

/// Every reflected binding of `sh` must be the declared slot at that index, with the same descriptor type; the
/// push block must be `P`'s size (absent when `P` is `()`). (That every slot is in some stage is checked by
/// [`ProgramDecl::mismatch`].)
const fn shader_mismatch(sh: &Shader, slots: &[Slot], push: u32) -> Option<&'static str> {
    let mut k = 0;
    while k < sh.bindings.len() {
        let (b, t) = sh.bindings[k];
        if b as usize >= slots.len() {
            return Some("the shader has a binding the pass does not declare");
        }
        if slots[b as usize].descriptor_type().as_raw() != t {
            return Some("a binding's descriptor type differs");
        }
        k += 1;
    }
    if sh.push != push {
        return Some("the push-constant size differs");
    }
    None
}

/// Whether the shader has binding `i`.
const fn has_binding(sh: &Shader, i: usize) -> bool {
    let mut k = 0;
    while k < sh.bindings.len() {
        if sh.bindings[k].0 as usize == i {
            return true;
        }
        k += 1;
    }
    false
}

/// Declare a pass's program as a `const` and check it against the shader's reflection at build time:
/// `declare_program!(PROGRAM: Push = compute(shaders::SSR, [Uniform, ImgRead, ImgOverwrite]));`
#[macro_export]
macro_rules! declare_program {
    ($vis:vis $name:ident : $push:ty = compute($shader:expr, [$($slot:ident),* $(,)?])) => {
        #[doc = concat!("The program of `", stringify!($shader), "`: slots [", stringify!($($slot),*), "], push `", stringify!($push), "` (checked against the SPIR-V at compile time).")]
        $vis const $name: $crate::gpu::ProgramDecl<$push> =
            $crate::gpu::ProgramDecl::compute(&$shader, &[$($crate::gpu::Slot::$slot),*]);
        const _: () = if let Some(e) = $name.mismatch() { panic!("{}", e) };
    };
    ($vis:vis $name:ident : $push:ty = graphics($vert:expr, $frag:expr, [$($slot:ident),* $(,)?])) => {
        #[doc = concat!("The program of `", stringify!($vert), "` + `", stringify!($frag), "`: slots [", stringify!($($slot),*), "], push `", stringify!($push), "` (checked against the SPIR-V at compile time).")]
        $vis const $name: $crate::gpu::ProgramDecl<$push> =
            $crate::gpu::ProgramDecl::graphics(&$vert, &$frag, &[$($crate::gpu::Slot::$slot),*]);
        const _: () = if let Some(e) = $name.mismatch() { panic!("{}", e) };
    };
}

/// Create a shader module from SPIR-V bytes (re-aligned to u32 by `read_spv`).
pub fn shader_module(gpu: &Gpu, spirv: &[u8]) -> Result<vk::ShaderModule> {
    let words = ash::util::read_spv(&mut std::io::Cursor::new(spirv))
        .map_err(|e| Error::Invalid(format!("bad SPIR-V: {e}")))?;
    let ci = vk::ShaderModuleCreateInfo::default().code(&words);
    unsafe { gpu.device.create_shader_module(&ci, None) }.vk("vkCreateShaderModule")
}

/// Push-descriptor set layout for a slot list, visible to `stages`.
pub fn set_layout(gpu: &Gpu, slots: &[Slot], stages: vk::ShaderStageFlags) -> Result<vk::DescriptorSetLayout> {
    let b: Vec<_> = slots
        .iter()
        .enumerate()
        .map(|(i, t)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i as u32)
                .descriptor_type(t.descriptor_type())
                .descriptor_count(1)
                .stage_flags(stages)
        })
        .collect();
    let ci = vk::DescriptorSetLayoutCreateInfo::default()
        .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
        .bindings(&b);
    unsafe { gpu.device.create_descriptor_set_layout(&ci, None) }.vk("vkCreateDescriptorSetLayout")
}

/// The push-descriptor set layout of a slot list and a pipeline layout with `push_size` bytes of push
/// constants for `stages`.
pub(super) fn layouts(
    gpu: &Gpu,
    slots: &[Slot],
    stages: vk::ShaderStageFlags,
    push_size: u32,
) -> Result<(vk::DescriptorSetLayout, vk::PipelineLayout)> {
    let set = set_layout(gpu, slots, stages)?;
    let ranges = [vk::PushConstantRange { stage_flags: stages, offset: 0, size: push_size }];
    let sets = [set];
    let mut lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&sets);
    if push_size > 0 {
        lci = lci.push_constant_ranges(&ranges);
    }
    let layout = unsafe { gpu.device.create_pipeline_layout(&lci, None) }.vk("vkCreatePipelineLayout")?;
    Ok((set, layout))
}

/// What every program owns: the pipeline, its layouts and its slot list (destroyed on drop).
pub struct ProgramCore {
    pub(super) gpu: Arc<Gpu>,
    /// The shader file (debug names and messages).
    pub file: &'static str,
    /// The pipeline.
    pub pipeline: vk::Pipeline,
    /// Its layout (push constants + the push-descriptor set).
    pub layout: vk::PipelineLayout,
    /// The push-descriptor set layout.
    pub set_layout: vk::DescriptorSetLayout,
    /// The slot list the layout was built from.
    pub slots: &'static [Slot],
    stages: vk::ShaderStageFlags,
    /// A compute shader that counts its work (declares WORK_COUNTING, shaders_glsl/work_count.glsl): its SPIR-V
    /// and specialization constants, for the counting twin built at the first frame that counts.
    counting: Option<Box<(&'static [u8], Vec<u32>)>>,
    /// The counting twin of `pipeline` (WORK_COUNTING = true), once built.
    counted: std::sync::OnceLock<vk::Pipeline>,
}

impl ProgramCore {
    /// A program's core: `pipeline` with its layouts, built from `decl`'s shader and slots for `stages`;
    /// `counting`: a compute shader that counts its work, with the specialization constants its pipeline got.
    pub(super) fn new<P>(
        gpu: &Arc<Gpu>,
        decl: &ProgramDecl<P>,
        (pipeline, layout, set_layout): (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSetLayout),
        stages: vk::ShaderStageFlags,
        counting: Option<Vec<u32>>,
    ) -> ProgramCore {
        gpu.name_object(pipeline, decl.shader.file);
        ProgramCore {
            gpu: gpu.clone(),
            file: decl.shader.file,
            pipeline,
            layout,
            set_layout,
            slots: decl.slots,
            stages,
            counting: counting.map(|c| Box::new((decl.shader.spirv, c))),
            counted: std::sync::OnceLock::new(),
        }
    }

    /// The pipeline to bind: the counting twin when `count_work` and the shader counts (built here the first
    /// time: a frame that counts pays its compile once), else the program's own. Should the twin fail to build,
    /// the program's own is bound and the pass's counts read 0.
    pub fn pipeline_for(&self, count_work: bool) -> vk::Pipeline {
        let Some((spirv, constants)) = self.counting.as_deref().filter(|_| count_work) else { return self.pipeline };
        *self.counted.get_or_init(|| {
            let build = || -> Result<vk::Pipeline> {
                let module = shader_module(&self.gpu, spirv)?;
                let p = compute_pipeline(&self.gpu, module, self.layout, constants, Some(true));
                unsafe { self.gpu.device.destroy_shader_module(module, None) };
                let p = p?;
                self.gpu.name_object(p, self.file);
                Ok(p)
            };
            build().unwrap_or(self.pipeline)
        })
    }
}

impl Drop for ProgramCore {
    fn drop(&mut self) {
        let d = &self.gpu.device;
        unsafe {
            if let Some(&p) = self.counted.get().filter(|&&p| p != self.pipeline) {
                d.destroy_pipeline(p, None);
            }
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

impl ProgramCore {
    /// Derive the barriers for `res` from the slots (one batch), then push the descriptors.
    pub(super) fn bind(&self, ctx: &mut FrameCtx, bind_point: vk::PipelineBindPoint, res: &[Res]) {
        assert_eq!(
            res.len(),
            self.slots.len(),
            "{}: {} resources for {} slots",
            self.file,
            res.len(),
            self.slots.len()
        );
        let graphics = bind_point == vk::PipelineBindPoint::GRAPHICS;
        let mut uses: Vec<Use> = Vec::with_capacity(res.len());
        for (i, (slot, r)) in self.slots.iter().zip(res).enumerate() {
            let (access, discard) = slot.access(graphics);
            match (*r, slot.is_buffer()) {
                (Res::Buf(b), true) => uses.push(Use::Buffer(b, access)),
                (Res::Img(img), false) => {
                    // An image bound twice (e.g. a stand-in for an unused optional input) is one use: a write
                    // if either slot writes, and never a discard then.
                    let twin = uses.iter_mut().find(|u| matches!(u, Use::Image(o, ..) if std::ptr::eq(*o, img)));
                    match twin {
                        Some(Use::Image(_, a, d)) => {
                            if access.info().writes {
                                *a = access;
                            }
                            *d = false;
                        }
                        _ => uses.push(Use::Image(img, access, discard)),
                    }
                }
                _ => panic!("{}: binding {i} is a {slot:?} slot, given the other kind of resource", self.file),
            }
        }
        ctx.barrier(&uses);
        push_descriptors(&self.gpu, ctx.cmd, bind_point, self.layout, self.slots, res);
    }

    pub(super) fn push<P: bytemuck::Pod>(&self, cmd: vk::CommandBuffer, push: &P) {
        let bytes = bytemuck::bytes_of(push);
        if !bytes.is_empty() {
            unsafe { self.gpu.device.cmd_push_constants(cmd, self.layout, self.stages, 0, bytes) };
        }
    }
}

/// A compute pipeline built from its [`ProgramDecl`]; `P` is its push-constant type.
pub struct ComputeProgram<P = ()> {
    /// Pipeline, layouts and slots.
    pub core: ProgramCore,
    _push: std::marker::PhantomData<P>,
}

impl<P: bytemuck::Pod> ComputeProgram<P> {
    /// Build from the declaration (checked against the shader's reflection again, with the details).
    pub fn new(gpu: &Arc<Gpu>, decl: &ProgramDecl<P>) -> Result<Self> {
        Self::specialized(gpu, decl, &[])
    }

    /// [`ComputeProgram::new`] with the shader's specialization constants `constant_id = k` set to
    /// `constants[k]` (32-bit each; the shader's defaults for the rest). The driver folds them like literals, so a
    /// setting fixed for the program's life costs nothing in its loops (e.g. sim_solve's s_corr exponent).
    pub fn specialized(gpu: &Arc<Gpu>, decl: &ProgramDecl<P>, constants: &[u32]) -> Result<Self> {
        decl.check()?;
        let push_size = decl.push_size();
        let file = decl.shader.file;
        if push_size > 128 {
            return Err(Error::Invalid(format!("push constants of {file} exceed 128 bytes (lavapipe's limit)")));
        }
        let d = &gpu.device;
        let module = shader_module(gpu, decl.shader.spirv)?;
        let stages = vk::ShaderStageFlags::COMPUTE;
        let (set_layout, layout) = layouts(gpu, decl.slots, stages, push_size)?;
        // A shader that counts its work gets WORK_COUNTING = false here: its counting sums compiled out of the
        // frames that do not ask for them (they cost lavapipe's noise splat 15–20 %: docs/gpu-frame.md).
        let counts = declares_spec_constant(decl.shader.spirv, WORK_COUNTING_ID);
        let pipeline = compute_pipeline(gpu, module, layout, constants, counts.then_some(false));
        unsafe { d.destroy_shader_module(module, None) };
        let counting = counts.then(|| constants.to_vec());
        let core = ProgramCore::new(gpu, decl, (pipeline?, layout, set_layout), stages, counting);
        Ok(ComputeProgram { core, _push: std::marker::PhantomData })
    }

    /// Barriers for `res` (derived from each resource's last access and its slot), bind `res` (in slot order),
    /// push `push`, dispatch `groups`.
    pub fn dispatch(&self, ctx: &mut FrameCtx, res: &[Res], push: &P, groups: [u32; 3]) {
        let c = &self.core;
        c.bind(ctx, vk::PipelineBindPoint::COMPUTE, res);
        unsafe {
            c.gpu.device.cmd_bind_pipeline(ctx.cmd, vk::PipelineBindPoint::COMPUTE, c.pipeline_for(ctx.count_work))
        };
        c.push(ctx.cmd, push);
        if groups.iter().all(|&g| g > 0) {
            unsafe { c.gpu.device.cmd_dispatch(ctx.cmd, groups[0], groups[1], groups[2]) };
        }
    }
}

impl<P: bytemuck::Pod> ComputeProgram<P> {
    /// As [`ComputeProgram::dispatch`], with the workgroup counts read by the device from the 12 bytes of `args`
    /// at `offset` (a `VkDispatchIndirectCommand` an earlier dispatch wrote; its barrier derived like any other
    /// use).
    pub fn dispatch_indirect(&self, ctx: &mut FrameCtx, res: &[Res], push: &P, args: &Buffer, offset: u64) {
        let c = &self.core;
        // The arguments are read before the dispatch's shaders run: their barrier comes first, so a dispatch that
        // also writes its arguments' buffer (the `iso` cast's, counting the queued rays in its header) waits for
        // the writes before it as an indirect read, and its own writes wait for that read.
        ctx.barrier(&[Use::Buffer(args, Access::IndirectRead)]);
        c.bind(ctx, vk::PipelineBindPoint::COMPUTE, res);
        unsafe {
            c.gpu.device.cmd_bind_pipeline(ctx.cmd, vk::PipelineBindPoint::COMPUTE, c.pipeline_for(ctx.count_work))
        };
        c.push(ctx.cmd, push);
        unsafe { c.gpu.device.cmd_dispatch_indirect(ctx.cmd, args.raw, offset) };
    }
}

/// Workgroups of `local`×`local` covering a `w`×`h` image.
pub fn groups_2d(w: u32, h: u32, local: u32) -> [u32; 3] {
    [w.div_ceil(local), h.div_ceil(local), 1]
}

/// Record push-descriptor writes for `res` against the slot list.
pub fn push_descriptors(
    gpu: &Gpu,
    cmd: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    slots: &[Slot],
    res: &[Res],
) {
    let mut images = Vec::with_capacity(res.len());
    let mut buffers = Vec::with_capacity(res.len());
    let mut texels = Vec::with_capacity(res.len());
    for (slot, r) in slots.iter().zip(res) {
        match (*slot, *r) {
            (Slot::TexelRead, Res::Buf(b)) => texels.push(
                b.texel_view
                    .unwrap_or_else(|| panic!("buffer {} is bound to a TexelRead slot without a texel view", b.name)),
            ),
            (_, Res::Buf(b)) => {
                buffers.push(vk::DescriptorBufferInfo { buffer: b.raw, offset: 0, range: vk::WHOLE_SIZE })
            }
            (Slot::Sampled | Slot::SampledNearest, Res::Img(i)) => images.push(vk::DescriptorImageInfo {
                sampler: if *slot == Slot::Sampled { gpu.linear_sampler } else { gpu.nearest_sampler },
                image_view: i.view,
                image_layout: i.state.get().layout,
            }),
            (_, Res::Img(i)) => images.push(vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: if matches!(slot, Slot::ImgAltWrite | Slot::ImgAltRead) {
                    i.alt_view.unwrap_or(i.view)
                } else {
                    i.view
                },
                image_layout: i.state.get().layout,
            }),
        }
    }
    let (mut ii, mut bi, mut ti) = (0, 0, 0);
    let writes: Vec<_> = slots
        .iter()
        .enumerate()
        .map(|(k, slot)| {
            let w = vk::WriteDescriptorSet::default().dst_binding(k as u32).descriptor_type(slot.descriptor_type());
            if *slot == Slot::TexelRead {
                ti += 1;
                w.texel_buffer_view(std::slice::from_ref(&texels[ti - 1]))
            } else if slot.is_buffer() {
                bi += 1;
                w.buffer_info(std::slice::from_ref(&buffers[bi - 1]))
            } else {
                ii += 1;
                w.image_info(std::slice::from_ref(&images[ii - 1]))
            }
        })
        .collect();
    unsafe { gpu.push_descriptor.cmd_push_descriptor_set(cmd, bind_point, layout, 0, &writes) };
}

#[cfg(test)]
mod tests;
