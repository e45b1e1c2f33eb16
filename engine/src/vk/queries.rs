//! Named GPU timestamps per pass.

use ash::vk;

use super::Device;
use crate::error::{Result, VkContext};

/// Timestamps around named scopes within one submission; a scope name may repeat (e.g. one per
/// accumulation pass) and [`GpuTimer::results`] sums repeats. A scope that begins right where the
/// previous one ended shares its timestamp ([`GpuTimer::begin`]): back-to-back passes cost one
/// timestamp each, not two — on lavapipe every timestamp after the top of the pipe flushes the
/// queued rendering, so they are not free.
pub struct GpuTimer {
    pool: vk::QueryPool,
    capacity: u32,
    next: u32,
    /// (name, begin query, end query).
    scopes: Vec<(String, u32, u32)>,
    /// The last timestamp written, while nothing has been recorded after it.
    boundary: Option<u32>,
    enabled: bool,
    device: Device,
}

/// Milliseconds per named scope, in first-use order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassTimings {
    pub passes: Vec<(String, f64)>,
}

impl PassTimings {
    /// The passes' sum; 0 (not the -0 an empty float `sum` gives) when nothing was timed.
    pub fn total_ms(&self) -> f64 {
        self.passes.iter().fold(0.0, |total, (_, ms)| total + ms)
    }
    pub fn get(&self, name: &str) -> Option<f64> {
        self.passes.iter().find(|(n, _)| n == name).map(|(_, ms)| *ms)
    }
    /// Adds `other`'s times to the scopes of the same name (appending new names in order).
    pub fn add(&mut self, other: &PassTimings) {
        for (name, ms) in &other.passes {
            match self.passes.iter_mut().find(|(n, _)| n == name) {
                Some((_, acc)) => *acc += ms,
                None => self.passes.push((name.clone(), *ms)),
            }
        }
    }
}

impl GpuTimer {
    /// A timer for up to `max_scopes` scopes. Without timestamp support it records nothing.
    pub fn new(device: &Device, max_scopes: u32) -> Result<Self> {
        let enabled = device.caps.timestamps;
        let capacity = max_scopes * 2;
        let pool = if enabled {
            let info =
                vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(capacity);
            unsafe { device.raw.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?
        } else {
            vk::QueryPool::null()
        };
        Ok(GpuTimer {
            pool,
            capacity,
            next: 0,
            scopes: vec![],
            boundary: None,
            enabled,
            device: device.clone(),
        })
    }

    /// A timer that records nothing: for a frame recorded into a caller's command buffer, whose
    /// completion Shutter never sees (so it could never read the queries back).
    pub fn disabled(device: &Device) -> Self {
        GpuTimer {
            pool: vk::QueryPool::null(),
            capacity: 0,
            next: 0,
            scopes: vec![],
            boundary: None,
            enabled: false,
            device: device.clone(),
        }
    }

    /// Resets the pool; record at the start of the command buffer.
    pub fn reset(&mut self, cmd: vk::CommandBuffer) {
        self.next = 0;
        self.scopes.clear();
        self.boundary = None;
        if self.enabled {
            unsafe { self.device.raw.cmd_reset_query_pool(cmd, self.pool, 0, self.capacity) };
        }
    }

    fn timestamp(&mut self, cmd: vk::CommandBuffer) -> Option<u32> {
        if !self.enabled || self.next >= self.capacity {
            return None;
        }
        let q = self.next;
        self.next += 1;
        unsafe {
            self.device.raw.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, q)
        };
        Some(q)
    }

    /// Marks that commands were recorded since the last timestamp (the next scope needs its own).
    pub fn interrupt(&mut self) {
        self.boundary = None;
    }

    /// Starts scope `name` (at the previous scope's end when nothing was recorded in between);
    /// returns a token for [`GpuTimer::end`].
    pub fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) -> Option<(String, u32)> {
        let q = match self.boundary.take() {
            Some(q) => q,
            None => self.timestamp(cmd)?,
        };
        Some((name.to_string(), q))
    }

    pub fn end(&mut self, cmd: vk::CommandBuffer, token: Option<(String, u32)>) {
        if let Some((name, begin)) = token {
            if let Some(end) = self.timestamp(cmd) {
                self.scopes.push((name, begin, end));
                self.boundary = Some(end);
            }
        }
    }

    /// Reads back the scopes' durations after the submission completed.
    pub fn results(&self) -> Result<PassTimings> {
        let mut out = PassTimings::default();
        if !self.enabled || self.next == 0 {
            return Ok(out);
        }
        let mut ticks = vec![0u64; self.next as usize];
        unsafe {
            self.device.raw.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let period = self.device.caps.timestamp_period_ns as f64;
        for (name, begin, end) in &self.scopes {
            let ms = ticks[*end as usize].saturating_sub(ticks[*begin as usize]) as f64 * period * 1e-6;
            match out.passes.iter_mut().find(|(n, _)| n == name) {
                Some((_, acc)) => *acc += ms,
                None => out.passes.push((name.clone(), ms)),
            }
        }
        Ok(out)
    }
}

impl Drop for GpuTimer {
    fn drop(&mut self) {
        if self.pool != vk::QueryPool::null() {
            unsafe { self.device.raw.destroy_query_pool(self.pool, None) };
        }
    }
}
