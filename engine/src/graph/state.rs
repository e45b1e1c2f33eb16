//! Hazard tracking: what a resource's last accesses were, and which barrier a new access needs.
//!
//! Pure CPU logic (no Vulkan calls), so the rules are unit-tested here. Access kinds are
//! `vk_sync_fork::AccessType`; its tables give each kind's pipeline stages, access mask and image
//! layout, and decide which kinds write. The rules:
//!
//! * **write** (write-after-write or write-after-read): always a barrier from the last write and every
//!   read since it (their stages: an execution dependency for the reads, availability for the write);
//! * **read after a write**: a barrier from that write, once per distinct read kind — a second read of
//!   the same kind is already ordered and visible;
//! * **read after a read** with the same layout: nothing;
//! * an **image whose layout must change**: a barrier with the transition, from the last write and the
//!   reads since it; `discard` (the pass overwrites every texel: clear or don't-care loads, transient
//!   first use) transitions from `UNDEFINED`, dropping the old contents.

use ash::vk;
use vk_sync_fork::{AccessType, GlobalBarrier, ImageBarrier};

/// Does `access` write? (vk-sync's own classification: a global barrier from it carries a source
/// access mask only for writes.)
pub fn is_write(access: AccessType) -> bool {
    let (previous, next) = ([access], [AccessType::Nothing]);
    let barrier = GlobalBarrier { previous_accesses: &previous, next_accesses: &next };
    let (_, _, b) = vk_sync_fork::get_memory_barrier(&barrier);
    b.src_access_mask != vk::AccessFlags::empty()
}

/// The image layout `access` needs (vk-sync's optimal layout for it).
pub fn layout_of(access: AccessType) -> vk::ImageLayout {
    let next = [access];
    let barrier = ImageBarrier { previous_accesses: &[], next_accesses: &next, ..Default::default() };
    let (_, _, b) = vk_sync_fork::get_image_memory_barrier(&barrier);
    b.new_layout
}

/// What a resource was last used for. Persistent resources keep it across frames (in
/// [`super::Tracked`]); a fresh resource starts with nothing and an undefined layout.
#[derive(Clone, Debug, PartialEq)]
pub struct ResourceState {
    /// The last write since the state began, if any.
    pub last_write: Option<AccessType>,
    /// Read kinds since `last_write`, the write's own pass' included: what a later write must wait
    /// for.
    pub reads: Vec<AccessType>,
    /// Of those, the kinds ordered after `last_write` (by a barrier, or because there was no write):
    /// a later read of such a kind needs no barrier. A read declared by the pass that writes is not
    /// among them — it is not ordered after that pass' own write.
    pub ordered_reads: Vec<AccessType>,
    /// Current layout (images only; `UNDEFINED` for buffers and fresh images).
    pub layout: vk::ImageLayout,
}

impl Default for ResourceState {
    fn default() -> Self {
        ResourceState {
            last_write: None,
            reads: Vec::new(),
            ordered_reads: Vec::new(),
            layout: vk::ImageLayout::UNDEFINED,
        }
    }
}

/// A barrier one access needs: from `previous` to `next` accesses, with the layout transition of an
/// image (`old_layout` → `new_layout`; equal for buffers and unchanged layouts).
#[derive(Clone, Debug, PartialEq)]
pub struct Transition {
    pub previous: Vec<AccessType>,
    pub next: Vec<AccessType>,
    pub old_layout: vk::ImageLayout,
    pub new_layout: vk::ImageLayout,
}

impl Transition {
    /// Does it change an image's layout?
    pub fn is_layout_change(&self) -> bool {
        self.old_layout != self.new_layout
    }
}

impl ResourceState {
    /// The state of a resource whose last access was `access` (an image: in the layout `access`
    /// needs): how a caller hands Shutter an image it used. [`AccessType::Nothing`] is a resource
    /// nothing used yet (undefined layout).
    pub fn after_access(access: AccessType, image: bool) -> Self {
        if access == AccessType::Nothing {
            return ResourceState::default();
        }
        let layout = if image { layout_of(access) } else { vk::ImageLayout::UNDEFINED };
        if is_write(access) {
            ResourceState { last_write: Some(access), reads: vec![], ordered_reads: vec![], layout }
        } else {
            ResourceState { last_write: None, reads: vec![access], ordered_reads: vec![access], layout }
        }
    }

    /// Records that a pass accesses the resource with `next` (every kind the pass declared for it) and
    /// returns the barrier needed first, if any. `image`: layouts apply. `discard`: the pass
    /// overwrites the whole resource, so an image may transition from `UNDEFINED`.
    /// Errors when `next` is empty or its kinds need different layouts of one image.
    pub fn access(
        &mut self,
        next: &[AccessType],
        image: bool,
        discard: bool,
    ) -> Result<Option<Transition>, String> {
        let Some(&first) = next.first() else {
            return Err("a pass declared an empty access list".into());
        };
        let new_layout = if image { layout_of(first) } else { vk::ImageLayout::UNDEFINED };
        if image {
            if let Some(&other) = next.iter().find(|&&a| layout_of(a) != new_layout) {
                return Err(format!(
                    "{first:?} needs layout {new_layout:?} but {other:?} needs {:?} in the same pass",
                    layout_of(other)
                ));
            }
        }
        let writes = next.iter().any(|&a| is_write(a));
        let layout_change = image && (self.layout != new_layout || (discard && self.layout_is_defined()));
        let unseen_read = next.iter().any(|a| !self.ordered_reads.contains(a));
        let needs_barrier = if writes || layout_change {
            // Every earlier access must finish first (and the last write be made available).
            self.last_write.is_some() || !self.reads.is_empty() || layout_change
        } else {
            self.last_write.is_some() && unseen_read
        };
        let transition = needs_barrier.then(|| {
            let mut previous: Vec<AccessType> = self.last_write.into_iter().collect();
            if writes || layout_change {
                previous.extend(self.reads.iter().copied());
            }
            Transition {
                previous,
                next: next.to_vec(),
                old_layout: if !image || discard { vk::ImageLayout::UNDEFINED } else { self.layout },
                new_layout,
            }
        });
        if writes {
            self.last_write = Some(*next.iter().find(|&&a| is_write(a)).expect("a write"));
            self.reads = next.iter().copied().filter(|&a| !is_write(a)).collect();
            self.ordered_reads.clear();
        } else if layout_change {
            self.reads = next.to_vec();
            self.ordered_reads = next.to_vec();
        } else {
            for &a in next {
                if !self.reads.contains(&a) {
                    self.reads.push(a);
                }
                // Ordered after the last write now: by the barrier just made, or already.
                if !self.ordered_reads.contains(&a) {
                    self.ordered_reads.push(a);
                }
            }
        }
        self.layout = new_layout;
        Ok(transition)
    }

    fn layout_is_defined(&self) -> bool {
        self.layout != vk::ImageLayout::UNDEFINED
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use AccessType::*;

    #[test]
    fn classification_follows_vk_sync() {
        assert!(is_write(ComputeShaderWrite) && is_write(ColorAttachmentWrite) && is_write(TransferWrite));
        assert!(is_write(ComputeShaderReadWrite) && is_write(DepthStencilAttachmentReadWrite));
        assert!(!is_write(ComputeShaderReadOther) && !is_write(HostRead) && !is_write(TransferRead));
        assert_eq!(layout_of(ColorAttachmentWrite), vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        assert_eq!(layout_of(ComputeShaderReadOther), vk::ImageLayout::GENERAL);
        assert_eq!(layout_of(TransferRead), vk::ImageLayout::TRANSFER_SRC_OPTIMAL);
        assert_eq!(
            layout_of(FragmentShaderReadSampledImageOrUniformTexelBuffer),
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL
        );
    }

    #[test]
    fn read_after_write_is_synchronised_once_per_read_kind() {
        let mut s = ResourceState::default();
        assert_eq!(
            s.access(&[ComputeShaderWrite], false, false).unwrap(),
            None,
            "first write: nothing before"
        );
        let t = s.access(&[FragmentShaderReadOther], false, false).unwrap().expect("RAW barrier");
        assert_eq!(t.previous, vec![ComputeShaderWrite]);
        assert_eq!(s.access(&[FragmentShaderReadOther], false, false).unwrap(), None, "already visible");
        let t = s.access(&[ComputeShaderReadOther], false, false).unwrap().expect("new reader");
        assert_eq!(t.previous, vec![ComputeShaderWrite]);
        // A write now waits for the write and both reads.
        let t = s.access(&[TransferWrite], false, false).unwrap().expect("WAR/WAW barrier");
        assert_eq!(t.previous, vec![ComputeShaderWrite, FragmentShaderReadOther, ComputeShaderReadOther]);
        let t = s.access(&[HostRead], false, false).unwrap().expect("device-to-host barrier");
        assert_eq!((t.previous, t.next), (vec![TransferWrite], vec![HostRead]));
    }

    /// A pass that reads and writes a resource: a later pass reading it the same way still waits for
    /// the write (the first pass' read is not ordered after its own write), and a later write waits
    /// for both.
    #[test]
    fn a_read_in_the_writing_pass_does_not_order_later_reads() {
        let mut s = ResourceState::default();
        s.access(&[ComputeShaderReadOther, ComputeShaderWrite], false, false).unwrap();
        let t = s.access(&[ComputeShaderReadOther], false, false).unwrap().expect("RAW barrier");
        assert_eq!(t.previous, vec![ComputeShaderWrite]);
        assert_eq!(s.access(&[ComputeShaderReadOther], false, false).unwrap(), None, "now ordered");
        let mut s = ResourceState::default();
        s.access(&[FragmentShaderReadOther, ComputeShaderWrite], false, false).unwrap();
        let t = s.access(&[TransferWrite], false, false).unwrap().expect("WAW + WAR");
        assert_eq!(t.previous, vec![ComputeShaderWrite, FragmentShaderReadOther]);
    }

    #[test]
    fn reads_without_a_write_need_nothing_and_writes_after_them_wait() {
        let mut s = ResourceState::default();
        assert_eq!(s.access(&[VertexShaderReadOther], false, false).unwrap(), None);
        assert_eq!(s.access(&[ComputeShaderReadOther], false, false).unwrap(), None);
        let t = s.access(&[ComputeShaderWrite], false, false).unwrap().expect("WAR");
        assert_eq!(t.previous, vec![VertexShaderReadOther, ComputeShaderReadOther]);
    }

    #[test]
    fn image_layouts_transition_and_discard_drops_contents() {
        let mut s = ResourceState::default();
        let t = s.access(&[ColorAttachmentWrite], true, true).unwrap().expect("first layout");
        assert_eq!(
            (t.old_layout, t.new_layout),
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        );
        let t = s.access(&[ComputeShaderReadOther], true, false).unwrap().expect("to GENERAL");
        assert_eq!(t.old_layout, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        assert_eq!(t.previous, vec![ColorAttachmentWrite]);
        // Overwritten again: discard, but still after the compute read (write-after-read).
        let t = s.access(&[ColorAttachmentWrite], true, true).unwrap().expect("WAR + layout");
        assert_eq!(t.old_layout, vk::ImageLayout::UNDEFINED);
        assert_eq!(t.previous, vec![ColorAttachmentWrite, ComputeShaderReadOther]);
        // Read in the same layout twice: one barrier.
        let mut s = ResourceState::default();
        s.access(&[ComputeShaderWrite], true, true).unwrap();
        assert!(s.access(&[ComputeShaderReadOther], true, false).unwrap().is_some());
        assert_eq!(s.access(&[ComputeShaderReadOther], true, false).unwrap(), None);
    }

    #[test]
    fn conflicting_layouts_in_one_pass_are_an_error() {
        let mut s = ResourceState::default();
        let e = s
            .access(&[ComputeShaderReadOther, ComputeShaderReadSampledImageOrUniformTexelBuffer], true, false)
            .unwrap_err();
        assert!(e.contains("GENERAL") && e.contains("SHADER_READ_ONLY_OPTIMAL"), "{e}");
        assert!(s.access(&[], true, false).is_err());
    }

    /// Property: for any sequence of accesses, every read-after-write and write-after-anything
    /// hazard against the last write is covered by a barrier at or after it (the tracker never lets an
    /// access through that has not been ordered after the last write).
    #[test]
    fn every_hazard_against_the_last_write_is_covered() {
        const KINDS: [AccessType; 8] = [
            ComputeShaderWrite,
            ComputeShaderReadOther,
            FragmentShaderReadOther,
            TransferWrite,
            TransferRead,
            HostRead,
            ComputeShaderReadWrite,
            VertexShaderReadOther,
        ];
        let mut rng = crate::sampling::Pcg32::new(9, 1);
        for _ in 0..2000 {
            let mut s = ResourceState::default();
            // The model: the last write and the read kinds since it.
            let (mut write, mut reads): (Option<AccessType>, Vec<AccessType>) = (None, vec![]);
            for _ in 0..12 {
                let a = KINDS[(rng.next_u32() % KINDS.len() as u32) as usize];
                let t = s.access(&[a], false, false).unwrap();
                if is_write(a) {
                    if write.is_some() || !reads.is_empty() {
                        let t =
                            t.unwrap_or_else(|| panic!("{a:?} after {write:?}/{reads:?} without a barrier"));
                        for p in write.iter().chain(&reads) {
                            assert!(t.previous.contains(p), "{a:?}: barrier misses {p:?}");
                        }
                    }
                    (write, reads) = (Some(a), vec![]);
                } else {
                    if let Some(w) = write {
                        if !reads.contains(&a) {
                            let t = t.unwrap_or_else(|| panic!("{a:?} reads {w:?}'s data without a barrier"));
                            assert!(t.previous.contains(&w));
                        }
                    }
                    if !reads.contains(&a) {
                        reads.push(a);
                    }
                }
            }
        }
    }
}
