//! Tests of gpu/pipeline.rs: a program's slot list and push constants checked against the shader's reflection.

use super::*;

const UBO: i32 = vk::DescriptorType::UNIFORM_BUFFER.as_raw();
const IMG: i32 = vk::DescriptorType::STORAGE_IMAGE.as_raw();
const SSBO: i32 = vk::DescriptorType::STORAGE_BUFFER.as_raw();

fn shader(bindings: &'static [(u32, i32)], push: u32) -> &'static Shader {
    Box::leak(Box::new(Shader { file: "test.comp", spirv: &[], bindings, push, local: [8, 8, 1] }))
}

fn decl<P: bytemuck::Pod>(sh: &'static Shader, slots: &'static [Slot]) -> ProgramDecl<P> {
    ProgramDecl::compute(sh, slots)
}

/// The checker behind `declare_program!`: agreement passes; a moved binding, a wrong type, a missing or an
/// extra binding and a wrong push size are each caught; binding 0 (the frame block) may be optimised away.
#[test]
fn slot_lists_are_checked_against_the_reflection() {
    use Slot::*;
    let slots: &'static [Slot] = &[Uniform, ImgRead, ImgOverwrite];
    assert_eq!(decl::<f32>(shader(&[(0, UBO), (1, IMG), (2, IMG)], 4), slots).mismatch(), None);
    assert_eq!(decl::<f32>(shader(&[(1, IMG), (2, IMG)], 4), slots).mismatch(), None, "unused frame block");
    let moved = decl::<f32>(shader(&[(0, UBO), (1, IMG), (3, IMG)], 4), slots);
    assert_eq!(moved.mismatch(), Some("the shader has a binding the pass does not declare"));
    let missing = decl::<f32>(shader(&[(0, UBO), (2, IMG)], 4), slots);
    assert_eq!(missing.mismatch(), Some("the pass declares a binding the shader does not have"));
    let typed = decl::<f32>(shader(&[(0, UBO), (1, SSBO), (2, IMG)], 4), slots);
    assert_eq!(typed.mismatch(), Some("a binding's descriptor type differs"));
    let push = decl::<[f32; 2]>(shader(&[(0, UBO), (1, IMG), (2, IMG)], 4), slots);
    assert_eq!(push.mismatch(), Some("the push-constant size differs"));
    let e = push.check().unwrap_err().to_string();
    assert!(e.contains("test.comp") && e.contains("8 push bytes") && e.contains("4 push bytes"), "{e}");
}

/// Buffers and images map to the accesses of the one table; a full write drops old contents.
#[test]
fn slots_map_to_accesses() {
    assert_eq!(Slot::ImgOverwrite.access(false), (Access::ComputeWrite, true));
    assert_eq!(Slot::ImgWrite.access(false), (Access::ComputeWrite, false));
    assert_eq!(Slot::Sampled.access(false), (Access::ComputeSampled, false));
    assert_eq!(Slot::BufRead.access(true), (Access::GraphicsRead, false));
    assert_eq!(Slot::ImgAltRead.descriptor_type(), vk::DescriptorType::STORAGE_IMAGE);
    assert!(Slot::Uniform.is_buffer() && !Slot::Sampled.is_buffer());
    // A texel buffer is a buffer read through the sampled path (its barrier must name SAMPLED_READ, which
    // sync validation checks).
    assert!(Slot::TexelRead.is_buffer());
    assert_eq!(Slot::TexelRead.descriptor_type(), vk::DescriptorType::UNIFORM_TEXEL_BUFFER);
    assert_eq!(Slot::TexelRead.access(false), (Access::ComputeSampled, false));
    assert!(Access::ComputeSampled.info().access.contains(vk::AccessFlags2::SHADER_SAMPLED_READ));
}
