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

/// The device's own counters over a frame (a pipeline-statistics query around each submission),
/// beside Shutter's sample counters: what the rasterizer and the shader stages were asked to do.
/// Collected for instrumented frames only, on devices with `pipelineStatisticsQuery`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PipelineStatistics {
    /// Primitives the input assembler produced (`None` where the frame draws with mesh shaders,
    /// which no pre-rasterization statistic may count).
    pub input_assembly_primitives: Option<u64>,
    pub vertex_shader_invocations: Option<u64>,
    /// Geometry-shader invocations and primitives (`None` without geometry shaders or with mesh
    /// shaders).
    pub geometry_shader_invocations: Option<u64>,
    pub geometry_shader_primitives: Option<u64>,
    /// Primitives that reached clipping, and those that left it.
    pub clipping_invocations: u64,
    pub clipping_primitives: u64,
    pub fragment_shader_invocations: u64,
    pub compute_shader_invocations: u64,
    /// Task- and mesh-shader invocations (`meshShaderQueries`; `None` without it or without mesh
    /// draws, task invocations also without task shaders).
    #[serde(default)]
    pub task_shader_invocations: Option<u64>,
    #[serde(default)]
    pub mesh_shader_invocations: Option<u64>,
}

impl PipelineStatistics {
    /// `IA primitives 12, VS 36, GS 12 → 48 primitives, clipping 48 → 48, FS 9216, CS 4096`
    /// (the statistics the query counted).
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        if let Some(p) = self.input_assembly_primitives {
            parts.push(format!("IA primitives {p}"));
        }
        if let Some(v) = self.vertex_shader_invocations {
            parts.push(format!("VS {v}"));
        }
        if let (Some(i), Some(p)) = (self.geometry_shader_invocations, self.geometry_shader_primitives) {
            parts.push(format!("GS {i} → {p} primitives"));
        }
        parts.push(format!("clipping {} → {}", self.clipping_invocations, self.clipping_primitives));
        parts.push(format!("FS {}", self.fragment_shader_invocations));
        parts.push(format!("CS {}", self.compute_shader_invocations));
        if let Some(t) = self.task_shader_invocations {
            parts.push(format!("TS {t}"));
        }
        if let Some(m) = self.mesh_shader_invocations {
            parts.push(format!("MS {m}"));
        }
        parts.join(", ")
    }

    fn add(&mut self, o: &PipelineStatistics) {
        let sum = |a: Option<u64>, b: Option<u64>| match (a, b) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
        };
        self.input_assembly_primitives = sum(self.input_assembly_primitives, o.input_assembly_primitives);
        self.vertex_shader_invocations = sum(self.vertex_shader_invocations, o.vertex_shader_invocations);
        self.geometry_shader_invocations =
            sum(self.geometry_shader_invocations, o.geometry_shader_invocations);
        self.geometry_shader_primitives = sum(self.geometry_shader_primitives, o.geometry_shader_primitives);
        self.clipping_invocations += o.clipping_invocations;
        self.clipping_primitives += o.clipping_primitives;
        self.fragment_shader_invocations += o.fragment_shader_invocations;
        self.compute_shader_invocations += o.compute_shader_invocations;
        self.task_shader_invocations = sum(self.task_shader_invocations, o.task_shader_invocations);
        self.mesh_shader_invocations = sum(self.mesh_shader_invocations, o.mesh_shader_invocations);
    }
}

/// What a device lets a statistics query count around mesh draws (`meshShaderQueries`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshStatistics {
    /// The frame draws no mesh shaders.
    NoMeshDraws,
    /// Mesh draws on a device without `meshShaderQueries`: no stage before rasterization is counted.
    Uncounted,
    /// Mesh draws, their invocations counted, and the task shader's where `task` holds.
    Counted { task: bool },
}

/// Which statistics a frame's query counts: the pre-rasterization ones only where no mesh shader
/// draws in it (Vulkan forbids them around mesh draws; the task and mesh shaders' instead, where the
/// device counts them), the geometry shader's only where the device has geometry shaders.
pub fn statistic_flags(geometry_shader: bool, mesh: MeshStatistics) -> vk::QueryPipelineStatisticFlags {
    type F = vk::QueryPipelineStatisticFlags;
    let mut flags = F::CLIPPING_INVOCATIONS
        | F::CLIPPING_PRIMITIVES
        | F::FRAGMENT_SHADER_INVOCATIONS
        | F::COMPUTE_SHADER_INVOCATIONS;
    match mesh {
        MeshStatistics::NoMeshDraws => {
            flags |= F::INPUT_ASSEMBLY_PRIMITIVES | F::VERTEX_SHADER_INVOCATIONS;
            if geometry_shader {
                flags |= F::GEOMETRY_SHADER_INVOCATIONS | F::GEOMETRY_SHADER_PRIMITIVES;
            }
        }
        MeshStatistics::Uncounted => {}
        MeshStatistics::Counted { task } => {
            flags |= F::MESH_SHADER_INVOCATIONS_EXT;
            if task {
                flags |= F::TASK_SHADER_INVOCATIONS_EXT;
            }
        }
    }
    flags
}

/// The statistics a query of `flags` wrote, in Vulkan's order (one value per set bit, lowest first).
pub fn decode_statistics(flags: vk::QueryPipelineStatisticFlags, values: &[u64]) -> PipelineStatistics {
    type F = vk::QueryPipelineStatisticFlags;
    let mut next = values.iter().copied();
    let mut take = |bit: F| flags.contains(bit).then(|| next.next().unwrap_or(0));
    // Bits in ascending order, as the results are laid out.
    let _vertices = take(F::INPUT_ASSEMBLY_VERTICES);
    let input_assembly_primitives = take(F::INPUT_ASSEMBLY_PRIMITIVES);
    let vertex_shader_invocations = take(F::VERTEX_SHADER_INVOCATIONS);
    let geometry_shader_invocations = take(F::GEOMETRY_SHADER_INVOCATIONS);
    let geometry_shader_primitives = take(F::GEOMETRY_SHADER_PRIMITIVES);
    let clipping_invocations = take(F::CLIPPING_INVOCATIONS).unwrap_or(0);
    let clipping_primitives = take(F::CLIPPING_PRIMITIVES).unwrap_or(0);
    let fragment_shader_invocations = take(F::FRAGMENT_SHADER_INVOCATIONS).unwrap_or(0);
    let _tcs = take(F::TESSELLATION_CONTROL_SHADER_PATCHES);
    let _tes = take(F::TESSELLATION_EVALUATION_SHADER_INVOCATIONS);
    let compute_shader_invocations = take(F::COMPUTE_SHADER_INVOCATIONS).unwrap_or(0);
    let task_shader_invocations = take(F::TASK_SHADER_INVOCATIONS_EXT);
    let mesh_shader_invocations = take(F::MESH_SHADER_INVOCATIONS_EXT);
    PipelineStatistics {
        input_assembly_primitives,
        vertex_shader_invocations,
        geometry_shader_invocations,
        geometry_shader_primitives,
        clipping_invocations,
        clipping_primitives,
        fragment_shader_invocations,
        compute_shader_invocations,
        task_shader_invocations,
        mesh_shader_invocations,
    }
}

/// One pipeline-statistics query around each submission of a graph, summed over its submissions.
pub struct StatisticsQuery {
    pool: vk::QueryPool,
    flags: vk::QueryPipelineStatisticFlags,
    total: PipelineStatistics,
    device: Device,
}

impl StatisticsQuery {
    pub fn new(device: &Device, flags: vk::QueryPipelineStatisticFlags) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::PIPELINE_STATISTICS)
            .query_count(1)
            .pipeline_statistics(flags);
        let pool = unsafe { device.raw.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(StatisticsQuery { pool, flags, total: PipelineStatistics::default(), device: device.clone() })
    }

    /// Resets and begins the query; record first in the command buffer, outside any rendering.
    pub fn begin(&self, cmd: vk::CommandBuffer) {
        unsafe {
            self.device.raw.cmd_reset_query_pool(cmd, self.pool, 0, 1);
            self.device.raw.cmd_begin_query(cmd, self.pool, 0, vk::QueryControlFlags::empty());
        }
    }

    /// Ends the query; record last in the command buffer.
    pub fn end(&self, cmd: vk::CommandBuffer) {
        unsafe { self.device.raw.cmd_end_query(cmd, self.pool, 0) };
    }

    /// Adds the completed submission's counts to the total.
    pub fn collect(&mut self) -> Result<()> {
        // One query: ash counts queries by elements, so the element is the query's whole result
        // (at most the 11 statistics Vulkan 1.0 defines, 64-bit each).
        let mut result = [[0u64; 11]; 1];
        unsafe {
            self.device.raw.get_query_pool_results(
                self.pool,
                0,
                &mut result,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let n = self.flags.as_raw().count_ones() as usize;
        self.total.add(&decode_statistics(self.flags, &result[0][..n]));
        Ok(())
    }

    pub fn total(&self) -> PipelineStatistics {
        self.total
    }
}

impl Drop for StatisticsQuery {
    fn drop(&mut self) {
        unsafe { self.device.raw.destroy_query_pool(self.pool, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_decode_in_vulkans_bit_order() {
        type F = vk::QueryPipelineStatisticFlags;
        let all = statistic_flags(true, MeshStatistics::NoMeshDraws);
        assert_eq!(all.as_raw().count_ones(), 8);
        let s = decode_statistics(all, &[1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(
            s,
            PipelineStatistics {
                input_assembly_primitives: Some(1),
                vertex_shader_invocations: Some(2),
                geometry_shader_invocations: Some(3),
                geometry_shader_primitives: Some(4),
                clipping_invocations: 5,
                clipping_primitives: 6,
                fragment_shader_invocations: 7,
                compute_shader_invocations: 8,
                task_shader_invocations: None,
                mesh_shader_invocations: None,
            }
        );
        // Around mesh draws no pre-rasterization statistic is counted, with or without geometry shaders.
        for gs in [false, true] {
            let mesh = statistic_flags(gs, MeshStatistics::Uncounted);
            assert!(!mesh.intersects(
                F::INPUT_ASSEMBLY_PRIMITIVES
                    | F::VERTEX_SHADER_INVOCATIONS
                    | F::GEOMETRY_SHADER_INVOCATIONS
                    | F::GEOMETRY_SHADER_PRIMITIVES
            ));
            let s = decode_statistics(mesh, &[5, 6, 7, 8]);
            assert_eq!(
                (s.input_assembly_primitives, s.clipping_invocations, s.compute_shader_invocations),
                (None, 5, 8)
            );
        }
        // With meshShaderQueries: the task (0x800) and mesh (0x1000) bits follow the compute bit.
        let counted = statistic_flags(true, MeshStatistics::Counted { task: true });
        assert!(!counted.intersects(F::INPUT_ASSEMBLY_PRIMITIVES | F::GEOMETRY_SHADER_INVOCATIONS));
        let c = decode_statistics(counted, &[5, 6, 7, 8, 9, 10]);
        assert_eq!(
            (c.compute_shader_invocations, c.task_shader_invocations, c.mesh_shader_invocations),
            (8, Some(9), Some(10))
        );
        let m = decode_statistics(
            statistic_flags(false, MeshStatistics::Counted { task: false }),
            &[5, 6, 7, 8, 9],
        );
        assert_eq!((m.task_shader_invocations, m.mesh_shader_invocations), (None, Some(9)));
        let no_gs =
            decode_statistics(statistic_flags(false, MeshStatistics::NoMeshDraws), &[1, 2, 5, 6, 7, 8]);
        assert_eq!((no_gs.geometry_shader_invocations, no_gs.clipping_invocations), (None, 5));
        let mut sum = s;
        sum.add(&s);
        assert_eq!((sum.fragment_shader_invocations, sum.input_assembly_primitives), (14, Some(2)));
    }
}
