//! Compiles every shader in `shaders_glsl/` (`*.comp`, `*.vert`, `*.frag`) to SPIR-V with shaderc and
//! generates `$OUT_DIR/shaders.rs`: one `pub const NAME: &[u8]` per file (stem upper-cased, `_VERT`/`_FRAG`
//! suffixes for graphics stages). `#include "x.glsl"` resolves inside `shaders_glsl/`. A GLSL error fails the
//! build with file:line.
//!
//! Each module is also reflected (rspirv-reflect): the generated constant is a `crate::gpu::Shader` with the
//! SPIR-V, its set-0 bindings (binding, descriptor type), push-constant size and work-group size, which every
//! pass's `declare_program!` checks its slot list against at compile time. The constants shared with Rust
//! (`src/shader_constants.rs`) are passed to every shader as macro definitions.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

// The constants shared by Rust and GLSL (SHADER_CONSTANTS), defined once.
#[allow(dead_code)]
mod shader_constants {
    include!("src/shader_constants.rs");
}

/// Sources compiled more than once: (file, [(constant suffix, macro defined for that variant)]).
/// `splat.frag` gives SPLAT_FRAGDEPTH_FRAG, SPLAT_CONSERVATIVE_FRAG and SPLAT_MIN_FRAG; a ("", "") entry keeps
/// the plain program too (`sim_density.comp` gives SIM_DENSITY and SIM_DENSITY_NBR16).
const VARIANTS: &[(&str, &[(&str, &str)])] = &[
    // The `mc` pass's stages as the live mesh surface runs them (block count and capacities on the device), and
    // its blocks found on the device (src/surface/mesh/live.rs).
    ("mc_field.comp", &[("", ""), ("LIVE", "MC_LIVE")]),
    ("mc_count.comp", &[("", ""), ("LIVE", "MC_LIVE")]),
    ("mc_emit.comp", &[("", ""), ("LIVE", "MC_LIVE")]),
    ("mc_blocks.comp", &[("MARK", "MC_BLOCKS_MARK"), ("LIST", "MC_BLOCKS_LIST"), ("ARGS", "MC_BLOCKS_ARGS")]),
    ("splat.frag", &[("FRAGDEPTH", "FRAG_DEPTH"), ("CONSERVATIVE", "CONSERVATIVE_DEPTH"), ("MIN", "MIN_BLEND")]),
    // The simulation's neighbour-list stages: 32-bit lists, and 16-bit pairs (src/sim/stages.rs).
    ("sim_neighbours.comp", NBR),
    ("sim_density.comp", NBR),
    ("sim_solve.comp", NBR),
    ("sim_vorticity.comp", NBR),
    ("sim_viscosity.comp", NBR),
    // The reorder, and the reorder that carries one more value per particle (DFSPH's divergence-free warm start).
    ("sim_reorder.comp", &[("", ""), ("CARRY", "REORDER_CARRY")]),
    // DFSPH's list readers (src/sim/dfsph.rs).
    ("sim_dfsph_alpha.comp", NBR),
    ("sim_dfsph_rate.comp", NBR),
    ("sim_dfsph_update.comp", NBR),
    // The smoothed iso field (src/surface/iso/volume.rs): the bricks marked, allocated, the sums deposited (two 32-bit
    // atomics, or one 64-bit where the device has them), the bricks' aprons copied; the cast over the volume and its queued rays.
    (
        "iso_volume.comp",
        &[
            ("MARK", "ISO_VOLUME_MARK"),
            ("ALLOC", "ISO_VOLUME_ALLOC"),
            ("", ""),
            ("DEPOSIT64", "ISO_VOLUME_DEPOSIT64"),
            ("APRON", "ISO_VOLUME_APRON"),
        ],
    ),
    (
        "iso_vol.comp",
        &[
            ("", ""),
            ("REST", "ISO_REST"),
            ("REST_WIDE8", "ISO_REST_WIDE8"),
            ("REST_WIDE8_MANY", "ISO_REST_WIDE8_MANY"),
            ("REST_WIDE32", "ISO_REST_WIDE32"),
        ],
    ),
    // The cast's queued rays, one lane each, or 8 or 32 lanes each (devices that shuffle within a subgroup).
    (
        "iso_rest.comp",
        &[("", ""), ("WIDE8", "ISO_REST_WIDE8"), ("WIDE8_MANY", "ISO_REST_WIDE8_MANY"), ("WIDE32", "ISO_REST_WIDE32")],
    ),
    // The compute clear of 32-bit storage images (src/compute/clear.rs): r32f and r32ui.
    ("clear.comp", &[("F32", "CLEAR_F32"), ("U32", "CLEAR_U32")]),
    // The normals, and the normals with an effect's detail height field (the noise's small waves).
    ("normals.comp", &[("", ""), ("DETAIL", "NORMALS_DETAIL")]),
    // The composite for 0 … 4 layers: a frame without effects runs the composite that knows of none.
    (
        "composite.comp",
        &[
            ("L0", "COMPOSITE_L0"),
            ("L1", "COMPOSITE_L1"),
            ("L2", "COMPOSITE_L2"),
            ("L3", "COMPOSITE_L3"),
            ("L4", "COMPOSITE_L4"),
        ],
    ),
    // The background without a mesh, and with one (its BVH walked).
    ("background.comp", &[("", ""), ("MESH", "BACKGROUND_MESH")]),
    // The iso grid cells' empty distance, one axis per dispatch.
    ("iso_empty.comp", &[("X", "ISO_EMPTY_X"), ("Y", "ISO_EMPTY_Y"), ("Z", "ISO_EMPTY_Z")]),
    // A mesh's Laplacian smoothing iteration, and its vertex normals.
    (
        "mesh_smooth.comp",
        &[
            ("", ""),
            ("NORMALS", "MESH_SMOOTH_NORMALS"),
            ("COUNT", "MESH_SMOOTH_COUNT"),
            ("FILL", "MESH_SMOOTH_FILL"),
            ("SORT", "MESH_SMOOTH_SORT"),
            ("NEIGHBOURS", "MESH_SMOOTH_NEIGHBOURS"),
            ("WEIGHTS", "MESH_SMOOTH_WEIGHTS"),
            // The live mesh surface's: counts from the device (src/surface/mesh/live.rs).
            ("LIVE", "MESH_SMOOTH_LIVE"),
            ("COUNT_LIVE", "MESH_SMOOTH_COUNT_LIVE"),
            ("FILL_LIVE", "MESH_SMOOTH_FILL_LIVE"),
            ("SORT_LIVE", "MESH_SMOOTH_SORT_LIVE"),
            ("WEIGHTS_LIVE", "MESH_SMOOTH_WEIGHTS_LIVE"),
        ],
    ),
    // The weights and neighbour counts, then each point's lattice order pooled over its neighbours.
    ("iso_density.comp", &[("", ""), ("ORDER", "ISO_DENSITY_ORDER")]),
];
const NBR: &[(&str, &str)] = &[("", ""), ("NBR16", "NBR16")];

fn main() {
    let src = Path::new("shaders_glsl");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    println!("cargo:rerun-if-changed=shaders_glsl");
    println!("cargo:rerun-if-changed=src/shader_constants.rs");
    // The commit the binary was built from, for benchmark JSON ("unknown" outside a git checkout).
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    let dirty = std::process::Command::new("git")
        .args(["status", "--porcelain", "--untracked-files=no"])
        .output()
        .ok()
        .is_some_and(|o| !o.stdout.is_empty());
    println!("cargo:rustc-env=MENISCUS_GIT_COMMIT={commit}{}", if dirty { "-dirty" } else { "" });
    println!("cargo:rerun-if-changed=.git/HEAD");
    println!("cargo:rerun-if-changed=.git/index");
    let compiler = shaderc::Compiler::new().expect("shaderc: cannot create a compiler");
    // Reflection failures are reported with the shader's name below, not as a panic message (the default hook
    // is back after the loop, so any later failure says what it is).
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    // No SPIR-V of an earlier build survives: a shader renamed or a variant dropped must not leave a stale file
    // that a later step (or a later build) would still find.
    for e in std::fs::read_dir(&out).into_iter().flatten().flatten() {
        if e.path().extension().is_some_and(|x| x == "spv") {
            let _ = std::fs::remove_file(e.path());
        }
    }
    // Every source under shaders_glsl/, its subfolders too (a technique's shaders: shaders_glsl/iso/).
    let mut entries = vec![];
    walk(src, &mut entries);
    entries.sort();
    let mut stems = std::collections::BTreeMap::new();
    let mut generated = String::from("// Generated by build.rs from shaders_glsl/. Do not edit.\n");
    let mut failures = vec![];
    for path in entries {
        println!("cargo:rerun-if-changed={}", path.display());
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let (kind, suffix) = match ext {
            "comp" => (shaderc::ShaderKind::Compute, ""),
            "vert" => (shaderc::ShaderKind::Vertex, "_VERT"),
            "frag" => (shaderc::ShaderKind::Fragment, "_FRAG"),
            _ => continue,
        };
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&path).expect("read shader");
        let file = format!("{stem}.{ext}");
        // The constants are named by the file's stem alone: two folders may not hold the same name.
        if let Some(other) = stems.insert(file.clone(), path.clone()) {
            failures.push(format!("{} and {} share the name {file}", other.display(), path.display()));
            continue;
        }
        // The path under shaders_glsl/ ("iso/iso.comp"): the program's label in errors and the generated docs.
        let rel = path.strip_prefix(src).unwrap_or(&path).display().to_string();
        // One source, several programs: each variant is compiled with its own macro defined.
        let variants: &[(&str, &str)] = VARIANTS.iter().find(|v| v.0 == file).map(|v| v.1).unwrap_or(&[("", "")]);
        for (variant, define) in variants {
            let mut opts = shaderc::CompileOptions::new().expect("shaderc options");
            opts.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
            opts.set_target_spirv(shaderc::SpirvVersion::V1_6);
            opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
            opts.set_generate_debug_info();
            for (name, value) in shader_constants::SHADER_CONSTANTS {
                // Unsigned literal only where an int cannot hold the value (SSR_MISS).
                let text = if *value > i32::MAX as u32 { format!("{value:#x}u") } else { value.to_string() };
                opts.add_macro_definition(name, Some(&text));
            }
            for (name, value) in shader_constants::SHADER_CONSTANTS_F32 {
                // A float literal GLSL reads as float ("4.0", not "4").
                opts.add_macro_definition(name, Some(&format!("{value:?}")));
            }
            if !define.is_empty() {
                opts.add_macro_definition(define, Some("1"));
            }
            // `#include "x.glsl"`: beside the including file first, then at the top of shaders_glsl/.
            opts.set_include_callback(|name, _ty, from, _depth| {
                let beside = Path::new(from).parent().map(|d| d.join(name)).filter(|p| p.is_file());
                let p = beside.unwrap_or_else(|| src.join(name));
                std::fs::read_to_string(&p)
                    .map(|content| shaderc::ResolvedInclude { resolved_name: p.display().to_string(), content })
                    .map_err(|e| format!("{}: {e}", p.display()))
            });
            let file_name = path.display().to_string();
            let (label, const_stem) = if variant.is_empty() {
                (rel.clone(), stem.to_uppercase().replace('-', "_"))
            } else {
                (format!("{rel} ({define})"), format!("{}_{variant}", stem.to_uppercase()))
            };
            match compiler.compile_into_spirv(&text, kind, &file_name, "main", Some(&opts)) {
                Ok(art) => {
                    let spv = out.join(format!("{stem}{}.{ext}.spv", variant.to_lowercase()));
                    std::fs::write(&spv, art.as_binary_u8()).expect("write spv");
                    let r = match reflect(art.as_binary_u8()) {
                        Ok(r) => r,
                        Err(e) => {
                            failures.push(format!("{label}: SPIR-V reflection failed: {e}"));
                            continue;
                        }
                    };
                    let _ = writeln!(
                        generated,
                        "/// shaders_glsl/{label}: SPIR-V and its reflection.\npub const {const_stem}{suffix}: crate::gpu::Shader = crate::gpu::Shader {{ file: {label:?}, spirv: include_bytes!({:?}), bindings: &{:?}, push: {}, local: {:?} }};",
                        spv.display().to_string(),
                        r.0,
                        r.1,
                        r.2,
                    );
                }
                Err(e) => failures.push(format!("{label}: {e}")),
            }
        }
    }
    std::panic::set_hook(default_hook);
    if !failures.is_empty() {
        for f in &failures {
            for line in f.lines() {
                println!("cargo:warning={line}");
            }
        }
        panic!("GLSL compilation failed:\n{}", failures.join("\n"));
    }
    // The frame uniform block's member offsets as the compiler laid them out (std140), for the test that checks
    // the Rust mirror `FrameUniforms` field by field.
    // (composite.comp is compiled once per layer count: the layers' variants share the block; L0 is read.)
    let composite = std::fs::read(out.join("compositel0.comp.spv")).expect("compositel0.comp.spv");
    let members = frame_block_offsets(&composite).expect("the Frame block of composite.comp");
    let _ =
        writeln!(generated, "/// (member, byte offset) of the `Frame` uniform block (common.glsl), from the SPIR-V.");
    let _ = writeln!(generated, "pub const FRAME_BLOCK: &[(&str, u32)] = &{members:?};");
    std::fs::write(out.join("shaders.rs"), generated).expect("write shaders.rs");
}

/// Set-0 bindings (binding, VkDescriptorType raw value), push-constant bytes and work-group size of a module.
type Reflected = (Vec<(u32, i32)>, u32, [u32; 3]);

fn reflect(spirv: &[u8]) -> Result<Reflected, String> {
    let r = rspirv_reflect::Reflection::new_from_spirv(spirv).map_err(|e| format!("{e:?}"))?;
    // rspirv-reflect asserts (panics) when two variables share a binding: report that as a shader error.
    let sets = std::panic::catch_unwind(|| r.get_descriptor_sets())
        .map_err(|_| "two variables share one binding number".to_string())?
        .map_err(|e| format!("{e:?}"))?;
    if sets.keys().any(|&s| s != 0) {
        return Err("only descriptor set 0 is used (push descriptors)".into());
    }
    let bindings = sets.get(&0).map(|b| b.iter().map(|(n, info)| (*n, info.ty.0 as i32)).collect()).unwrap_or_default();
    let push = r.get_push_constant_range().map_err(|e| format!("{e:?}"))?.map(|p| p.offset + p.size).unwrap_or(0);
    let local = r.get_compute_group_size().map(|(x, y, z)| [x, y, z]).unwrap_or([0; 3]);
    Ok((bindings, push, local))
}

/// (member name, Offset decoration) of the struct named `Frame` in a SPIR-V module (debug names are on).
fn frame_block_offsets(spirv: &[u8]) -> Option<Vec<(String, u32)>> {
    use rspirv::dr::Operand;
    use rspirv::spirv::{Decoration, Op};
    let m = rspirv::dr::load_bytes(spirv).ok()?;
    let id = m.debug_names.iter().find_map(|i| match (i.class.opcode, i.operands.as_slice()) {
        (Op::Name, [Operand::IdRef(id), Operand::LiteralString(n)]) if n == "Frame" => Some(*id),
        _ => None,
    })?;
    let mut members: Vec<(u32, String, u32)> = m
        .debug_names
        .iter()
        .filter_map(|i| match (i.class.opcode, i.operands.as_slice()) {
            (Op::MemberName, [Operand::IdRef(s), Operand::LiteralBit32(k), Operand::LiteralString(n)]) if *s == id => {
                Some((*k, n.clone(), 0))
            }
            _ => None,
        })
        .collect();
    for i in &m.annotations {
        if let (
            Op::MemberDecorate,
            [Operand::IdRef(s), Operand::LiteralBit32(k), Operand::Decoration(Decoration::Offset), Operand::LiteralBit32(off)],
        ) = (i.class.opcode, i.operands.as_slice())
        {
            if *s == id {
                if let Some(e) = members.iter_mut().find(|e| e.0 == *k) {
                    e.2 = *off;
                }
            }
        }
    }
    members.sort();
    Some(members.into_iter().map(|(_, n, o)| (n, o)).collect())
}

/// Every file under `dir`, its subfolders walked.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        if path.is_dir() {
            println!("cargo:rerun-if-changed={}", path.display());
            walk(&path, out);
        } else {
            out.push(path);
        }
    }
}
