//! Shader modules, pipeline layouts, graphics (dynamic rendering) and compute pipelines, RAII.

use ash::vk;

use super::Device;
use crate::error::{Result, VkContext};
use crate::shaders::{ShaderSource, ShaderStage};

fn stage_flags(s: ShaderStage) -> vk::ShaderStageFlags {
    match s {
        ShaderStage::Vertex => vk::ShaderStageFlags::VERTEX,
        ShaderStage::Geometry => vk::ShaderStageFlags::GEOMETRY,
        ShaderStage::Task => vk::ShaderStageFlags::TASK_EXT,
        ShaderStage::Mesh => vk::ShaderStageFlags::MESH_EXT,
        ShaderStage::Fragment => vk::ShaderStageFlags::FRAGMENT,
        ShaderStage::Compute => vk::ShaderStageFlags::COMPUTE,
    }
}

/// A shader module made from an embedded permutation.
pub struct ShaderModule {
    pub raw: vk::ShaderModule,
    pub source: ShaderSource,
    /// The (set, binding) pairs its entry point statically uses ([`statically_used_descriptors`]).
    pub used_descriptors: Vec<(u32, u32)>,
    device: Device,
}

/// The (set, binding) of every descriptor `words`' entry points statically use, sorted. From
/// SPIR-V 1.4 on, an `OpEntryPoint`'s interface lists every global variable the entry point
/// statically uses — descriptors included — so this reads the interfaces and the variables'
/// `DescriptorSet` and `Binding` decorations, nothing else (the build compiles SPIR-V 1.5). A
/// binding a shader declares but never touches is not used: Vulkan reads no descriptor there.
pub fn statically_used_descriptors(words: &[u32]) -> Vec<(u32, u32)> {
    const OP_ENTRY_POINT: u32 = 15;
    const OP_DECORATE: u32 = 71;
    const DECORATION_BINDING: u32 = 33;
    const DECORATION_DESCRIPTOR_SET: u32 = 34;
    let (mut interface, mut set, mut binding) =
        (Vec::new(), std::collections::HashMap::new(), std::collections::HashMap::new());
    let mut at = 5; // after the header
    while at < words.len() {
        let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if count == 0 || at + count > words.len() {
            break; // malformed: nothing more can be read
        }
        let operands = &words[at + 1..at + count];
        match opcode {
            OP_ENTRY_POINT if operands.len() >= 2 => {
                // Execution model, entry id, the name (a NUL-terminated string packed four bytes a
                // word), then the interface ids.
                let name_words =
                    operands[2..].iter().position(|w| w.to_le_bytes().contains(&0)).map_or(0, |i| i + 1);
                interface.extend_from_slice(&operands[(2 + name_words).min(operands.len())..]);
            }
            OP_DECORATE if operands.len() == 3 && operands[1] == DECORATION_DESCRIPTOR_SET => {
                set.insert(operands[0], operands[2]);
            }
            OP_DECORATE if operands.len() == 3 && operands[1] == DECORATION_BINDING => {
                binding.insert(operands[0], operands[2]);
            }
            _ => {}
        }
        at += count;
    }
    let mut used: Vec<(u32, u32)> =
        interface.iter().filter_map(|id| Some((*set.get(id)?, *binding.get(id)?))).collect();
    used.sort_unstable();
    used.dedup();
    used
}

impl ShaderModule {
    pub fn new(device: &Device, source: ShaderSource) -> Result<Self> {
        let words = ash::util::read_spv(&mut std::io::Cursor::new(source.spirv)).map_err(|e| {
            crate::Error::Unsupported(format!("corrupt embedded SPIR-V {}: {e}", source.file))
        })?;
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        let raw = unsafe { device.raw.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
        device.set_name(raw, &format!("{}[{}]", source.file, source.permutation));
        let used_descriptors = statically_used_descriptors(&words);
        Ok(ShaderModule { raw, source, used_descriptors, device: device.clone() })
    }
    /// What makes two modules the same code: the embedded permutation and its SPIR-V (a pipeline's
    /// [`PipelineStore`] key).
    fn key(&self) -> String {
        let s = &self.source;
        format!("{}[{}] {:?} {:p}+{}", s.file, s.permutation, s.stage, s.spirv.as_ptr(), s.spirv.len())
    }
    fn stage_info(&self) -> vk::PipelineShaderStageCreateInfo<'_> {
        vk::PipelineShaderStageCreateInfo::default()
            .stage(stage_flags(self.source.stage))
            .module(self.raw)
            .name(c"main")
    }
}

impl Drop for ShaderModule {
    fn drop(&mut self) {
        unsafe { self.device.raw.destroy_shader_module(self.raw, None) };
    }
}

/// One binding of a descriptor-set table: layouts and pools are created from such tables, and the
/// SPIR-V reflection test checks the shaders against them. `block` names what GLSL binds there: a
/// buffer's block type name (`Materials` in `buffer Materials { .. } materials;`), a sampler's or
/// image's variable name (`albedo_texture`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub binding: u32,
    pub ty: vk::DescriptorType,
    pub block: &'static str,
}

/// A descriptor set layout, RAII.
pub struct DescriptorSetLayout {
    pub raw: vk::DescriptorSetLayout,
    /// Its definition, (binding, type, stages) per descriptor: two layouts defined alike are
    /// compatible, so a pipeline made with one serves the other ([`PipelineStore`]).
    bindings: Vec<(u32, vk::DescriptorType, vk::ShaderStageFlags)>,
    device: Device,
}

impl DescriptorSetLayout {
    /// `bindings`: (binding, type, stages), one descriptor each.
    pub fn new(
        device: &Device,
        name: &str,
        bindings: &[(u32, vk::DescriptorType, vk::ShaderStageFlags)],
    ) -> Result<Self> {
        let b: Vec<_> = bindings
            .iter()
            .map(|&(binding, ty, stages)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(binding)
                    .descriptor_type(ty)
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&b);
        let raw = unsafe { device.raw.create_descriptor_set_layout(&info, None) }
            .vk("vkCreateDescriptorSetLayout")?;
        device.set_name(raw, name);
        Ok(DescriptorSetLayout { raw, bindings: bindings.to_vec(), device: device.clone() })
    }
}

impl DescriptorSetLayout {
    /// A layout with one descriptor per entry of `table`, visible to `stages`.
    pub fn from_table(
        device: &Device,
        name: &str,
        table: &[Binding],
        stages: vk::ShaderStageFlags,
    ) -> Result<Self> {
        let bindings: Vec<_> = table.iter().map(|b| (b.binding, b.ty, stages)).collect();
        DescriptorSetLayout::new(device, name, &bindings)
    }
}

impl Drop for DescriptorSetLayout {
    fn drop(&mut self) {
        unsafe { self.device.raw.destroy_descriptor_set_layout(self.raw, None) };
    }
}

/// A descriptor pool from which sets are allocated; sets die with the pool.
pub struct DescriptorPool {
    pub raw: vk::DescriptorPool,
    /// Every set allocated from it (forgotten by the device's [`DescriptorRefs`] when it goes).
    sets: std::sync::Mutex<Vec<vk::DescriptorSet>>,
    device: Device,
}

impl DescriptorPool {
    pub fn new(device: &Device, max_sets: u32, sizes: &[(vk::DescriptorType, u32)]) -> Result<Self> {
        let s: Vec<_> =
            sizes.iter().map(|&(ty, n)| vk::DescriptorPoolSize { ty, descriptor_count: n.max(1) }).collect();
        let info = vk::DescriptorPoolCreateInfo::default().max_sets(max_sets.max(1)).pool_sizes(&s);
        let raw = unsafe { device.raw.create_descriptor_pool(&info, None) }.vk("vkCreateDescriptorPool")?;
        Ok(DescriptorPool { raw, sets: Default::default(), device: device.clone() })
    }
    /// A pool for `sets` sets of each `(table, sets)` entry.
    pub fn for_tables(device: &Device, max_sets: u32, tables: &[(&[Binding], u32)]) -> Result<Self> {
        let mut sizes: Vec<(vk::DescriptorType, u32)> = Vec::new();
        for (table, sets) in tables {
            for b in table.iter() {
                match sizes.iter_mut().find(|(ty, _)| *ty == b.ty) {
                    Some((_, n)) => *n += sets,
                    None => sizes.push((b.ty, *sets)),
                }
            }
        }
        DescriptorPool::new(device, max_sets, &sizes)
    }
    pub fn allocate(&self, layout: &DescriptorSetLayout) -> Result<vk::DescriptorSet> {
        let layouts = [layout.raw];
        let info = vk::DescriptorSetAllocateInfo::default().descriptor_pool(self.raw).set_layouts(&layouts);
        let set =
            unsafe { self.device.raw.allocate_descriptor_sets(&info) }.vk("vkAllocateDescriptorSets")?[0];
        self.sets.lock().expect("pool sets").push(set);
        Ok(set)
    }
}

impl Drop for DescriptorPool {
    fn drop(&mut self) {
        self.device.descriptor_refs.forget(&self.sets.lock().expect("pool sets"));
        unsafe { self.device.raw.destroy_descriptor_pool(self.raw, None) };
    }
}

/// What one binding of a descriptor set references: a buffer, or an image through one of its views.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DescriptorRef {
    Buffer(vk::Buffer),
    View(vk::ImageView),
}

/// Per descriptor set, what [`write_descriptors`] wrote into it, binding by binding. A pool's sets
/// are forgotten when the pool is dropped, so the record does not grow with every prepared frame and
/// a handle the driver reuses after its pool went starts empty.
#[derive(Default)]
pub struct DescriptorRefs(
    std::sync::Mutex<std::collections::HashMap<vk::DescriptorSet, Vec<(u32, DescriptorRef)>>>,
);

impl DescriptorRefs {
    fn forget(&self, sets: &[vk::DescriptorSet]) {
        let mut map = self.0.lock().expect("descriptor refs");
        for set in sets {
            map.remove(set);
        }
    }

    fn write(&self, set: vk::DescriptorSet, binding: u32, what: DescriptorRef) {
        let mut map = self.0.lock().expect("descriptor refs");
        let refs = map.entry(set).or_default();
        refs.retain(|(b, _)| *b != binding);
        refs.push((binding, what));
    }

    /// What `set` references, by binding (empty for a set Shutter did not write).
    pub fn of(&self, set: vk::DescriptorSet) -> Vec<(u32, DescriptorRef)> {
        self.0.lock().expect("descriptor refs").get(&set).cloned().unwrap_or_default()
    }
}

/// One descriptor write, as data (applied by [`write_descriptors`]).
pub enum DescriptorWrite {
    Buffer { binding: u32, ty: vk::DescriptorType, buffer: vk::Buffer },
    StorageImage { binding: u32, view: vk::ImageView },
    SampledImage { binding: u32, view: vk::ImageView, sampler: vk::Sampler },
}

impl DescriptorWrite {
    pub fn storage_buffer(binding: u32, buffer: &super::Buffer) -> Self {
        DescriptorWrite::Buffer { binding, ty: vk::DescriptorType::STORAGE_BUFFER, buffer: buffer.raw }
    }
    pub fn uniform_buffer(binding: u32, buffer: &super::Buffer) -> Self {
        DescriptorWrite::Buffer { binding, ty: vk::DescriptorType::UNIFORM_BUFFER, buffer: buffer.raw }
    }
}

/// Writes `writes` into `set`, and records what each binding now references
/// ([`DescriptorRefs`]: a graph pass that binds the set must declare those of them in its graph).
pub fn write_descriptors(device: &Device, set: vk::DescriptorSet, writes: &[DescriptorWrite]) {
    for w in writes {
        let (binding, what) = match w {
            DescriptorWrite::Buffer { binding, buffer, .. } => (*binding, DescriptorRef::Buffer(*buffer)),
            DescriptorWrite::StorageImage { binding, view }
            | DescriptorWrite::SampledImage { binding, view, .. } => (*binding, DescriptorRef::View(*view)),
        };
        device.descriptor_refs.write(set, binding, what);
    }
    let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = writes
        .iter()
        .map(|w| match w {
            DescriptorWrite::Buffer { buffer, .. } => {
                [vk::DescriptorBufferInfo::default().buffer(*buffer).range(vk::WHOLE_SIZE)]
            }
            _ => [vk::DescriptorBufferInfo::default()],
        })
        .collect();
    let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = writes
        .iter()
        .map(|w| match w {
            DescriptorWrite::StorageImage { view, .. } => {
                [vk::DescriptorImageInfo::default().image_view(*view).image_layout(vk::ImageLayout::GENERAL)]
            }
            DescriptorWrite::SampledImage { view, sampler, .. } => [vk::DescriptorImageInfo::default()
                .image_view(*view)
                .sampler(*sampler)
                .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)],
            _ => [vk::DescriptorImageInfo::default()],
        })
        .collect();
    let vk_writes: Vec<_> = writes
        .iter()
        .enumerate()
        .map(|(i, w)| {
            let base = vk::WriteDescriptorSet::default().dst_set(set);
            match w {
                DescriptorWrite::Buffer { binding, ty, .. } => {
                    base.dst_binding(*binding).descriptor_type(*ty).buffer_info(&buffer_infos[i])
                }
                DescriptorWrite::StorageImage { binding, .. } => base
                    .dst_binding(*binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(&image_infos[i]),
                DescriptorWrite::SampledImage { binding, .. } => base
                    .dst_binding(*binding)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .image_info(&image_infos[i]),
            }
        })
        .collect();
    unsafe { device.raw.update_descriptor_sets(&vk_writes, &[]) };
}

/// A pipeline layout, RAII.
pub struct PipelineLayout {
    pub raw: vk::PipelineLayout,
    /// Its sets' definitions and its push range, written out: the part of a [`PipelineStore`] key
    /// that stands for the layout (Vulkan calls layouts defined alike compatible).
    definition: String,
    set_count: u32,
    push_bytes: u32,
    push_stages: vk::ShaderStageFlags,
    device: Device,
}

impl PipelineLayout {
    pub fn new(
        device: &Device,
        sets: &[&DescriptorSetLayout],
        push_bytes: u32,
        push_stages: vk::ShaderStageFlags,
    ) -> Result<Self> {
        let set_layouts: Vec<_> = sets.iter().map(|s| s.raw).collect();
        let ranges = [vk::PushConstantRange { stage_flags: push_stages, offset: 0, size: push_bytes }];
        let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_bytes > 0 {
            info = info.push_constant_ranges(&ranges);
        }
        let raw = unsafe { device.raw.create_pipeline_layout(&info, None) }.vk("vkCreatePipelineLayout")?;
        let definition = format!(
            "sets {:?} push {push_bytes} {push_stages:?}",
            sets.iter().map(|s| &s.bindings).collect::<Vec<_>>()
        );
        Ok(PipelineLayout {
            raw,
            definition,
            set_count: sets.len() as u32,
            push_bytes,
            push_stages,
            device: device.clone(),
        })
    }

    /// Its descriptor sets.
    pub fn set_count(&self) -> u32 {
        self.set_count
    }
    /// The size of its one push-constant range (0: none).
    pub fn push_bytes(&self) -> u32 {
        self.push_bytes
    }
    /// The stages of its push-constant range.
    pub fn push_stages(&self) -> vk::ShaderStageFlags {
        self.push_stages
    }
    /// Whether it was created on `device`.
    pub fn belongs_to(&self, device: &Device) -> bool {
        self.device.raw.handle() == device.raw.handle()
    }
}

impl Drop for PipelineLayout {
    fn drop(&mut self) {
        unsafe { self.device.raw.destroy_pipeline_layout(self.raw, None) };
    }
}

/// A pipeline: a handle into its device's [`PipelineStore`], which owns it (or, where the store
/// keeps none, RAII).
pub struct Pipeline {
    pub raw: vk::Pipeline,
    pub bind_point: vk::PipelineBindPoint,
    /// The sides it rasterizes ([`GraphicsDesc::faces`]; [`Faces::Both`] for compute).
    pub faces: Faces,
    /// Its name, as given at creation (for messages).
    pub name: String,
    /// The (set, binding) pairs its stages statically use, sorted: what a draw or dispatch with it
    /// reads through the bound sets (`graph/record.rs` checks those against the pass' declarations).
    pub used_descriptors: Vec<(u32, u32)>,
    device: Device,
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        if !self.device.pipelines.reuses() {
            unsafe { self.device.raw.destroy_pipeline(self.raw, None) };
        }
    }
}

/// The union of `stages`' statically used descriptors, sorted.
fn used_by(stages: &[&ShaderModule]) -> Vec<(u32, u32)> {
    let mut used: Vec<(u32, u32)> = stages.iter().flat_map(|s| s.used_descriptors.iter().copied()).collect();
    used.sort_unstable();
    used.dedup();
    used
}

impl Pipeline {
    /// Whether it was created on `device`.
    pub fn belongs_to(&self, device: &Device) -> bool {
        self.device.raw.handle() == device.raw.handle()
    }
}

/// Every pipeline Shutter created on a device, by what defines it: its stages' code, its fixed
/// state and its layout's definition. A technique prepared again — another scene, the same options —
/// takes the pipelines it had instead of compiling them again. On lavapipe that is most of a
/// prepare's time: the stochastic rasterizer's geometry-shader pipeline takes about 80 ms to create
/// on either version even when Mesa's shader cache holds its code, and a `VkPipelineCache` does not
/// shorten it (measured 2026-12-08; docs/CI.md). The device keeps them until it is dropped: their
/// number is bounded by the shader permutations times the few states each is drawn with.
///
/// A pipeline outlives the layout it was made with, which Vulkan allows where `maintenance4` is
/// enabled: Shutter's own devices enable it; on a lent device without it the store keeps nothing and
/// every [`Pipeline`] destroys its own.
pub struct PipelineStore {
    pipelines: std::sync::Mutex<std::collections::HashMap<String, vk::Pipeline>>,
    reuse: bool,
}

impl PipelineStore {
    /// A store that keeps pipelines (`reuse`) or one that keeps none.
    pub(crate) fn new(reuse: bool) -> Self {
        PipelineStore { pipelines: Default::default(), reuse }
    }

    /// Whether it keeps pipelines for later prepares.
    pub fn reuses(&self) -> bool {
        self.reuse
    }

    /// The pipeline `key` names, made by `create` if the store has none (two threads may both
    /// make it; the second's is destroyed).
    fn get_or_create(
        &self,
        device: &ash::Device,
        key: String,
        create: impl FnOnce() -> Result<vk::Pipeline>,
    ) -> Result<vk::Pipeline> {
        if !self.reuse {
            return create();
        }
        if let Some(&raw) = self.pipelines.lock().expect("pipeline store").get(&key) {
            return Ok(raw);
        }
        // Not locked while the driver compiles: another device thread's pipelines need not wait.
        let made = create()?;
        let mut map = self.pipelines.lock().expect("pipeline store");
        let kept = *map.entry(key).or_insert(made);
        if kept != made {
            unsafe { device.destroy_pipeline(made, None) };
        }
        Ok(kept)
    }

    /// How many pipelines it holds.
    pub fn len(&self) -> usize {
        self.pipelines.lock().expect("pipeline store").len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Destroys them all.
    ///
    /// # Safety
    /// None may be in use or used again: the device calls it as it is dropped.
    pub(crate) unsafe fn destroy_all(&self, device: &ash::Device) {
        let mut map = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        for (_, raw) in map.drain() {
            unsafe { device.destroy_pipeline(raw, None) };
        }
    }
}

/// What a graphics pipeline renders into and how (declared up front, Falcor-style).
pub struct GraphicsDesc<'a> {
    pub name: &'a str,
    pub stages: &'a [&'a ShaderModule],
    pub vertex_bindings: &'a [vk::VertexInputBindingDescription],
    pub vertex_attributes: &'a [vk::VertexInputAttributeDescription],
    pub color_formats: &'a [vk::Format],
    pub depth_format: Option<vk::Format>,
    pub samples: u32,
    /// `Some(min)`: sample-rate shading with minSampleShading = min.
    pub sample_shading: Option<f32>,
    pub faces: Faces,
    pub depth_compare: vk::CompareOp,
    pub depth_write: bool,
    /// Rasterize in `VK_EXT_conservative_rasterization`'s overestimation mode (no extra size): a
    /// fragment, every sample covered, for each pixel whose square the primitive meets. Only the
    /// conservative hulls ask for it, as [`crate::mirror::conservative::choose`] decides.
    pub overestimate: bool,
}

/// Which sides of its triangles a graphics pipeline rasterizes. The front is the side from which a
/// triangle's vertices run counter-clockwise on the image (`gl_FrontFacing`, the reference's `!back`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Faces {
    /// Both sides, always: pipelines whose triangles are not the scene's own faces (bounds, atlas
    /// charts, full-screen passes), shadow casters (one-sided surfaces cast shadows from both sides)
    /// and probes.
    Both,
    /// Per draw: the cull mode is dynamic state, which [`crate::gpu::GpuWorld::record_object_draws`]
    /// sets per object — back faces culled for a one-sided material
    /// ([`crate::scene::Material::one_sided`]), none for a two-sided one.
    PerObject,
}

/// How a graphics pipeline's fragments combine with the colour attachment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColorBlend {
    /// The fragment's colour replaces the attachment's (no blending).
    #[default]
    Replace,
    /// The attachment is multiplied by the fragment's colour, every channel (`dst × src`): coloured
    /// transmission, order-independent because a product is.
    Multiply,
    /// rgb multiplied as [`ColorBlend::Multiply`], alpha the larger of the two (`max(src, dst)`): a
    /// coloured shadow map's hue product and nearest tinted depth (reversed Z), both order-independent.
    MultiplyMaxAlpha,
    /// The fragment's colour is added to the attachment's, every channel (`dst + src`): sums over
    /// fragments, order-independent up to rounding (depth-based stochastic transparency).
    Add,
}

impl Pipeline {
    pub fn graphics(device: &Device, layout: &PipelineLayout, d: &GraphicsDesc) -> Result<Pipeline> {
        Self::graphics_blended(device, layout, d, ColorBlend::Replace)
    }

    /// [`Pipeline::graphics`] with the colour attachments blended as `blend` says.
    pub fn graphics_blended(
        device: &Device,
        layout: &PipelineLayout,
        d: &GraphicsDesc,
        blend: ColorBlend,
    ) -> Result<Pipeline> {
        Self::graphics_written(device, layout, d, blend, None)
    }

    /// [`Pipeline::graphics_blended`] writing only the colour attachments `written[i]` says (the
    /// others keep their contents: write mask 0); `None` writes them all.
    pub fn graphics_written(
        device: &Device,
        layout: &PipelineLayout,
        d: &GraphicsDesc,
        blend: ColorBlend,
        written: Option<&[bool]>,
    ) -> Result<Pipeline> {
        if let Some(w) = written {
            if w.len() != d.color_formats.len() {
                return Err(crate::error::Error::Unsupported(format!(
                    "pipeline `{}`: {} write flags for {} colour attachments",
                    d.name,
                    w.len(),
                    d.color_formats.len()
                )));
            }
            if w.iter().any(|&x| x != w[0]) {
                device.caps.require(
                    super::Feature::IndependentBlend,
                    &format!("pipeline `{}` (it writes some colour attachments and keeps others)", d.name),
                )?;
            }
        }
        let stages: Vec<_> = d.stages.iter().map(|s| s.stage_info()).collect();
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(d.vertex_bindings)
            .vertex_attribute_descriptions(d.vertex_attributes);
        let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
        if d.overestimate {
            device.caps.require(
                super::Feature::ConservativeRasterization,
                &format!("pipeline `{}` (its hull is dilated by the rasterizer's overestimation)", d.name),
            )?;
        }
        let mut conservative = vk::PipelineRasterizationConservativeStateCreateInfoEXT::default()
            .conservative_rasterization_mode(vk::ConservativeRasterizationModeEXT::OVERESTIMATE)
            .extra_primitive_overestimation_size(0.0);
        let mut raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        if d.overestimate {
            raster = raster.push_next(&mut conservative);
        }
        let mut multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::from_raw(d.samples));
        if let Some(min) = d.sample_shading {
            multisample = multisample.sample_shading_enable(true).min_sample_shading(min);
        }
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(d.depth_format.is_some())
            .depth_write_enable(d.depth_write)
            .depth_compare_op(d.depth_compare);
        let blend_attachments: Vec<_> = (0..d.color_formats.len())
            .map(|i| {
                let mask = match written {
                    Some(w) if !w[i] => vk::ColorComponentFlags::empty(),
                    _ => vk::ColorComponentFlags::RGBA,
                };
                let state = vk::PipelineColorBlendAttachmentState::default().color_write_mask(mask);
                match blend {
                    ColorBlend::Replace => state,
                    // result = src · dst + dst · 0
                    ColorBlend::Multiply => state
                        .blend_enable(true)
                        .src_color_blend_factor(vk::BlendFactor::DST_COLOR)
                        .dst_color_blend_factor(vk::BlendFactor::ZERO)
                        .color_blend_op(vk::BlendOp::ADD)
                        .src_alpha_blend_factor(vk::BlendFactor::DST_ALPHA)
                        .dst_alpha_blend_factor(vk::BlendFactor::ZERO)
                        .alpha_blend_op(vk::BlendOp::ADD),
                    // rgb = src · dst; a = max(src, dst) (factors are ignored by MAX)
                    ColorBlend::MultiplyMaxAlpha => state
                        .blend_enable(true)
                        .src_color_blend_factor(vk::BlendFactor::DST_COLOR)
                        .dst_color_blend_factor(vk::BlendFactor::ZERO)
                        .color_blend_op(vk::BlendOp::ADD)
                        .src_alpha_blend_factor(vk::BlendFactor::ONE)
                        .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                        .alpha_blend_op(vk::BlendOp::MAX),
                    // result = src · 1 + dst · 1
                    ColorBlend::Add => state
                        .blend_enable(true)
                        .src_color_blend_factor(vk::BlendFactor::ONE)
                        .dst_color_blend_factor(vk::BlendFactor::ONE)
                        .color_blend_op(vk::BlendOp::ADD)
                        .src_alpha_blend_factor(vk::BlendFactor::ONE)
                        .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                        .alpha_blend_op(vk::BlendOp::ADD),
                }
            })
            .collect();
        let blend_state = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let mut dynamic_states = vec![vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        if d.faces == Faces::PerObject {
            // Core in Vulkan 1.3, which the device context requires.
            dynamic_states.push(vk::DynamicState::CULL_MODE);
        }
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(d.color_formats)
            .depth_attachment_format(d.depth_format.unwrap_or(vk::Format::UNDEFINED));
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend_state)
            .dynamic_state(&dynamic)
            .layout(layout.raw)
            .push_next(&mut rendering);
        let key = format!(
            // Plain values only: a create-info struct would print its pointers.
            "graphics {} | {} | {:?} {:?} | {:?} {:?} | {} {:?} | {:?} {:?} {} {} | {blend:?} {written:?}",
            d.stages.iter().map(|s| s.key()).collect::<Vec<_>>().join(" + "),
            layout.definition,
            d.vertex_bindings,
            d.vertex_attributes,
            d.color_formats,
            d.depth_format,
            d.samples,
            d.sample_shading,
            d.faces,
            d.depth_compare,
            d.depth_write,
            d.overestimate,
        );
        let raw = device.pipelines.get_or_create(&device.raw, key, || {
            let raw =
                unsafe { device.raw.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
                    .map_err(|(_, e)| e)
                    .vk("vkCreateGraphicsPipelines")?[0];
            device.set_name(raw, d.name);
            Ok(raw)
        })?;
        Ok(Pipeline {
            raw,
            bind_point: vk::PipelineBindPoint::GRAPHICS,
            faces: d.faces,
            name: d.name.to_string(),
            used_descriptors: used_by(d.stages),
            device: device.clone(),
        })
    }

    pub fn compute(
        device: &Device,
        name: &str,
        layout: &PipelineLayout,
        shader: &ShaderModule,
    ) -> Result<Pipeline> {
        let info = vk::ComputePipelineCreateInfo::default().stage(shader.stage_info()).layout(layout.raw);
        let key = format!("compute {} | {}", shader.key(), layout.definition);
        let raw = device.pipelines.get_or_create(&device.raw, key, || {
            let raw =
                unsafe { device.raw.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) }
                    .map_err(|(_, e)| e)
                    .vk("vkCreateComputePipelines")?[0];
            device.set_name(raw, name);
            Ok(raw)
        })?;
        Ok(Pipeline {
            raw,
            bind_point: vk::PipelineBindPoint::COMPUTE,
            faces: Faces::Both,
            name: name.to_string(),
            used_descriptors: used_by(&[shader]),
            device: device.clone(),
        })
    }
}
