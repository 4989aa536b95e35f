//! Host-memory probe for issue #17: runs one kind of GPU work N times and prints the process RSS after a warm-up
//! and at the end, so each Vulkan usage pattern can be checked on its own ("vary one thing at a time").
//!
//! `cargo run --release --example leak_probe -- MODE [N]`, MODE one of:
//! - `empty`      allocate a command buffer, submit it empty with a new fence, wait, free (what `one_shot` does)
//! - `reuse`      one command buffer and one fence, reset and reused (no allocate/free per frame)
//! - `timestamps` `empty` + reset of a query pool and two timestamps, results read back
//! - `labels`     `empty` + a debug-utils label
//! - `dispatch`   `empty` + one push-descriptor compute dispatch (the upsample pass on a 64×64 image)
//! - `clear`      `empty` + vkCmdClearColorImage of a 64×64 image
//! - `composite`  only the composite pass (after one frame); `composite-sampledonly`: its 2D sampled slots bound
//!   to a SAMPLED-only image
//! - `frame`      a whole frame of the renderer (wave scene, 160×90), as `render --timings` runs it; `frame-cachedbg`, `frame-nofilter` vary it
use std::sync::Arc;

use ash::vk;
use meniscus::gpu::Timer;
use meniscus::gpu::{Buffer, FrameCtx, Gpu, GpuOptions, Image};
use meniscus::renderer::Renderer;
use meniscus::scene::camera::Camera;
use meniscus::scene::{self, procedural};
use meniscus::settings::Settings;
use meniscus::view::Environment;
use meniscus::view::View;

fn rss_mb() -> f64 {
    let s = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: f64 = s.split_whitespace().nth(1).and_then(|x| x.parse().ok()).unwrap_or(0.0);
    pages * 4096.0 / 1e6
}

fn main() -> meniscus::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("frame").to_string();
    let n: usize = args.get(2).and_then(|x| x.parse().ok()).unwrap_or(1000);
    let gpu = Gpu::new(&GpuOptions::default())?;
    let mut step: Box<dyn FnMut() -> meniscus::Result<()>> = match mode.as_str() {
        "empty" => {
            let g = gpu.clone();
            Box::new(move || g.one_shot(|_| Ok(())))
        }
        "reuse" => Box::new(reuse(&gpu)?),
        "timestamps" => {
            let g = gpu.clone();
            let mut timer = Timer::new(&gpu)?;
            Box::new(move || {
                g.one_shot(|cmd| {
                    timer.reset(cmd);
                    if let Some(i) = timer.begin(cmd, "x") {
                        timer.end(cmd, i);
                    }
                    Ok(())
                })?;
                timer.read().map(|_| ())
            })
        }
        "labels" => {
            let g = gpu.clone();
            Box::new(move || {
                g.one_shot(|cmd| {
                    g.begin_label(cmd, "probe");
                    g.end_label(cmd);
                    Ok(())
                })
            })
        }
        "dispatch" => {
            let g = gpu.clone();
            let up = meniscus::passes::upsample::Upsample::new(&gpu)?;
            let ext = vk::Extent2D { width: 64, height: 64 };
            let usage = vk::ImageUsageFlags::STORAGE;
            let a = Image::new(&gpu, "a", ext, vk::Format::R32_SFLOAT, usage, None)?;
            let b = Image::new(&gpu, "b", ext, vk::Format::R32_SFLOAT, usage, None)?;
            let ubo = Buffer::with_data(&gpu, "u", &[0u8; 1024], vk::BufferUsageFlags::UNIFORM_BUFFER)?;
            Box::new(move || {
                g.one_shot(|cmd| {
                    let mut ctx = FrameCtx::new(&g, cmd, None);
                    up.record(&mut ctx, &ubo, &a, &b, 1.0);
                    Ok(())
                })
            })
        }
        "clear" => {
            // vkCmdClearColorImage on a 64×64 R32F image (the splat and thickness passes clear this way).
            let g = gpu.clone();
            let ext = vk::Extent2D { width: 64, height: 64 };
            let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
            let a = Image::new(&gpu, "a", ext, vk::Format::R32_SFLOAT, usage, None)?;
            Box::new(move || {
                g.one_shot(|cmd| {
                    let mut ctx = FrameCtx::new(&g, cmd, None);
                    ctx.barrier(&[meniscus::gpu::Use::Image(&a, meniscus::gpu::Access::TransferDst, true)]);
                    unsafe {
                        g.device.cmd_clear_color_image(
                            cmd,
                            a.raw,
                            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                            &vk::ClearColorValue { float32: [0.0; 4] },
                            &[Image::color_range()],
                        )
                    };
                    Ok(())
                })
            })
        }
        m if m.starts_with("composite") => {
            // Only the composite pass, after one whole frame, bound as the frame binds it.
            let (mut r, view, s) = wave_frame(&gpu, false)?;
            r.render(&view, &s)?;
            let g = gpu.clone();
            // `composite-sampledonly`: the two 2D sampled slots bound to an image made with SAMPLED usage only.
            let sampled_only = m.contains("sampledonly");
            let tex = Image::new(
                &gpu,
                "tex",
                vk::Extent2D { width: 160, height: 90 },
                vk::Format::R16G16B16A16_SFLOAT,
                vk::ImageUsageFlags::SAMPLED,
                None,
            )?;
            Box::new(move || {
                let t = r.state().targets().expect("rendered");
                let inputs = meniscus::passes::composite::CompositeInputs {
                    scene_color: if sampled_only { &tex } else { &t.scene_color },
                    scene_depth: &t.scene_depth,
                    depth: &t.filter_a,
                    normals: &t.normals,
                    thickness: if sampled_only { &tex } else { &t.thickness },
                    ssr: &t.ssr,
                    sky: &r.state().background().sky,
                };
                g.one_shot(|cmd| {
                    let mut ctx = FrameCtx::new(&g, cmd, None);
                    let layers = r.state().effects().layers(&meniscus::settings::Settings::default())?;
                    r.state().passes().composite.record(
                        &mut ctx,
                        r.state().uniforms(),
                        &inputs,
                        &layers,
                        &t.final_color,
                    )
                })
            })
        }
        m if m.starts_with("frame") => {
            // frame, frame-cachedbg (static background reused), frame-nofilter (filter none)
            let (mut r, view, s) = wave_frame(&gpu, m.contains("nofilter"))?;
            r.parts_mut().background.always_render = !m.contains("cachedbg");
            Box::new(move || r.render(&view, &s).map(|_| ()))
        }
        m => return Err(meniscus::Error::Invalid(format!("unknown mode {m}"))),
    };
    let warm = (n / 10).max(20);
    for _ in 0..warm {
        step()?;
    }
    let start = rss_mb();
    let t = std::time::Instant::now();
    for _ in 0..n {
        step()?;
    }
    let end = rss_mb();
    println!(
        "{mode:10} {n:6} iterations: RSS {start:7.1} → {end:7.1} MB  ({:+.1} kB/iteration, {:.2} ms/iteration)",
        (end - start) * 1e3 / n as f64,
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    Ok(())
}

/// A renderer with the wave scene (20k particles) uploaded, its 160×90 view and settings (filter none if asked).
fn wave_frame(gpu: &Arc<Gpu>, no_filter: bool) -> meniscus::Result<(Renderer, View, Settings)> {
    let gen = procedural::generate("wave", 20_000)?;
    let mut s = Settings { radius: gen.radius, ..Settings::default() };
    if no_filter {
        s.filter.method = meniscus::named::Filter::None;
    }
    let bounds = scene::percentile_bounds(&gen.particles.positions, 0.01).expect("particles");
    let view = View {
        camera: Camera::fit(&bounds, 16.0 / 9.0),
        width: 160,
        height: 90,
        env: Environment::around(&bounds, s.radius, &s),
    };
    let mut r = Renderer::new(gpu)?;
    r.upload(meniscus::renderer::Upload::Points {
        positions: &gen.particles.positions,
        radii: None,
        isolated: None,
        motion: None,
    })?;
    Ok((r, view, s))
}

trait Vk<T> {
    fn vk(self, call: &'static str) -> meniscus::Result<T>;
}
impl<T> Vk<T> for Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> meniscus::Result<T> {
        self.map_err(|result| meniscus::Error::Vulkan { call, result })
    }
}

/// One command buffer and one fence reused every iteration (reset pool / reset fence).
fn reuse(gpu: &Arc<Gpu>) -> meniscus::Result<impl FnMut() -> meniscus::Result<()>> {
    let d = gpu.device.clone();
    let pi = vk::CommandPoolCreateInfo::default().queue_family_index(gpu.queue_family);
    let pool = unsafe { d.create_command_pool(&pi, None) }.vk("vkCreateCommandPool")?;
    let ai = vk::CommandBufferAllocateInfo::default()
        .command_pool(pool)
        .level(vk::CommandBufferLevel::PRIMARY)
        .command_buffer_count(1);
    let cmd = unsafe { d.allocate_command_buffers(&ai) }.vk("vkAllocateCommandBuffers")?[0];
    let fence = unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.vk("vkCreateFence")?;
    let queue = gpu.queue;
    Ok(move || {
        unsafe {
            d.reset_command_pool(pool, vk::CommandPoolResetFlags::empty()).vk("vkResetCommandPool")?;
            d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default()).vk("vkBeginCommandBuffer")?;
            d.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            d.queue_submit(queue, &submit, fence).vk("vkQueueSubmit")?;
            d.wait_for_fences(&[fence], true, u64::MAX).vk("vkWaitForFences")?;
            d.reset_fences(&[fence]).vk("vkResetFences")?;
        }
        Ok(())
    })
}
