//! A small typed frame graph: techniques declare passes and what each reads and writes; the graph
//! places every barrier and layout transition, opens a debug label and a named GPU timestamp scope per
//! pass, repeats a group of passes (the P passes of a multipass frame), and submits.
//!
//! # The contract
//! * **Resources.** A handle ([`ImageHandle`], [`BufferHandle`]) carries its description. It is either
//!   *imported* — a [`Tracked`] resource the technique owns, whose synchronization state persists
//!   across passes, graphs and frames (accumulators, caches, per-view triangle buffers) — or *transient*
//!   ([`FrameGraph::create_image`]): taken from a [`TransientPool`] for this graph only, contents
//!   undefined at its first use (MSAA colour, depth). Read-only data the host wrote before the frame
//!   (scene geometry, materials, textures, sample tables) may be bound without being declared:
//!   `vkQueueSubmit` makes host writes visible, and nothing on the GPU writes it.
//! * **Passes** ([`FrameGraph::pass`]) declare every GPU access to a graph resource with a
//!   `vk_sync_fork::AccessType` (re-exported as [`Access`]): sampled, storage read/write, transfer,
//!   host read, or — through [`PassBuilder::color`], [`PassBuilder::resolve`], [`PassBuilder::depth`] —
//!   a colour/depth attachment with its load and store ops, which makes the pass a *raster* pass: the
//!   graph begins dynamic rendering over the attachments and sets viewport and scissor to them.
//!   A pass that overwrites a resource whole may say so ([`PassBuilder::overwrite`], clear and
//!   don't-care loads do it implicitly), so its image transitions from `UNDEFINED`.
//! * **Barriers** are derived while recording from each resource's last accesses ([`state`]): exactly
//!   the hazards are synchronised, through vk-sync's stage/access/layout tables. A CPU read of
//!   GPU-written data is declared ([`FrameGraph::host_read`], [`FrameGraph::read_back`]) and gets its
//!   device→host dependency before the submission ends.
//! * **Repeat** ([`FrameGraph::repeat`]): a group of passes recorded `count` times; each call of a
//!   pass' recording closure sees the iteration in [`PassContext::iteration`]. Barriers between
//!   iterations follow from the same tracking.
//! * **Submission** ([`FrameGraph::execute`]): passes are recorded in order into command buffers of at
//!   most [`MAX_PASSES_PER_SUBMIT`] passes — as many as take about [`TARGET_SUBMIT_SECONDS`], so an
//!   interrupt is seen within about that long — each submitted through the one submit path
//!   ([`CommandRecorder::submit`]), which waits for it: nothing is ever in flight when `execute`
//!   returns, so RAII wrappers may free their handles at any time the CPU holds them.
//! * **Recording for a caller** ([`FrameGraph::record_into`]): an embedding engine's frame is
//!   recorded whole into the engine's command buffer, neither submitted nor waited on; the transient
//!   resources it used are handed out, to live until the engine says the frame executed
//!   (`crate::embed`). A caller's image enters with the state the caller left it in
//!   (`import_external_image`).
//! * No aliasing, no async compute, no reordering: passes run in declaration order.
//!
//! kajiya's `kajiya-rg` and Granite's render graph were the models (declared accesses with vk-sync
//! access types; imported vs transient resources); this one is much smaller: it compiles nothing
//! ahead, tracks state while recording, and keeps techniques' own descriptor sets.

mod record;
pub mod state;

use std::cell::RefCell;
use std::rc::Rc;

use ash::vk;
use gpu_allocator::MemoryLocation;

pub use state::ResourceState;
pub use vk_sync_fork::AccessType as Access;

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::vk::{read_rgba32f, Buffer, CommandRecorder, Device, GpuTimer, Image, ImageDesc, PassTimings};

/// Passes recorded per command buffer (bounds command-buffer size and the timestamp pool).
pub const MAX_PASSES_PER_SUBMIT: usize = 128;

/// Wall time one submission aims at. An interrupt (Ctrl-C) is seen between submissions, so this is
/// about how long stopping waits; the passes per submission follow the measured time per pass (at
/// most [`MAX_PASSES_PER_SUBMIT`]): 128 passes of a stochastic frame at a high S took a minute on
/// lavapipe, all before an interrupt could be seen.
pub const TARGET_SUBMIT_SECONDS: f64 = 0.25;

/// Passes in the first submission of a graph, before any pass has been timed; each later one at
/// most doubles.
const FIRST_SUBMIT_PASSES: usize = 4;

/// A resource the technique owns, with its synchronization state between graphs and frames.
pub struct Tracked<T> {
    resource: T,
    state: RefCell<ResourceState>,
}

impl<T> Tracked<T> {
    /// A resource nothing has accessed yet (undefined layout, no pending writes).
    pub fn new(resource: T) -> Self {
        Tracked { resource, state: RefCell::new(ResourceState::default()) }
    }
    /// The resource, to change it between graphs (e.g. host writes to a mapped buffer).
    pub fn get_mut(&mut self) -> &mut T {
        &mut self.resource
    }
    /// Its state after the last graph that used it (for tests and diagnostics).
    pub fn state(&self) -> ResourceState {
        self.state.borrow().clone()
    }
}

impl<T> std::ops::Deref for Tracked<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.resource
    }
}

/// Images and buffers lent to graphs as transient resources, kept between frames so a frame of the
/// same shape allocates nothing. A resource is reused when its name and description match and no live
/// graph holds it.
#[derive(Default)]
pub struct TransientPool {
    images: RefCell<Vec<(String, Rc<Image>)>>,
    buffers: RefCell<Vec<(String, BufferKey, Rc<Buffer>)>>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
struct BufferKey {
    size: u64,
    usage: vk::BufferUsageFlags,
    host_visible: bool,
}

impl TransientPool {
    fn image(&self, device: &Device, name: &str, desc: ImageDesc) -> Result<Rc<Image>> {
        let mut images = self.images.borrow_mut();
        if let Some((_, i)) =
            images.iter().find(|(n, i)| n == name && i.desc == desc && Rc::strong_count(i) == 1)
        {
            return Ok(i.clone());
        }
        let image = Rc::new(Image::new(device, name, desc)?);
        images.push((name.to_string(), image.clone()));
        Ok(image)
    }

    fn buffer(&self, device: &Device, name: &str, key: BufferKey) -> Result<Rc<Buffer>> {
        let mut buffers = self.buffers.borrow_mut();
        if let Some((_, _, b)) =
            buffers.iter().find(|(n, k, b)| n == name && *k == key && Rc::strong_count(b) == 1)
        {
            return Ok(b.clone());
        }
        let location = if key.host_visible { MemoryLocation::GpuToCpu } else { MemoryLocation::GpuOnly };
        let buffer = Rc::new(Buffer::new(device, name, key.size, key.usage, location)?);
        buffers.push((name.to_string(), key, buffer.clone()));
        Ok(buffer)
    }
}

/// An image of a graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageHandle {
    index: usize,
    pub desc: ImageDesc,
}

/// A buffer of a graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferHandle {
    index: usize,
    pub size: u64,
}

/// Either kind of handle, for the access declarations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResourceHandle {
    Image(ImageHandle),
    Buffer(BufferHandle),
}

impl ResourceHandle {
    fn index(&self) -> usize {
        match self {
            ResourceHandle::Image(h) => h.index,
            ResourceHandle::Buffer(h) => h.index,
        }
    }
}

impl From<ImageHandle> for ResourceHandle {
    fn from(h: ImageHandle) -> Self {
        ResourceHandle::Image(h)
    }
}
impl From<BufferHandle> for ResourceHandle {
    fn from(h: BufferHandle) -> Self {
        ResourceHandle::Buffer(h)
    }
}

/// A graph recorded into a caller's command buffer ([`FrameGraph::record_into`]): the transient
/// resources its commands use, which must outlive their execution, and the passes recorded.
pub struct RecordedGraph {
    /// Held until the caller says the commands have executed (the transient pool does not lend a
    /// resource to another graph while it is held here).
    pub(crate) retained: Vec<Rc<dyn std::any::Any>>,
    /// The passes recorded, in order (repeats once per iteration).
    pub passes: Vec<String>,
}

/// A CPU copy of an image the graph reads back ([`FrameGraph::read_back`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Readback {
    index: usize,
}

/// How an attachment starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load<T> {
    /// Cleared to a value (the old contents are discarded).
    Clear(T),
    /// Kept from the previous writer.
    Load,
    /// Undefined (discarded).
    DontCare,
}

/// What happens to an attachment's contents at the end of the pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Store {
    Store,
    DontCare,
}

impl Store {
    fn op(self) -> vk::AttachmentStoreOp {
        match self {
            Store::Store => vk::AttachmentStoreOp::STORE,
            Store::DontCare => vk::AttachmentStoreOp::DONT_CARE,
        }
    }
}

fn load_op<T>(l: &Load<T>) -> vk::AttachmentLoadOp {
    match l {
        Load::Clear(_) => vk::AttachmentLoadOp::CLEAR,
        Load::Load => vk::AttachmentLoadOp::LOAD,
        Load::DontCare => vk::AttachmentLoadOp::DONT_CARE,
    }
}

enum Slot<'a> {
    ImportedImage(&'a Tracked<Image>),
    ImportedBuffer(&'a Tracked<Buffer>),
    TransientImage(Rc<Image>),
    TransientBuffer(Rc<Buffer>),
    /// A caller's image ([`FrameGraph::import_external_image`]): its state before the graph is
    /// what the caller says; after it, the caller's to know (the graph ends with the access it asked
    /// for).
    External {
        image: Image,
        before: ResourceState,
    },
}

struct Resource<'a> {
    name: String,
    slot: Slot<'a>,
}

impl Resource<'_> {
    fn is_image(&self) -> bool {
        self.image().is_some()
    }
    fn image(&self) -> Option<&Image> {
        match &self.slot {
            Slot::ImportedImage(t) => Some(t),
            Slot::TransientImage(i) => Some(i),
            Slot::External { image, .. } => Some(image),
            _ => None,
        }
    }
    fn buffer(&self) -> Option<&Buffer> {
        match &self.slot {
            Slot::ImportedBuffer(t) => Some(t),
            Slot::TransientBuffer(b) => Some(b),
            _ => None,
        }
    }
    /// The state cell of an imported resource (None for a transient one).
    fn tracked_state(&self) -> Option<&RefCell<ResourceState>> {
        match &self.slot {
            Slot::ImportedImage(t) => Some(&t.state),
            Slot::ImportedBuffer(t) => Some(&t.state),
            _ => None,
        }
    }
    fn initial_state(&self) -> ResourceState {
        if let Slot::External { before, .. } = &self.slot {
            return before.clone();
        }
        self.tracked_state().map(|c| c.borrow().clone()).unwrap_or_default()
    }
    fn store_state(&self, s: &ResourceState) {
        if let Some(c) = self.tracked_state() {
            *c.borrow_mut() = s.clone();
        }
    }
}

/// One declared use of a resource by a pass.
struct Use {
    resource: usize,
    accesses: Vec<Access>,
    discard: bool,
}

struct ColorTarget {
    image: usize,
    load: Load<[f32; 4]>,
    store: Store,
    resolve: Option<usize>,
}

struct DepthTarget {
    image: usize,
    load: Load<f32>,
    store: Store,
    read_only: bool,
}

#[derive(Default)]
struct Attachments {
    colors: Vec<ColorTarget>,
    depth: Option<DepthTarget>,
    /// Render area of a raster pass without attachments (its fragments only have side effects).
    area: Option<vk::Extent2D>,
}

impl Attachments {
    /// Whether the pass rasterizes (begins dynamic rendering).
    fn is_raster(&self) -> bool {
        !self.colors.is_empty() || self.depth.is_some() || self.area.is_some()
    }
}

type RecordFn<'a> = Box<dyn FnMut(&mut PassContext<'_>) -> Result<()> + 'a>;

struct Pass<'a> {
    name: String,
    uses: Vec<Use>,
    attachments: Attachments,
    /// GPU work (None: a pass that only places barriers, e.g. a host read).
    record: Option<RecordFn<'a>>,
}

enum Node<'a> {
    Pass(Pass<'a>),
    Repeat { count: u32, passes: Vec<Pass<'a>> },
}

/// What a pass' recording closure gets, and records with: typed commands (`bind_pipeline`,
/// `bind_sets`, `push`, `dispatch`, `draw`, `fill_buffer`, … in `graph/record.rs`), which check what
/// they can of the contract below — the pass' declared accesses included — and hold its one `unsafe`.
///
/// # Recording raw commands: the contract
///
/// Those commands, and a closure that records a command they lack with `ash`'s raw `cmd_*` calls on
/// [`PassContext::cmd`] (`unsafe`: Vulkan checks nothing), rely on this. The executor guarantees, for
/// the duration of the closure:
///
/// * `cmd` is a primary command buffer of `device` in the recording state, not submitted until the
///   closure returns; inside a raster pass, dynamic rendering over the pass' attachments (or its
///   [`PassBuilder::render_area`]) has begun, with viewport and scissor set; outside one it has not;
/// * every resource the pass declared (`access`, `overwrite`, attachments) has the layout and the
///   barriers its declared accesses need, and [`PassContext::image`] / [`PassContext::buffer`] return
///   live handles for it.
///
/// The closure in turn promises, and each `// SAFETY:` comment in a technique points here for it:
///
/// * it touches on the GPU only what the pass declared, or read-only data the host wrote before the
///   frame (the world, views, sample tables: see the frame graph's docs), with the access it declared;
/// * every handle it records (pipelines, layouts, descriptor sets, buffers) belongs to `device` and
///   outlives the graph's execution: the technique owns it, and the graph borrows the technique;
/// * descriptor sets and push constants it binds match the bound pipeline's layout (the layouts are
///   checked against every shader permutation by `gpu/layout_tests.rs`), and push ranges lie in it;
/// * it begins or ends no rendering and submits nothing; synchronization inside one pass (e.g.
///   between consecutive dispatches) is its own, with explicit barriers.
pub struct PassContext<'r> {
    pub device: &'r Device,
    pub cmd: vk::CommandBuffer,
    /// The iteration of the enclosing [`FrameGraph::repeat`] (0 outside one).
    pub iteration: u32,
    /// The render area of a raster pass (zero otherwise).
    pub extent: vk::Extent2D,
    resources: &'r [Resource<'r>],
    /// What the pass declared (the typed commands check their resources against it).
    uses: &'r [Use],
    /// What its commands bound, for the check of what a draw or dispatch reads (`record.rs`).
    bound: std::cell::RefCell<record::Bound>,
}

impl PassContext<'_> {
    /// The image behind a handle.
    pub fn image(&self, h: ImageHandle) -> &Image {
        self.resources[h.index].image().expect("image handle names an image")
    }
    /// The buffer behind a handle.
    pub fn buffer(&self, h: BufferHandle) -> &Buffer {
        self.resources[h.index].buffer().expect("buffer handle names a buffer")
    }
}

/// The passes of one submission sequence. Build, then [`FrameGraph::execute`].
pub struct FrameGraph<'a> {
    device: Device,
    pool: Rc<TransientPool>,
    resources: Vec<Resource<'a>>,
    nodes: Vec<Node<'a>>,
    /// Passes of the repeat node being built.
    repeat_body: Option<Vec<Pass<'a>>>,
    /// (image read back, host-visible buffer it is copied to).
    readbacks: Vec<(ImageHandle, BufferHandle)>,
}

/// What a graph produced: GPU time per pass name (repeats summed) and the images read back.
pub struct GraphResult {
    pub timings: PassTimings,
    images: Vec<LinearImage>,
}

impl GraphResult {
    /// No timings, no images: what a graph recorded for a caller returns.
    pub(crate) fn empty() -> Self {
        GraphResult { timings: PassTimings::default(), images: Vec::new() }
    }
    /// The CPU copy of a read-back image.
    pub fn image(&self, r: Readback) -> &LinearImage {
        &self.images[r.index]
    }
    /// Takes the CPU copy of a read-back image out.
    pub fn take_image(&mut self, r: Readback) -> LinearImage {
        std::mem::replace(&mut self.images[r.index], LinearImage::new(0, 0))
    }
}

impl<'a> FrameGraph<'a> {
    /// An empty graph on `device` whose transient resources come from `pool`.
    pub fn new(device: &Device, pool: Rc<TransientPool>) -> Self {
        FrameGraph {
            device: device.clone(),
            pool,
            resources: Vec::new(),
            nodes: Vec::new(),
            repeat_body: None,
            readbacks: Vec::new(),
        }
    }

    pub fn device(&self) -> &Device {
        &self.device
    }

    fn add(&mut self, name: &str, slot: Slot<'a>) -> usize {
        self.resources.push(Resource { name: name.to_string(), slot });
        self.resources.len() - 1
    }

    /// Adds an imported resource once: importing the same `Tracked` again returns its first index (one
    /// resource, one state).
    fn import(&mut self, name: &str, slot: Slot<'a>, state: &RefCell<ResourceState>) -> usize {
        let known =
            self.resources.iter().position(|r| r.tracked_state().is_some_and(|c| std::ptr::eq(c, state)));
        known.unwrap_or_else(|| self.add(name, slot))
    }

    /// Lends a persistent image to this graph; its state carries over from earlier graphs. Importing
    /// the same image again returns the same handle.
    pub fn import_image(&mut self, name: &str, image: &'a Tracked<Image>) -> ImageHandle {
        ImageHandle { index: self.import(name, Slot::ImportedImage(image), &image.state), desc: image.desc }
    }

    /// Lends a persistent buffer to this graph; its state carries over from earlier graphs. Importing
    /// the same buffer again returns the same handle.
    pub fn import_buffer(&mut self, name: &str, buffer: &'a Tracked<Buffer>) -> BufferHandle {
        BufferHandle {
            index: self.import(name, Slot::ImportedBuffer(buffer), &buffer.state),
            size: buffer.size,
        }
    }

    /// Lends a caller's image to this graph (embedding: the frame's result is copied into it).
    /// `before` is its state as the caller left it — the accesses the first pass using it must wait
    /// for, and its layout. Its state after the graph is not kept: declare the access the caller
    /// needs next in a last pass ([`PassBuilder::barrier_only`]).
    pub(crate) fn import_external_image(
        &mut self,
        name: &str,
        image: Image,
        before: ResourceState,
    ) -> ImageHandle {
        let desc = image.desc;
        ImageHandle { index: self.add(name, Slot::External { image, before }), desc }
    }

    /// A transient image for this graph only (from the pool); undefined until a pass writes it.
    pub fn create_image(&mut self, name: &str, desc: ImageDesc) -> Result<ImageHandle> {
        let image = self.pool.image(&self.device, name, desc)?;
        Ok(ImageHandle { index: self.add(name, Slot::TransientImage(image)), desc })
    }

    /// A transient buffer for this graph only (from the pool); `host_visible` for CPU reads.
    pub fn create_buffer(
        &mut self,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        host_visible: bool,
    ) -> Result<BufferHandle> {
        let buffer = self.pool.buffer(&self.device, name, BufferKey { size, usage, host_visible })?;
        Ok(BufferHandle { index: self.add(name, Slot::TransientBuffer(buffer)), size })
    }

    /// Starts declaring a pass named `name` (its debug label and timestamp scope).
    pub fn pass(&mut self, name: impl Into<String>) -> PassBuilder<'_, 'a> {
        PassBuilder {
            graph: self,
            pass: Pass {
                name: name.into(),
                uses: Vec::new(),
                attachments: Attachments::default(),
                record: None,
            },
        }
    }

    fn push(&mut self, pass: Pass<'a>) {
        match &mut self.repeat_body {
            Some(body) => body.push(pass),
            None => self.nodes.push(Node::Pass(pass)),
        }
    }

    /// Declares the passes `body` adds as a group recorded `count` times in a row (repeat nodes do
    /// not nest). A count of 0 records nothing.
    pub fn repeat(&mut self, count: u32, body: impl FnOnce(&mut Self) -> Result<()>) -> Result<()> {
        if self.repeat_body.is_some() {
            return Err(Error::Graph("repeat nodes do not nest".into()));
        }
        self.repeat_body = Some(Vec::new());
        let built = body(self);
        let passes = self.repeat_body.take().expect("set above");
        built?;
        self.nodes.push(Node::Repeat { count, passes });
        Ok(())
    }

    /// A pass named `name` that clears all of colour image `image` to `value` (a transfer write: the
    /// image needs `TRANSFER_DST` usage).
    pub fn clear_color(&mut self, name: &str, image: ImageHandle, value: [f32; 4]) {
        self.pass(name).overwrite(image, Access::TransferWrite).record(move |ctx| {
            let target = ctx.image(image);
            let clear = vk::ClearColorValue { float32: value };
            // SAFETY: the recording contract of `PassContext`; the pass declared the overwrite
            // (TRANSFER_DST).
            unsafe {
                ctx.device.raw.cmd_clear_color_image(
                    ctx.cmd,
                    target.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &clear,
                    &[target.full_range()],
                )
            };
            Ok(())
        });
    }

    /// A pass named `name` that copies all of colour image `src` into `dst`, of the same size, which
    /// it overwrites: a plain copy between equal formats, else a blit, which converts as
    /// `vkCmdBlitImage` does (to 8-bit UNORM or sRGB, say; nearest filter at equal sizes, so no
    /// resampling). `src` needs `TRANSFER_SRC` usage and `dst` `TRANSFER_DST`; a blit also needs the
    /// formats' blit features.
    pub fn copy_image(&mut self, name: &str, src: ImageHandle, dst: ImageHandle) -> Result<()> {
        let (w, h) = (src.desc.width, src.desc.height);
        if (w, h) != (dst.desc.width, dst.desc.height) {
            return Err(Error::Graph(format!(
                "pass `{name}`: copies a {w}×{h} image into a {}×{} one (sizes must match)",
                dst.desc.width, dst.desc.height
            )));
        }
        let same_format = src.desc.format == dst.desc.format;
        self.pass(name).access(src, Access::TransferRead).overwrite(dst, Access::TransferWrite).record(
            move |ctx| {
                let (from, to) = (ctx.image(src), ctx.image(dst));
                let layers = vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .layer_count(1);
                let (src_layout, dst_layout) =
                    (vk::ImageLayout::TRANSFER_SRC_OPTIMAL, vk::ImageLayout::TRANSFER_DST_OPTIMAL);
                if same_format {
                    let region = vk::ImageCopy::default()
                        .src_subresource(layers)
                        .dst_subresource(layers)
                        .extent(vk::Extent3D { width: w, height: h, depth: 1 });
                    unsafe {
                        ctx.device.raw.cmd_copy_image(
                            ctx.cmd,
                            from.raw,
                            src_layout,
                            to.raw,
                            dst_layout,
                            &[region],
                        )
                    };
                } else {
                    let corner = vk::Offset3D { x: w as i32, y: h as i32, z: 1 };
                    let region = vk::ImageBlit::default()
                        .src_subresource(layers)
                        .dst_subresource(layers)
                        .src_offsets([vk::Offset3D::default(), corner])
                        .dst_offsets([vk::Offset3D::default(), corner]);
                    unsafe {
                        ctx.device.raw.cmd_blit_image(
                            ctx.cmd,
                            from.raw,
                            src_layout,
                            to.raw,
                            dst_layout,
                            &[region],
                            vk::Filter::NEAREST,
                        )
                    };
                }
                Ok(())
            },
        );
        Ok(())
    }

    /// Makes the GPU's writes to `buffer` visible to the host once [`FrameGraph::execute`] returns
    /// (the device→host memory dependency), for a host-visible buffer the CPU then maps.
    pub fn host_read(&mut self, buffer: BufferHandle) {
        self.push(Pass {
            name: "host read".into(),
            uses: vec![Use { resource: buffer.index, accesses: vec![Access::HostRead], discard: false }],
            attachments: Attachments::default(),
            record: None,
        });
    }

    /// Copies an `R32G32B32A32_SFLOAT` image to a host-visible buffer in a pass named `readback`; the
    /// result holds it as a [`LinearImage`].
    pub fn read_back(&mut self, image: ImageHandle) -> Result<Readback> {
        if image.desc.format != vk::Format::R32G32B32A32_SFLOAT {
            return Err(Error::Graph(format!(
                "read_back needs an RGBA32F image, not {:?}",
                image.desc.format
            )));
        }
        let bytes = image.desc.width as u64 * image.desc.height as u64 * 16;
        let buffer = self.create_buffer("readback", bytes, vk::BufferUsageFlags::TRANSFER_DST, true)?;
        self.pass("readback")
            .access(image, Access::TransferRead)
            .overwrite(buffer, Access::TransferWrite)
            .record(move |ctx| {
                let (src, dst) = (ctx.image(image), ctx.buffer(buffer));
                let region = vk::BufferImageCopy::default()
                    .image_subresource(
                        vk::ImageSubresourceLayers::default()
                            .aspect_mask(vk::ImageAspectFlags::COLOR)
                            .layer_count(1),
                    )
                    .image_extent(vk::Extent3D { width: src.desc.width, height: src.desc.height, depth: 1 });
                // SAFETY: the recording contract of `PassContext`; the pass declared the image read
                // (TRANSFER_SRC) and the host-visible buffer written.
                unsafe {
                    ctx.device.raw.cmd_copy_image_to_buffer(
                        ctx.cmd,
                        src.raw,
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                        dst.raw,
                        &[region],
                    )
                };
                Ok(())
            });
        self.host_read(buffer);
        self.readbacks.push((image, buffer));
        Ok(Readback { index: self.readbacks.len() - 1 })
    }

    /// Records every pass in order, submitting (and waiting) every few passes: as many as take about
    /// [`TARGET_SUBMIT_SECONDS`], at most [`MAX_PASSES_PER_SUBMIT`]; an interrupt is checked before
    /// each submission.
    pub fn execute(self, rec: &mut CommandRecorder) -> Result<GraphResult> {
        self.execute_reporting(rec, None)
    }

    /// [`FrameGraph::execute`], showing progress under `label` ([`crate::progress`]) when the graph
    /// takes more than one submission, and stopping with [`Error::Interrupted`] between submissions
    /// once an interrupt is requested (nothing is in flight then).
    pub fn execute_reporting(self, rec: &mut CommandRecorder, label: Option<&str>) -> Result<GraphResult> {
        self.execute_counting(rec, label, None)
    }

    /// [`FrameGraph::execute_reporting`], with `statistics` (a pipeline-statistics query) begun
    /// and ended around every submission and its counts added up.
    pub fn execute_counting(
        self,
        rec: &mut CommandRecorder,
        label: Option<&str>,
        mut statistics: Option<&mut crate::vk::StatisticsQuery>,
    ) -> Result<GraphResult> {
        crate::progress::check_interrupt()?;
        let FrameGraph { device, resources, mut nodes, readbacks, .. } = self;
        let mut schedule: Vec<(usize, usize, u32)> = Vec::new();
        for (ni, node) in nodes.iter().enumerate() {
            match node {
                Node::Pass(_) => schedule.push((ni, 0, 0)),
                Node::Repeat { count, passes } => {
                    for it in 0..*count {
                        schedule.extend((0..passes.len()).map(|pi| (ni, pi, it)));
                    }
                }
            }
        }
        let mut states: Vec<ResourceState> = resources.iter().map(|r| r.initial_state()).collect();
        let timed = schedule.len().min(MAX_PASSES_PER_SUBMIT) as u32;
        let mut timer = GpuTimer::new(&device, timed.max(1))?;
        let mut timings = PassTimings::default();
        let progress = match label {
            Some(label) if schedule.len() > MAX_PASSES_PER_SUBMIT => {
                crate::progress::Progress::new(label, schedule.len() as u64, "GPU passes")
            }
            _ => crate::progress::Progress::hidden(),
        };
        let mut next = 0;
        let mut chunk = FIRST_SUBMIT_PASSES;
        while next < schedule.len() {
            crate::progress::check_interrupt()?;
            let end = (next + chunk).min(schedule.len());
            let started = std::time::Instant::now();
            rec.submit(|d, cmd| {
                timer.reset(cmd);
                if let Some(q) = statistics.as_deref() {
                    q.begin(cmd);
                }
                for &(ni, pi, iteration) in &schedule[next..end] {
                    let pass = match &mut nodes[ni] {
                        Node::Pass(p) => p,
                        Node::Repeat { passes, .. } => &mut passes[pi],
                    };
                    record_pass(d, cmd, pass, iteration, &resources, &mut states, &mut timer)?;
                }
                if let Some(q) = statistics.as_deref() {
                    q.end(cmd);
                }
                Ok(())
            })?;
            if let Some(q) = statistics.as_deref_mut() {
                q.collect()?;
            }
            // What was submitted has happened: persistent resources remember it.
            for (r, s) in resources.iter().zip(&states) {
                r.store_state(s);
            }
            timings.add(&timer.results()?);
            progress.inc((end - next) as u64);
            // The next submission: as many passes as fit the target at this one's pace.
            let per_pass = started.elapsed().as_secs_f64() / (end - next) as f64;
            let fit = if per_pass > 0.0 { (TARGET_SUBMIT_SECONDS / per_pass) as usize } else { usize::MAX };
            chunk = fit.clamp(1, (2 * chunk).min(MAX_PASSES_PER_SUBMIT));
            next = end;
        }
        progress.finish();
        let images = readbacks
            .iter()
            .map(|(image, buffer)| {
                let b = resources[buffer.index].buffer().expect("readback buffer");
                read_rgba32f(b, image.desc.width, image.desc.height)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(GraphResult { timings, images })
    }
}

impl FrameGraph<'_> {
    /// Records every pass in order into `cmd` — a caller's command buffer, in the recording state —
    /// and neither submits nor waits: embedding, where the caller submits the frame with its own
    /// work. Persistent resources take the state the recorded commands leave them in, so the caller
    /// must submit `cmd` before any later graph's commands that use them, on a queue of the device's
    /// queue family. No timestamps are written (Shutter never sees the commands complete) and a
    /// graph with a read-back is refused (the CPU copy would exist only after the caller's fence).
    /// On an error `cmd` holds part of the graph: reset it rather than submit it.
    pub fn record_into(self, cmd: vk::CommandBuffer) -> Result<RecordedGraph> {
        let FrameGraph { device, resources, mut nodes, readbacks, .. } = self;
        if !readbacks.is_empty() {
            return Err(Error::Graph(
                "a graph recorded into a caller's command buffer cannot read an image back: the copy \
                 exists only once the caller's submission completes (copy it into the caller's image)"
                    .into(),
            ));
        }
        let mut states: Vec<ResourceState> = resources.iter().map(|r| r.initial_state()).collect();
        let mut timer = GpuTimer::disabled(&device);
        let mut passes = Vec::new();
        for node in &mut nodes {
            match node {
                Node::Pass(pass) => {
                    record_pass(&device, cmd, pass, 0, &resources, &mut states, &mut timer)?;
                    passes.push(pass.name.clone());
                }
                Node::Repeat { count, passes: body } => {
                    for iteration in 0..*count {
                        for pass in body.iter_mut() {
                            record_pass(&device, cmd, pass, iteration, &resources, &mut states, &mut timer)?;
                            passes.push(pass.name.clone());
                        }
                    }
                }
            }
        }
        // What was recorded will have happened before anything recorded (and submitted) later.
        for (r, s) in resources.iter().zip(&states) {
            r.store_state(s);
        }
        let retained = resources
            .into_iter()
            .filter_map(|r| -> Option<Rc<dyn std::any::Any>> {
                match r.slot {
                    Slot::TransientImage(i) => Some(i),
                    Slot::TransientBuffer(b) => Some(b),
                    _ => None,
                }
            })
            .collect();
        Ok(RecordedGraph { retained, passes })
    }
}

/// Barriers, label, timestamps, attachments and the pass' own commands.
fn record_pass(
    device: &Device,
    cmd: vk::CommandBuffer,
    pass: &mut Pass<'_>,
    iteration: u32,
    resources: &[Resource<'_>],
    states: &mut [ResourceState],
    timer: &mut GpuTimer,
) -> Result<()> {
    let gpu_work = pass.record.is_some();
    let scope = if gpu_work { timer.begin(cmd, &pass.name) } else { None };
    if gpu_work {
        device.begin_label(cmd, &pass.name);
    }
    if record_barriers(device, cmd, pass, resources, states)? && !gpu_work {
        // A barrier outside any scope: the next scope starts after it.
        timer.interrupt();
    }
    if let Some(record) = &mut pass.record {
        let raster = pass.attachments.is_raster();
        let extent = if raster {
            begin_rendering(device, cmd, &pass.attachments, resources)
        } else {
            vk::Extent2D::default()
        };
        let mut ctx = PassContext {
            device,
            cmd,
            iteration,
            extent,
            resources,
            uses: &pass.uses,
            bound: Default::default(),
        };
        let recorded = record(&mut ctx);
        if raster {
            // SAFETY: `cmd` is recording and `begin_rendering` began this pass' rendering above; the closure
            // neither begins nor ends one (the contract of `PassContext`).
            unsafe { device.raw.cmd_end_rendering(cmd) };
        }
        recorded?;
        device.end_label(cmd);
    }
    timer.end(cmd, scope);
    Ok(())
}

/// Records the barriers `pass` needs first; returns whether there were any.
fn record_barriers(
    device: &Device,
    cmd: vk::CommandBuffer,
    pass: &Pass<'_>,
    resources: &[Resource<'_>],
    states: &mut [ResourceState],
) -> Result<bool> {
    let (mut src, mut dst) = (vk::PipelineStageFlags::empty(), vk::PipelineStageFlags::empty());
    let mut memory = vk::MemoryBarrier::default();
    let mut any_memory = false;
    let mut images = Vec::new();
    for u in &pass.uses {
        let r = &resources[u.resource];
        let t = states[u.resource]
            .access(&u.accesses, r.is_image(), u.discard)
            .map_err(|e| Error::Graph(format!("pass `{}`, resource `{}`: {e}", pass.name, r.name)))?;
        let Some(t) = t else { continue };
        match r.image() {
            Some(image) => {
                let (s, d, b) = vk_sync_fork::get_image_memory_barrier(&vk_sync_fork::ImageBarrier {
                    previous_accesses: &t.previous,
                    next_accesses: &t.next,
                    ..Default::default()
                });
                src |= s;
                dst |= d;
                // The tracked layouts are authoritative (vk-sync would derive the old one from the
                // previous access kinds: the same unless contents are discarded).
                images.push(
                    vk::ImageMemoryBarrier::default()
                        .src_access_mask(b.src_access_mask)
                        .dst_access_mask(b.dst_access_mask)
                        .old_layout(t.old_layout)
                        .new_layout(t.new_layout)
                        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .image(image.raw)
                        .subresource_range(image.full_range()),
                );
            }
            None => {
                let (s, d, b) = vk_sync_fork::get_memory_barrier(&vk_sync_fork::GlobalBarrier {
                    previous_accesses: &t.previous,
                    next_accesses: &t.next,
                });
                src |= s;
                dst |= d;
                memory.src_access_mask |= b.src_access_mask;
                memory.dst_access_mask |= b.dst_access_mask;
                any_memory = true;
            }
        }
    }
    let any = any_memory || !images.is_empty();
    if any {
        let memories: &[vk::MemoryBarrier] = if any_memory { std::slice::from_ref(&memory) } else { &[] };
        // SAFETY: `cmd` is recording outside any rendering; the barriers name live resources of this graph.
        unsafe {
            device.raw.cmd_pipeline_barrier(
                cmd,
                src,
                dst,
                vk::DependencyFlags::empty(),
                memories,
                &[],
                &images,
            )
        };
    }
    Ok(any)
}

/// Begins dynamic rendering over a raster pass' attachments, viewport and scissor covering the first
/// one; returns the render area.
fn begin_rendering(
    device: &Device,
    cmd: vk::CommandBuffer,
    a: &Attachments,
    resources: &[Resource<'_>],
) -> vk::Extent2D {
    let image = |i: usize| resources[i].image().expect("attachment is an image");
    let first = a.colors.first().map(|c| c.image).or(a.depth.as_ref().map(|d| d.image));
    let extent = match (first, a.area) {
        (Some(i), _) => image(i).extent_2d(),
        (None, Some(area)) => area,
        (None, None) => unreachable!("a raster pass has attachments or an area"),
    };
    let colors: Vec<vk::RenderingAttachmentInfo> = a
        .colors
        .iter()
        .map(|c| {
            let clear = match c.load {
                Load::Clear(v) => v,
                _ => [0.0; 4],
            };
            let mut info = vk::RenderingAttachmentInfo::default()
                .image_view(image(c.image).view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(load_op(&c.load))
                .store_op(c.store.op())
                .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: clear } });
            if let Some(r) = c.resolve {
                info = info
                    .resolve_mode(vk::ResolveModeFlags::AVERAGE)
                    .resolve_image_view(image(r).view)
                    .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
            }
            info
        })
        .collect();
    let depth = a.depth.as_ref().map(|d| {
        let clear = match d.load {
            Load::Clear(v) => v,
            _ => 0.0,
        };
        vk::RenderingAttachmentInfo::default()
            .image_view(image(d.image).view)
            .image_layout(if d.read_only {
                vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL
            } else {
                vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL
            })
            .load_op(load_op(&d.load))
            .store_op(d.store.op())
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue { depth: clear, stencil: 0 },
            })
    });
    let area = vk::Rect2D { offset: vk::Offset2D::default(), extent };
    let mut info = vk::RenderingInfo::default().render_area(area).layer_count(1).color_attachments(&colors);
    if let Some(d) = &depth {
        info = info.depth_attachment(d);
    }
    // SAFETY: `cmd` is recording outside any rendering; the attachments' views are live and in the
    // layouts the barriers just placed.
    unsafe { device.raw.cmd_begin_rendering(cmd, &info) };
    crate::vk::set_viewport(device, cmd, area);
    extent
}

/// Declares one pass; ends with [`PassBuilder::record`] (or [`PassBuilder::barrier_only`]).
pub struct PassBuilder<'g, 'a> {
    graph: &'g mut FrameGraph<'a>,
    pass: Pass<'a>,
}

impl<'a> PassBuilder<'_, 'a> {
    fn add_use(mut self, h: ResourceHandle, access: Access, discard: bool) -> Self {
        let index = h.index();
        match self.pass.uses.iter_mut().find(|u| u.resource == index) {
            Some(u) => {
                if !u.accesses.contains(&access) {
                    u.accesses.push(access);
                }
                u.discard &= discard;
            }
            None => self.pass.uses.push(Use { resource: index, accesses: vec![access], discard }),
        }
        self
    }

    /// The pass accesses `h` as `access` (read, write or both: vk-sync's classification decides).
    pub fn access(self, h: impl Into<ResourceHandle>, access: Access) -> Self {
        self.add_use(h.into(), access, false)
    }

    /// The pass accesses each `(handle, access)` of `uses` ([`PassBuilder::access`] for each).
    pub fn accesses(self, uses: impl IntoIterator<Item = (ResourceHandle, Access)>) -> Self {
        uses.into_iter().fold(self, |pass, (h, access)| pass.access(h, access))
    }

    /// The pass writes all of `h` without reading it: earlier contents may be discarded.
    pub fn overwrite(self, h: impl Into<ResourceHandle>, access: Access) -> Self {
        self.add_use(h.into(), access, true)
    }

    /// A colour attachment (in declaration order: location 0, 1, ...).
    pub fn color(mut self, image: ImageHandle, load: Load<[f32; 4]>, store: Store) -> Self {
        let discard = !matches!(load, Load::Load);
        let access = if discard { Access::ColorAttachmentWrite } else { Access::ColorAttachmentReadWrite };
        self.pass.attachments.colors.push(ColorTarget { image: image.index, load, store, resolve: None });
        self.add_use(image.into(), access, discard)
    }

    /// Resolves the last colour attachment (MSAA, averaged) into `target`, which is overwritten.
    pub fn resolve(mut self, target: ImageHandle) -> Self {
        if let Some(c) = self.pass.attachments.colors.last_mut() {
            c.resolve = Some(target.index);
        }
        self.add_use(target.into(), Access::ColorAttachmentWrite, true)
    }

    /// The depth attachment, tested and written.
    pub fn depth(mut self, image: ImageHandle, load: Load<f32>, store: Store) -> Self {
        let discard = !matches!(load, Load::Load);
        self.pass.attachments.depth = Some(DepthTarget { image: image.index, load, store, read_only: false });
        self.add_use(image.into(), Access::DepthStencilAttachmentReadWrite, discard)
    }

    /// A raster pass without attachments over `width × height` pixels: its fragment shaders work
    /// through storage writes only (the stochastic visibility buffer's atomics).
    pub fn render_area(mut self, width: u32, height: u32) -> Self {
        self.pass.attachments.area = Some(vk::Extent2D { width, height });
        self
    }

    /// The depth attachment, loaded and tested but not written (pipelines must not write depth).
    pub fn depth_read_only(mut self, image: ImageHandle) -> Self {
        self.pass.attachments.depth =
            Some(DepthTarget { image: image.index, load: Load::Load, store: Store::Store, read_only: true });
        self.add_use(image.into(), Access::DepthStencilAttachmentRead, false)
    }

    /// Ends the declaration with the pass' commands. For a raster pass they run inside dynamic
    /// rendering, with viewport and scissor set.
    pub fn record(mut self, f: impl FnMut(&mut PassContext<'_>) -> Result<()> + 'a) {
        self.pass.record = Some(Box::new(f));
        self.graph.push(self.pass);
    }

    /// Ends the declaration with no commands: the pass only orders its accesses after earlier ones.
    pub fn barrier_only(self) {
        self.graph.push(self.pass);
    }
}
