//! Timings and their statistics, independent of the device: the GPU time of each pass of a frame
//! ([`PassTimes`], what the renderer and the simulation return), the medians and percentiles the benchmark
//! and `--timings` report, and the naming rule of a pass's parts. `gpu::timer` measures; this reads.

/// Most scopes a frame can open. A DFSPH step times each of its two solves whole (about 14 scopes per step), but
/// with `bench --parts` every correction it recorded ahead (three dispatches each, up to
/// `max_solver_iterations` per solve): a frame of eight steps at 20 corrections then opens about 1,100 scopes and
/// at 100 about 4,900; a frame that opens more is not timed at all (its passes read as none) rather than timed
/// in part.
pub const MAX_SCOPES: u32 = 8192;

/// Milliseconds per pass name, in recording order; a name used twice in a frame is summed.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PassTimes(pub Vec<(String, f64)>);

impl PassTimes {
    /// Time of `name`, if it ran.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, t)| *t)
    }
    /// Sum over all passes (the parts of a pass, [`is_part`], are inside it).
    pub fn total(&self) -> f64 {
        self.0.iter().filter(|(n, _)| !is_part(n)).map(|(_, t)| t).sum()
    }
}

/// Whether a timed scope is a part of a pass ("pass/part", `FrameCtx::part`) rather than a pass.
pub fn is_part(name: &str) -> bool {
    name.contains('/')
}

/// Per-pass medians over several frames (passes in the order of the first frame).
pub fn median_times(runs: &[PassTimes]) -> PassTimes {
    let Some(first) = runs.first() else { return PassTimes::default() };
    PassTimes(
        first
            .0
            .iter()
            .map(|(name, _)| {
                let mut v: Vec<f64> = runs.iter().filter_map(|r| r.get(name)).collect();
                (name.clone(), median(&mut v))
            })
            .collect(),
    )
}

/// Median of `v` (sorts it); 0 when empty.
pub fn median(v: &mut [f64]) -> f64 {
    percentile(v, 0.5)
}

/// Percentile `p` in [0, 1] of `v` with linear interpolation (sorts it); 0 when empty.
pub fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let x = p.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    if i + 1 < v.len() {
        v[i] * (1.0 - f) + v[i + 1] * f
    } else {
        v[i]
    }
}
