//! GPU timestamp scopes, one per pass. Tick differences are masked to the queue family's
//! `timestampValidBits` and multiplied by `timestampPeriod` (ns per tick). Where the device has
//! `pipelineStatisticsQuery` (`DeviceInfo::pipeline_statistics`), each outermost scope also counts the compute
//! shader invocations it ran (a pipeline-statistics query; Vulkan allows one active at a time, so a scope
//! opened inside another is counted in its parent, not on its own): the work a pass did, on any device.

use std::sync::Arc;

use ash::vk;

use super::Gpu;
use crate::error::{Result, VkContext};
use crate::timing::{PassTimes, MAX_SCOPES};

/// One scope of a frame: its name, begin and end (ns, device clock), compute invocations where counted.
pub type ScopeSpan = (String, f64, f64, Option<u64>);

/// A timestamp query pool and the names of the scopes written into it; a pipeline-statistics pool beside it
/// where the device counts invocations.
pub struct Timer {
    gpu: Arc<Gpu>,
    pool: vk::QueryPool,
    names: Vec<String>,
    /// Compute-invocation queries, one per scope index (only outermost scopes use theirs).
    stats: Option<vk::QueryPool>,
    /// The scope whose statistics query is open.
    counting: Option<u32>,
    /// Per scope: whether its statistics query ran.
    counted: Vec<bool>,
    /// Scopes opened this frame after the pool was full (not timed).
    dropped: u32,
}

impl Timer {
    /// A pool for [`MAX_SCOPES`] begin/end pairs.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Timer> {
        let ci = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2 * MAX_SCOPES);
        let pool = unsafe { gpu.device.create_query_pool(&ci, None) }.vk("vkCreateQueryPool")?;
        let stats = if gpu.info.pipeline_statistics {
            let ci = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::PIPELINE_STATISTICS)
                .pipeline_statistics(vk::QueryPipelineStatisticFlags::COMPUTE_SHADER_INVOCATIONS)
                .query_count(MAX_SCOPES);
            match unsafe { gpu.device.create_query_pool(&ci, None) }.vk("vkCreateQueryPool") {
                Ok(p) => Some(p),
                Err(e) => {
                    unsafe { gpu.device.destroy_query_pool(pool, None) };
                    return Err(e);
                }
            }
        } else {
            None
        };
        Ok(Timer { gpu: gpu.clone(), pool, names: vec![], stats, counting: None, counted: vec![], dropped: 0 })
    }

    /// Reset the pool in `cmd`; call once at the start of a frame.
    pub fn reset(&mut self, cmd: vk::CommandBuffer) {
        self.names.clear();
        self.counted.clear();
        self.counting = None;
        self.dropped = 0;
        unsafe { self.gpu.device.cmd_reset_query_pool(cmd, self.pool, 0, 2 * MAX_SCOPES) };
        if let Some(stats) = self.stats {
            unsafe { self.gpu.device.cmd_reset_query_pool(cmd, stats, 0, MAX_SCOPES) };
        }
    }

    /// Write the begin timestamp of scope `name`; returns its index, or None when the pool is full.
    pub fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) -> Option<u32> {
        let i = self.names.len() as u32;
        if i >= MAX_SCOPES {
            self.dropped += 1;
            return None;
        }
        self.names.push(name.to_string());
        unsafe { self.gpu.device.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, 2 * i) };
        let count = self.stats.is_some() && self.counting.is_none();
        if let (true, Some(stats)) = (count, self.stats) {
            unsafe { self.gpu.device.cmd_begin_query(cmd, stats, i, vk::QueryControlFlags::empty()) };
            self.counting = Some(i);
        }
        self.counted.push(count);
        Some(i)
    }

    /// Write the end timestamp of scope `i` (after all earlier work finished).
    pub fn end(&mut self, cmd: vk::CommandBuffer, i: u32) {
        if let (Some(stats), Some(open)) = (self.stats, self.counting) {
            if open == i {
                unsafe { self.gpu.device.cmd_end_query(cmd, stats, i) };
                self.counting = None;
            }
        }
        unsafe {
            self.gpu.device.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, 2 * i + 1)
        };
    }

    /// Per scope of the last frame: the compute shader invocations it ran (None: not counted — no statistics
    /// on this device, or a scope inside another; waits).
    pub fn invocations(&self) -> Result<Vec<Option<u64>>> {
        let Some(stats) = self.stats else { return Ok(vec![None; self.names.len()]) };
        self.counted
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                if !c {
                    return Ok(None);
                }
                let mut v = [0u64; 1];
                unsafe {
                    self.gpu.device.get_query_pool_results(
                        stats,
                        i as u32,
                        &mut v,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }
                .vk("vkGetQueryPoolResults")?;
                Ok(Some(v[0]))
            })
            .collect()
    }

    /// Per scope of the last frame: its begin timestamp and its length, in ticks (valid bits only; waits).
    fn ticks(&self) -> Result<Vec<(u64, u64)>> {
        let n = self.names.len();
        if n == 0 {
            return Ok(vec![]);
        }
        let mut raw = vec![0u64; 2 * n];
        unsafe {
            self.gpu.device.get_query_pool_results(
                self.pool,
                0,
                &mut raw,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let bits = self.gpu.info.timestamp_valid_bits;
        let mask = if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 };
        Ok(raw.chunks_exact(2).map(|be| (be[0] & mask, be[1].wrapping_sub(be[0]) & mask)).collect())
    }

    /// Begin and end of every scope of the last frame in nanoseconds of the device clock, and its compute
    /// invocations where counted (waits for them).
    pub fn spans(&self) -> Result<Vec<ScopeSpan>> {
        if self.dropped > 0 {
            return Ok(vec![]);
        }
        let period = self.gpu.info.timestamp_period as f64;
        Ok(self
            .names
            .iter()
            .zip(self.ticks()?)
            .zip(self.invocations()?)
            .map(|((name, (b, d)), n)| (name.clone(), b as f64 * period, b as f64 * period + d as f64 * period, n))
            .collect())
    }

    /// Scopes the last frame opened past [`MAX_SCOPES`] (0: every scope was timed).
    pub fn untimed(&self) -> u32 {
        self.dropped
    }

    /// Read the results of the last frame (waits for them). Same-named scopes are summed. A frame that opened
    /// more than [`MAX_SCOPES`] scopes reads as untimed (no passes; [`Timer::untimed`] says how many were
    /// left out): sums that leave out the passes recorded last would read as a cheaper frame.
    pub fn read(&self) -> Result<PassTimes> {
        if self.dropped > 0 {
            return Ok(PassTimes(vec![]));
        }
        let period = self.gpu.info.timestamp_period as f64;
        let mut out: Vec<(String, f64)> = vec![];
        for (name, (_, ticks)) in self.names.iter().zip(self.ticks()?) {
            let ms = ticks as f64 * period * 1e-6;
            match out.iter_mut().find(|(n, _)| n == name) {
                Some(e) => e.1 += ms,
                None => out.push((name.clone(), ms)),
            }
        }
        Ok(PassTimes(out))
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        unsafe { self.gpu.device.destroy_query_pool(self.pool, None) };
        if let Some(stats) = self.stats {
            unsafe { self.gpu.device.destroy_query_pool(stats, None) };
        }
    }
}
