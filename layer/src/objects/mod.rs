//! The Vulkan objects revz tracks per device, and the command buffers it tracks per process.
//!
//! Depth images carry their policy decision for life; views, framebuffers and render passes
//! only say which image a depth attachment is. These tables are written at object creation and
//! destruction and read when a render pass or rendering scope begins (not per draw). Command
//! buffers are looked up on every recorded command: a thread-local cache answers repeated
//! lookups from the thread that records (the usual case) without touching the shared table
//! (`command_buffers.rs`).

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, PoisonError, RwLock};

use ash::vk;
use rustc_hash::{FxHashMap, FxHashSet};

use crate::command_state::{CommandState, PipelineDepth, Target};
use crate::policy::{
    follows_demotion, kept_resolve_partner, pass_resolve_swappable, resolved_destination,
    DepthResolve, ImageDepth, NativeReason, PassTwin, ResolvePartner, ResolvedDestination,
};
use crate::precise::Carrier;
use crate::shader::analysis::Analysis;
use crate::shader::fragment_depth::Unsupported;
use crate::state::DeviceState;

/// The shader analysis of one module: each vertex entry point's result, or why naga could not
/// read it.
pub type ModuleAnalysis = Result<Vec<(String, Analysis)>, String>;
/// A fragment module rewritten for reversed attachments (`crate::shader::fragment_depth`), or why it
/// cannot be.
pub type ReversedFragment = Result<Arc<[u32]>, Unsupported>;
/// A vertex module rewritten to store the carrier's depth (`crate::shader::position_store`), or why it
/// cannot be.
pub type RewrittenVertex = Result<VertexRewrite, crate::shader::position_store::Unsupported>;

/// A vertex module's `Position` rewrite: its code, and where the matrix comes from when the
/// stage derives its range itself (`crate::shader::derived_range`: no projection in push constants).
#[derive(Clone, Debug)]
pub struct VertexRewrite {
    pub code: Arc<[u32]>,
    pub derived: Option<crate::shader::derived_range::MatrixSource>,
    /// Where a deriving rewrite's matrix lies in the push constants, where the stage loads it
    /// whole from a member of its block: the CPU can classify it as it does a vertex stage's
    /// projection (`crate::shader::derived_range::Leaf::push_slot`).
    pub push_slot: Option<crate::shader::analysis::ProjectionSlot>,
    /// The stage projects the previous stage's `Position`: the pipeline takes the precise
    /// path only where that stage stores w = 1 (`DeviceObjects::position_w_one`).
    pub needs_input_unit_w: bool,
}

/// A stage's code with the carrier baked in (`crate::shader::position_store::CarrierRead::
/// Baked`): the last pre-rasterization stage of the reversed variants of a pipeline whose
/// layout has no room for the pushed carrier.
#[derive(Clone, Debug)]
pub struct BakedStage {
    pub code: Arc<[u32]>,
    /// Where the matrix it fits comes from.
    pub source: crate::shader::derived_range::MatrixSource,
    /// It projects the previous stage's `Position`, whose w = 1 the pipeline must check.
    pub assumes_input_unit_w: bool,
}

/// A layout's push-constant ranges as (stages, offset, size), the key of revz's own push
/// layouts.
pub type PushRanges = Vec<(u32, u32, u32)>;

/// A tracked depth image.
#[derive(Clone, Copy, Debug)]
pub struct ImageInfo {
    /// The format the application created it with.
    pub format: vk::Format,
    pub depth: ImageDepth,
    /// The float format revz created it in instead, if it promoted it (for life).
    pub promoted: Option<vk::Format>,
    /// Its size and sample count (to find its likely resolve partners).
    pub extent: vk::Extent3D,
    pub samples: vk::SampleCountFlags,
    /// Its array layers (a copy region's `VK_REMAINING_ARRAY_LAYERS` counts to the last).
    pub array_layers: u32,
    /// The native image shaders read in its place (`crate::policy::DevicePolicy::reads_through_twin`).
    pub twin: Option<ReadTwin>,
}

/// The view of a read twin made beside a view of its image, with what a refresh at the end
/// of a render pass needs: the image and the view's subresources.
#[derive(Clone, Copy, Debug)]
pub struct TwinView {
    pub view: vk::ImageView,
    pub image: vk::Image,
    pub range: vk::ImageSubresourceRange,
}

/// A reversed image's read twin (issue #39): a native image of the application's format (a
/// promoted image's twin is UNORM, so that shaders read the texels the application's format
/// holds), size, mip levels and layers, in revz's own memory, refreshed with the image's
/// standard values whenever the application makes the image readable, and read by shaders
/// through views made beside the application's ([`DeviceObjects::twin_views`]), always in
/// `SHADER_READ_ONLY_OPTIMAL` once refreshed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadTwin {
    pub image: vk::Image,
    pub memory: vk::DeviceMemory,
    /// The twin's own format: the application's (the stored float one only where the device
    /// refused a twin in the application's format), `R32_SFLOAT` for a multisampled twin.
    pub format: vk::Format,
    pub extent: vk::Extent3D,
    pub mip_levels: u32,
    pub array_layers: u32,
    /// The aspects of the image it serves (DEPTH, or DEPTH | STENCIL; DEPTH alone for a
    /// multisampled twin, whose image's stencil shaders read from the image itself).
    pub aspects: vk::ImageAspectFlags,
    /// Every aspect of the image's format (what a layout transition of it must name).
    pub image_aspects: vk::ImageAspectFlags,
    /// The image's samples: a multisampled twin is an `R32_SFLOAT` image of as many samples,
    /// refreshed per sample by a compute pass (`crate::depth_copy::twin`).
    pub samples: vk::SampleCountFlags,
}

impl ReadTwin {
    /// Whether it is a multisampled twin (see [`ReadTwin::samples`]).
    pub fn multisampled(&self) -> bool {
        self.samples != vk::SampleCountFlags::TYPE_1
    }
}

/// What the refresh of a multisampled twin binds (`crate::depth_copy::twin`): a view of the
/// image's depth aspect (every layer, sampled) and of the twin (every layer, storage) in a
/// descriptor set of revz's own pool. Made at the image's first view, once its memory is
/// bound; destroyed with the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MultisampledBindings {
    pub pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
    pub depth_view: vk::ImageView,
    pub twin_view: vk::ImageView,
}

/// A render pass: each attachment's format and whether its depth is cleared at load, each
/// subpass's depth attachment and depth resolve, and the twin revz made to swap MIN and MAX
/// depth resolves.
#[derive(Clone, Debug, Default)]
pub struct RenderPassInfo {
    pub attachments: Vec<vk::Format>,
    /// Where each attachment's read twin is refreshed, if its image has one: before the pass
    /// (a first use that reads it) and after it (left readable after writes).
    pub twin_refreshes: Vec<crate::policy::twins::PassRefresh>,
    /// Whether each attachment may be read by shaders in a subpass after an earlier one wrote
    /// it (`crate::policy::twins::AttachmentUse::read_after_written_inside`): a twin read
    /// there holds what the image held when the pass began.
    pub read_after_written_inside: Vec<bool>,
    pub depth_cleared: Vec<bool>,
    pub subpass_depth: Vec<Option<u32>>,
    /// Each subpass's input attachments that read depth (`crate::policy::reads_depth_input`):
    /// the fragment shaders of its pipelines convert what they read where the attachment is
    /// reversed (`crate::shader::input_depth`).
    pub subpass_depth_inputs: Vec<Vec<DepthInput>>,
    /// Whether each attachment is an input attachment of some subpass (any aspect): its
    /// image then has `INPUT_ATTACHMENT` usage, which the spec requires of every image a
    /// subpass reads so.
    pub input_attachments: Vec<bool>,
    pub subpass_resolve: Vec<Option<SubpassResolve>>,
    /// The same render pass with MIN and MAX depth resolves swapped, begun in its place when
    /// the resolved attachment is reversed. Only single-subpass passes have one: resolve modes
    /// do not count for their compatibility (Vulkan spec, "Render Pass Compatibility"), so the
    /// application's framebuffers and pipelines work with it.
    pub swapped_resolve_twin: Option<vk::RenderPass>,
    /// The same render pass with its UNORM depth attachments (resolve attachments included)
    /// in their float formats, begun in its place over framebuffers of promoted images
    /// (`crate::policy::DevicePolicy::promoted_format`); and the same for the swapped-resolve
    /// twin.
    pub promoted_twin: Option<vk::RenderPass>,
    pub promoted_swapped_twin: Option<vk::RenderPass>,
}

/// An input attachment of a subpass that reads depth: its input attachment index (what a
/// shader's `InputAttachmentIndex` names) and the render pass attachment it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthInput {
    pub index: u32,
    pub attachment: u32,
}

/// A subpass's depth resolve: the attachment resolved into and the depth mode (never NONE).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SubpassResolve {
    pub attachment: u32,
    pub mode: vk::ResolveModeFlags,
}

impl RenderPassInfo {
    /// Whether attachment `index` has a format revz promotes.
    pub fn promotable(&self, index: usize) -> bool {
        self.attachments
            .get(index)
            .is_some_and(|&format| crate::policy::promotable_format(format))
    }

    /// The render pass the policy's choice of twin names (`None`: the application's, or a
    /// twin the pass does not have).
    pub fn twin(&self, twin: PassTwin) -> Option<vk::RenderPass> {
        match twin {
            PassTwin::Application => None,
            PassTwin::SwappedResolve => self.swapped_resolve_twin,
            PassTwin::Promoted => self.promoted_twin,
            PassTwin::PromotedSwapped => self.promoted_swapped_twin,
        }
    }

    /// The twins revz created for this pass (to destroy with it).
    pub fn twins(&self) -> impl Iterator<Item = vk::RenderPass> + '_ {
        [
            self.swapped_resolve_twin,
            self.promoted_twin,
            self.promoted_swapped_twin,
        ]
        .into_iter()
        .flatten()
    }

    /// Whether a depth resolve of this pass can be swapped
    /// ([`crate::policy::pass_resolve_swappable`]: it needs none, or the pass has its twin).
    pub fn resolve_swappable(&self, resolve: SubpassResolve) -> bool {
        pass_resolve_swappable(resolve.mode, self.swapped_resolve_twin.is_some())
    }

    /// Each depth resolve of the pass: (source attachment, resolve).
    pub fn depth_resolves(&self) -> impl Iterator<Item = (u32, SubpassResolve)> + '_ {
        self.subpass_depth
            .iter()
            .zip(&self.subpass_resolve)
            .filter_map(|(depth, resolve)| Some(((*depth)?, (*resolve)?)))
    }
}

/// A map behind a read-write lock that tolerates poisoning (a panic caught at the boundary
/// leaves every map consistent: each operation is one insert, remove or read). Keys are Vulkan
/// handles, which no one chooses adversarially: Fx hashing keeps a lookup (one per pipeline
/// bind) to a few nanoseconds.
#[derive(Debug)]
pub struct Table<K, V>(RwLock<FxHashMap<K, V>>);

impl<K: std::hash::Hash + Eq, V: Clone> Table<K, V> {
    pub fn new() -> Self {
        Table(RwLock::new(FxHashMap::default()))
    }

    pub fn insert(&self, key: K, value: V) {
        self.replace(key, value);
    }

    /// [`Self::insert`], returning the value it replaced.
    pub fn replace(&self, key: K, value: V) -> Option<V> {
        self.0
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(key, value)
    }

    /// Empties the table, returning what it held (at device destruction: what the
    /// application never destroyed).
    pub fn take_all(&self) -> Vec<V> {
        let mut map = self.0.write().unwrap_or_else(PoisonError::into_inner);
        map.drain().map(|(_, value)| value).collect()
    }

    pub fn remove(&self, key: &K) -> Option<V> {
        self.0
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(key)
    }

    pub fn get(&self, key: &K) -> Option<V> {
        self.0
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .get(key)
            .cloned()
    }
}

impl<K, V> Table<K, V> {
    /// How many entries the table holds.
    pub fn len(&self) -> usize {
        self.0.read().unwrap_or_else(PoisonError::into_inner).len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    #[cfg(test)]
    pub fn count(&self) -> usize {
        self.len()
    }
}

impl<K: std::hash::Hash + Eq, V: Clone> Default for Table<K, V> {
    fn default() -> Self {
        Self::new()
    }
}

/// What revz made of SPIR-V, by the code's content: shader modules (their analysis and
/// rewrites made at creation) and SPIR-V chained into pipeline stages
/// (`VkShaderModuleCreateInfo` in a stage's `pNext`). Applications create modules of the same
/// code again and again (a module per pipeline from a cached blob, translation layers per
/// variant): the code is analyzed once (issue #42). Each entry keeps its words, compared on a
/// hit, so a hash collision is a miss. Entries outlive their modules (the code may come back)
/// until the device is destroyed: at most [`CodeCache::CAPACITY`] codes (modules and chained
/// SPIR-V together) and [`CodeCache::BUDGET_WORDS`] words of their code are kept, with what was
/// made of them (about as much again: the rewrite), and past that each creation does the work
/// again.
#[derive(Debug)]
pub struct CodeCache<T> {
    codes: Table<u64, Arc<CachedCode<T>>>,
    /// The words the entries hold.
    words: AtomicUsize,
}

/// One kept code: its words and what was made of them.
type CachedCode<T> = (Arc<[u32]>, T);

impl<T: Clone> CodeCache<T> {
    pub const CAPACITY: usize = 1024;
    /// 16 MiB of code.
    pub const BUDGET_WORDS: usize = 4 << 20;

    /// What `make` makes of `words`, made once per distinct code.
    pub fn get_or_make(&self, words: &[u32], make: impl FnOnce() -> T) -> T {
        self.lookup(words, make, false).1
    }

    /// [`Self::get_or_make`], with the words as kept (shared with the cache where it keeps
    /// them): for what is made of the code later, at pipeline creation.
    pub fn get_or_make_kept(&self, words: &[u32], make: impl FnOnce() -> T) -> (Arc<[u32]>, T) {
        let (kept, made) = self.lookup(words, make, true);
        (kept.unwrap_or_else(|| words.into()), made)
    }

    fn lookup(
        &self,
        words: &[u32],
        make: impl FnOnce() -> T,
        keep: bool,
    ) -> (Option<Arc<[u32]>>, T) {
        use std::hash::{Hash, Hasher};
        let mut hasher = rustc_hash::FxHasher::default();
        words.hash(&mut hasher);
        let key = hasher.finish();
        if let Some(hit) = self.codes.get(&key) {
            if *hit.0 == *words {
                return (keep.then(|| hit.0.clone()), hit.1.clone());
            }
        }
        let made = make();
        let kept = self.words.load(Ordering::Relaxed);
        if self.codes.len() < Self::CAPACITY
            && kept.saturating_add(words.len()) <= Self::BUDGET_WORDS
        {
            // Counted before the entry is in the table, so that a thread replacing it (a
            // collision, or two threads making the same code) gives back words already
            // counted. Threads inserting at once may overshoot the budget a little.
            self.words.fetch_add(words.len(), Ordering::Relaxed);
            let shared: Arc<[u32]> = words.into();
            let replaced = self
                .codes
                .replace(key, Arc::new((shared.clone(), made.clone())));
            if let Some(replaced) = replaced {
                self.words.fetch_sub(replaced.0.len(), Ordering::Relaxed);
            }
            return (keep.then_some(shared), made);
        }
        (None, made)
    }

    /// How many distinct codes are kept.
    pub fn len(&self) -> usize {
        self.codes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl<T: Clone> Default for CodeCache<T> {
    fn default() -> Self {
        CodeCache {
            codes: Table::new(),
            words: AtomicUsize::new(0),
        }
    }
}

/// The depth resolves seen between two reversed images, as (source image, destination image)
/// pairs. A reversed image may only be resolved into, or from, a reversed one, so when either
/// end of a pair is made native later, the other end must follow
/// ([`DeviceObjects::settle_depth_resolve`]). Pairs with a native end are not kept: an image
/// made native stays native, so such a pair can never ask for anything again.
#[derive(Debug, Default)]
pub struct ResolvePairs(RwLock<FxHashSet<(vk::Image, vk::Image)>>);

impl ResolvePairs {
    /// Whether the resolve from `pair.0` into `pair.1` was seen between reversed images.
    fn contains(&self, pair: (vk::Image, vk::Image)) -> bool {
        self.0
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .contains(&pair)
    }

    /// Remembers a resolve from `pair.0` into `pair.1`, both reversed.
    fn insert(&self, pair: (vk::Image, vk::Image)) {
        self.0
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(pair);
    }

    /// Forgets the pairs of a destroyed image: its handle may come back for another image,
    /// which must not inherit them. (Named like [`Table::remove`] for the destroy hook.)
    pub fn remove(&self, image: &vk::Image) {
        self.0
            .write()
            .unwrap_or_else(PoisonError::into_inner)
            .retain(|&(source, destination)| source != *image && destination != *image);
    }

    /// Removes and returns the pairs with `image` at either end.
    fn take_touching(&self, image: vk::Image) -> Vec<(vk::Image, vk::Image)> {
        let mut pairs = self.0.write().unwrap_or_else(PoisonError::into_inner);
        let touching: Vec<_> = pairs
            .iter()
            .copied()
            .filter(|&(source, destination)| source == image || destination == image)
            .collect();
        for pair in &touching {
            pairs.remove(pair);
        }
        touching
    }

    /// How many pairs are kept.
    #[cfg(test)]
    pub fn count(&self) -> usize {
        self.0.read().unwrap_or_else(PoisonError::into_inner).len()
    }
}

/// Every object of one device that revz tracks.
#[derive(Debug, Default)]
pub struct DeviceObjects {
    pub images: Table<vk::Image, ImageInfo>,
    /// Infinite mode: the n / f of the camera whose draws last went into each reversed image,
    /// as its command buffer knew it when the render pass or rendering instance ended. Its
    /// clears, the flip-path draws of a pass into it before a projection is pushed, and its
    /// copies and read twin refreshes map with it, not with another camera's (a spot light's
    /// shadow map beside the main view). Removed with the image.
    pub near_over_far: Table<vk::Image, f32>,
    /// Resolves seen between reversed images, to carry a later demotion across them.
    pub resolve_pairs: ResolvePairs,
    /// Views of tracked depth images, with the image they show.
    pub views: Table<vk::ImageView, vk::Image>,
    /// The view of its read twin made beside each view of an image that has one: what
    /// descriptors hold in its place.
    pub twin_views: Table<vk::ImageView, TwinView>,
    /// Infinite mode: the images that store complementary depth
    /// (`crate::policy::DevicePolicy::stores_complementary`: read as input attachments).
    pub complementary_images: Table<vk::Image, ()>,
    /// The refresh bindings of each image with a multisampled twin, from its first view on.
    pub multisampled_twins: Table<vk::Image, MultisampledBindings>,
    /// Live read twins (descriptor writes and barriers look no further while there is none).
    pub twins: std::sync::atomic::AtomicUsize,
    /// Each descriptor update template's image entries (`crate::hooks::descriptors`).
    pub templates:
        Table<vk::DescriptorUpdateTemplate, Arc<crate::hooks::descriptors::TemplateEntries>>,
    pub render_passes: Table<vk::RenderPass, Arc<RenderPassInfo>>,
    /// Each framebuffer's attachments (empty for an imageless framebuffer).
    pub framebuffers: Table<vk::Framebuffer, Arc<[vk::ImageView]>>,
    /// Framebuffers created with their render pass's promoted twin (their depth images are
    /// promoted): their passes begin as the twin.
    pub promoted_framebuffers: Table<vk::Framebuffer, ()>,
    pub pipelines: Table<vk::Pipeline, Arc<PipelineDepth>>,
    /// Bumped at every pipeline destroyed: recordings keep the pipelines they bound by handle
    /// (`crate::command_state::KnownPipelines`) only under the generation they found them in.
    pipeline_generation: AtomicU64,
    /// Images demoted since the depth profile last asked (`crate::profile`; kept only where
    /// there is a profile: `keep_demotions`).
    demotions: Mutex<Vec<(vk::Image, NativeReason)>>,
    pub keep_demotions: std::sync::atomic::AtomicBool,
    /// Shader modules that compute with depth (`FragDepth`, `FragCoord.z`): rewritten for
    /// reversed attachments, or why they cannot be.
    pub fragment_depth_modules: Table<vk::ShaderModule, ReversedFragment>,
    /// What the shader analysis found in each vertex module (precise modes only): per entry
    /// point, or why the module could not be read.
    pub vertex_modules: Table<vk::ShaderModule, Arc<ModuleAnalysis>>,
    /// Vertex modules with a projection from push constants (precise modes only): rewritten
    /// to store the carrier's depth into `Position` (`crate::shader::position_store`), or why not.
    pub position_stores: Table<vk::ShaderModule, RewrittenVertex>,
    /// Whether each vertex or tessellation evaluation module stores `Position` with w = 1
    /// exactly (`crate::shader::position_store::stores_position_w_one`), where the device
    /// enabled a later stage: what a geometry or tessellation evaluation stage that projects
    /// `gl_in[i].gl_Position` needs of the stage before.
    pub position_w_one: Table<vk::ShaderModule, bool>,
    /// Whether each geometry or tessellation module only carries `gl_in[i].gl_Position` on,
    /// keeping the line the stage before stores on, where the device enabled those stages: a
    /// geometry stage that passes the positions through
    /// (`crate::shader::position_store::passes_position_through`), a tessellation control
    /// stage that copies them, or an evaluation stage that interpolates them
    /// (`crate::shader::tessellation_positions`). The stage before is then the one the precise
    /// path rewrites.
    pub position_passthrough: Table<vk::ShaderModule, bool>,
    /// The code of each vertex module analyzed (precise modes only; shared with
    /// [`Self::vertex_codes`] where it keeps the code): a pipeline whose layout has no room
    /// for the pushed carrier gets a variant with the carrier baked into this code, made at
    /// its creation (issue #41).
    pub vertex_words: Table<vk::ShaderModule, Arc<[u32]>>,
    /// The rewrites with the carrier baked in made of those codes (and of SPIR-V chained into
    /// stages), once per distinct code, or why there is none.
    pub baked_codes: CodeCache<Result<Option<BakedStage>, &'static str>>,
    /// The code of vertex modules and of SPIR-V chained into vertex stages instead of a
    /// module: analyzed and rewritten once per distinct code, not at every module or pipeline
    /// creation.
    pub vertex_codes: CodeCache<(Arc<ModuleAnalysis>, Option<RewrittenVertex>)>,
    /// SPIR-V chained into fragment stages: rewritten once per distinct code (a module's is
    /// rewritten at its creation, one pass over its words).
    pub fragment_codes: CodeCache<Option<ReversedFragment>>,
    /// The code of fragment modules that declare input attachments, where the policy converts
    /// depth read through them (`crate::policy::DevicePolicy::converts_input_reads`): which
    /// input attachment reads depth is known only with a pipeline's render pass, so their
    /// rewrite (`crate::shader::input_depth`) is made at pipeline creation.
    pub input_modules: Table<vk::ShaderModule, Arc<[u32]>>,
    /// Fragment shader objects (`VK_EXT_shader_object`) that compute with depth, or whose code
    /// revz cannot read: each one's reversed variant, or that it keeps standard depth
    /// (`crate::hooks::shader_object`). Other shader objects have no entry.
    pub fragment_shaders: Table<vk::ShaderEXT, FragmentShader>,
    /// Vertex, tessellation evaluation and geometry shader objects that store `Position`
    /// (precise modes only): each one's variant with the carrier baked in, or that its draws
    /// take the flip path (`crate::hooks::shader_object`).
    pub position_shaders: Table<vk::ShaderEXT, PositionShader>,
    /// Each pipeline layout's push-constant ranges as the application gave them (precise
    /// modes only).
    pub pipeline_layouts: Table<vk::PipelineLayout, Arc<[vk::PushConstantRange]>>,
    /// The carrier revz reserved in each pipeline layout, where it had room.
    pub layout_carriers: Table<vk::PipelineLayout, Carrier>,
    /// For each pipeline layout with a carrier, revz's own layout with the same push-constant
    /// ranges (compatible for push constants, no descriptor sets): what revz pushes a carrier
    /// with for a pipeline whose application pushes nothing of its own (projections in
    /// buffers), where the application's last push layout may be another pipeline's, and the
    /// application may have destroyed the pipeline's own (`maintenance4`).
    pub layout_pushers: Table<vk::PipelineLayout, vk::PipelineLayout>,
    /// revz's push layouts, one per set of push-constant ranges (destroyed with the device).
    pub push_layouts: Mutex<Vec<(PushRanges, vk::PipelineLayout)>>,
    /// Each pool's command buffers, to forget them when the pool is destroyed.
    pub pools: Table<vk::CommandPool, Arc<Mutex<Vec<vk::CommandBuffer>>>>,
    /// The depth target each subpass (render pass, index) or dynamic rendering depth format
    /// was last begun with for secondaries, for secondaries whose inheritance names no
    /// framebuffer (`crate::policy::secondary_target`). A render pass's entries go with it.
    pub secondary_targets: Table<SecondaryPass, Target>,
    /// Whether each of those was last begun promoted (as its promoted twin, or with a
    /// promoted view), for the same secondaries.
    pub secondary_promoted: Table<SecondaryPass, bool>,
}

/// A fragment shader object that computes with depth (or may: binary code), as draws into
/// reversed attachments see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FragmentShader {
    /// The shader object of its rewritten code (revz's own), bound in its place for draws into
    /// reversed attachments.
    Reversed(vk::ShaderEXT),
    /// No variant: its draws into reversed attachments keep standard fragment depth (warned
    /// once at draw). The code was refused by the rewrite, the variant could not be created,
    /// the shader is part of a linked set, or its code is binary.
    Unreversed,
}

impl FragmentShader {
    /// The reversed variant, if there is one.
    pub fn variant(self) -> Option<vk::ShaderEXT> {
        match self {
            FragmentShader::Reversed(variant) => Some(variant),
            FragmentShader::Unreversed => None,
        }
    }
}

/// A vertex, tessellation evaluation, geometry or mesh shader object (precise modes), as draws
/// into reversed attachments see it where it is the last pre-rasterization stage bound (issue
/// #41, `crate::policy::pipelines::ShaderObjectPosition`).
#[derive(Clone, Debug)]
pub enum PositionShader {
    /// A shader object whose push-constant ranges hold revz's carrier: `variant`, the
    /// shader object of its code rewritten to store `Position` through the pushed carrier
    /// (revz's own), is bound in its place for precise-path draws, and `depth` says for the
    /// state machine what a pipeline's facts say of its last stage (where its projection
    /// is, the carrier, the layout revz pushes it with), so that its draws take the pipelines'
    /// per-camera path. `projects_input`: as for [`PositionShader::Baked`].
    Pushed {
        variant: vk::ShaderEXT,
        depth: std::sync::Arc<crate::command_state::PipelineDepth>,
        projects_input: bool,
    },
    /// The shader object of its code with the carrier baked in (revz's own), bound in its
    /// place for precise-path draws: it stores complementary depth of the range it fits.
    /// `projects_input`: the matrix multiplies the previous stage's `Position`
    /// (`gl_in[i].gl_Position`), whose w = 1 the variant assumes: it is bound only after a
    /// stage bound before it that stores w = 1 (`crate::command_state::CommandState`; a
    /// pipeline checks this at its creation, shader objects are paired only at draw time).
    Baked {
        variant: vk::ShaderEXT,
        projects_input: bool,
    },
    /// No variant: its draws into reversed attachments take the flip path. `stores_unit_w`:
    /// every `Position` it stores is `vec4(p, 1.0)`
    /// (`crate::shader::position_store::stores_position_w_one`), which a later stage that
    /// projects it needs (asked of vertex and tessellation evaluation shaders on devices with
    /// geometry or tessellation shaders).
    Flip { stores_unit_w: bool },
    /// A geometry shader that stores `gl_in[i].gl_Position` as it is into every vertex it
    /// emits (`crate::shader::position_store::passes_position_through`), a tessellation
    /// control shader that copies the positions, or an evaluation shader that interpolates
    /// them (`crate::shader::tessellation_positions`): no variant of its own; the stage bound
    /// before it is the one precise-path draws bind a variant of, whose depth line it keeps.
    PassesThrough,
}

/// Shaders of the pushed route compare by their variant and the same facts (one `Arc`).
impl PartialEq for PositionShader {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (
                PositionShader::Pushed {
                    variant,
                    depth,
                    projects_input,
                },
                PositionShader::Pushed {
                    variant: other_variant,
                    depth: other_depth,
                    projects_input: other_projects_input,
                },
            ) => {
                variant == other_variant
                    && std::sync::Arc::ptr_eq(depth, other_depth)
                    && projects_input == other_projects_input
            }
            (
                PositionShader::Baked {
                    variant,
                    projects_input,
                },
                PositionShader::Baked {
                    variant: other_variant,
                    projects_input: other_projects_input,
                },
            ) => variant == other_variant && projects_input == other_projects_input,
            (
                PositionShader::Flip { stores_unit_w },
                PositionShader::Flip {
                    stores_unit_w: other,
                },
            ) => stores_unit_w == other,
            (PositionShader::PassesThrough, PositionShader::PassesThrough) => true,
            _ => false,
        }
    }
}

impl PositionShader {
    /// The variant, if there is one.
    pub fn variant(&self) -> Option<vk::ShaderEXT> {
        match self {
            PositionShader::Pushed { variant, .. } | PositionShader::Baked { variant, .. } => {
                Some(*variant)
            }
            PositionShader::Flip { .. } | PositionShader::PassesThrough => None,
        }
    }

    /// Whether its variant projects the previous stage's `Position`, assuming its w = 1.
    pub fn projects_input(&self) -> bool {
        match self {
            PositionShader::Pushed { projects_input, .. }
            | PositionShader::Baked { projects_input, .. } => *projects_input,
            PositionShader::Flip { .. } | PositionShader::PassesThrough => false,
        }
    }

    /// Whether it stores every `Position` as `vec4(p, 1.0)` itself.
    pub fn stores_unit_w(&self) -> bool {
        matches!(
            self,
            PositionShader::Flip {
                stores_unit_w: true
            }
        )
    }
}

/// What a secondary's inheritance names of the pass it continues, without a framebuffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SecondaryPass {
    Subpass(vk::RenderPass, u32),
    Rendering(vk::Format),
}

impl DeviceObjects {
    /// The raw handle of `view`'s image, 0 for none (the depth profile's key).
    pub fn view_image_raw(&self, view: vk::ImageView) -> u64 {
        self.views.get(&view).map_or(0, vk::Handle::as_raw)
    }

    /// The format of a tracked depth view's image.
    pub fn view_format(&self, view: vk::ImageView) -> Option<vk::Format> {
        let image = self.views.get(&view)?;
        self.images.get(&image).map(|info| info.format)
    }

    /// Remembers the target a primary begins `pass` with for secondaries (written only when
    /// it changes: a read lock in the steady state).
    pub fn remember_secondary_target(&self, pass: SecondaryPass, target: Target, promoted: bool) {
        if self.secondary_targets.get(&pass) != Some(target) {
            self.secondary_targets.insert(pass, target);
        }
        if self.secondary_promoted.get(&pass) != Some(promoted) {
            self.secondary_promoted.insert(pass, promoted);
        }
    }
}

impl DeviceObjects {
    /// The float format of a view's image, if revz promoted it.
    pub fn view_promoted(&self, view: vk::ImageView) -> Option<vk::Format> {
        let image = self.views.get(&view)?;
        self.images.get(&image)?.promoted
    }

    /// Whether a live depth image that may be resolved with an image of `format`, `extent`
    /// and `samples` keeps its format, as the policy says of each ([`kept_resolve_partner`]).
    pub fn resolve_partner_kept(
        &self,
        format: vk::Format,
        extent: vk::Extent3D,
        samples: vk::SampleCountFlags,
    ) -> bool {
        let image = ResolvePartner {
            format,
            extent,
            samples,
        };
        let images = self.images.0.read().unwrap_or_else(PoisonError::into_inner);
        images.values().any(|info| {
            let other = ResolvePartner {
                format: info.format,
                extent: info.extent,
                samples: info.samples,
            };
            kept_resolve_partner(image, other, info.promoted.is_some())
        })
    }

    /// How many live depth images of `format` are promoted and kept in `format`.
    pub fn count_promoted(&self, format: vk::Format) -> (usize, usize) {
        let images = self.images.0.read().unwrap_or_else(PoisonError::into_inner);
        images
            .values()
            .filter(|info| info.format == format)
            .fold((0, 0), |(p, k), info| match info.promoted {
                Some(_) => (p + 1, k),
                None => (p, k + 1),
            })
    }

    /// The depth target a view is: reversed, native, or not a tracked depth view.
    pub fn view_target(&self, view: vk::ImageView) -> Target {
        let Some(image) = self.views.get(&view) else {
            return Target::None;
        };
        self.images
            .get(&image)
            .map_or(Target::None, |info| info.depth.target())
    }

    /// How many live depth images of `format` are reversed and native.
    pub fn count_images(&self, format: vk::Format) -> (usize, usize) {
        let images = self.images.0.read().unwrap_or_else(PoisonError::into_inner);
        images
            .values()
            .filter(|info| info.format == format)
            .fold((0, 0), |(r, n), info| match info.depth {
                ImageDepth::Reversed => (r + 1, n),
                ImageDepth::Native(_) => (r, n + 1),
            })
    }

    /// Makes a reversed depth image native for the rest of its life (logged once: it happens
    /// once per image). Returns whether it was reversed until now.
    pub fn demote(&self, image: vk::Image, reason: NativeReason) -> bool {
        let mut images = self
            .images
            .0
            .write()
            .unwrap_or_else(PoisonError::into_inner);
        let Some(info) = images.get_mut(&image) else {
            return false;
        };
        let Some(demoted) = info.depth.demoted(reason) else {
            return false;
        };
        info.depth = demoted;
        if self
            .keep_demotions
            .load(std::sync::atomic::Ordering::Relaxed)
        {
            self.demotions
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push((image, reason));
        }
        log::info!(
            "depth image {image:?} ({:?}): native from now on, because {reason}",
            info.format
        );
        true
    }

    /// The images demoted since the last call, with why (for the depth profile).
    pub fn take_demotions(&self) -> Vec<(vk::Image, NativeReason)> {
        std::mem::take(
            &mut *self
                .demotions
                .lock()
                .unwrap_or_else(PoisonError::into_inner),
        )
    }

    /// Applies the resolve rule of the policy ([`DepthResolve::demotes_source`]) to a depth
    /// resolve from `source` into `destination`: a reversed source that cannot stay reversed
    /// through it becomes native, and so does a reversed destination of a native source. Each
    /// image made native is then followed through the resolves seen before
    /// (`Self::propagate_demotions`), so every resolve seen keeps holding the rule. Called
    /// where resolves are first seen (framebuffer creation, imageless and dynamic rendering
    /// begins), before the instance's targets are decided.
    pub fn settle_depth_resolve(
        &self,
        source: vk::ImageView,
        destination: vk::ImageView,
        mode: vk::ResolveModeFlags,
        swappable: bool,
    ) {
        if mode == vk::ResolveModeFlags::NONE {
            return;
        }
        let Some(source_image) = self.views.get(&source) else {
            return;
        };
        let destination_image = self.views.get(&destination);
        // Empty unless something is made native (no allocation on the usual begin).
        let mut demoted = Vec::new();
        if self.image_reversed(source_image) {
            let resolve = DepthResolve {
                mode,
                destination: self.view_target(destination),
                destination_image: destination_image.unwrap_or_default(),
                swappable,
            };
            if let Some(reason) = resolve.demotes_source() {
                if self.demote(source_image, reason) {
                    demoted.push(source_image);
                }
            }
        }
        if let Some(destination_image) = destination_image {
            match resolved_destination(source_image, self.image_reversed(source_image)) {
                ResolvedDestination::Demoted(reason) => {
                    if self.demote(destination_image, reason) {
                        demoted.push(destination_image);
                    }
                }
                ResolvedDestination::Paired => {
                    let pair = (source_image, destination_image);
                    if !self.resolve_pairs.contains(pair) {
                        self.resolve_pairs.insert(pair);
                        // Another thread may have made an end native between the checks above
                        // and the insert, and missed the pair when it followed that demotion.
                        demoted.extend(
                            [source_image, destination_image]
                                .into_iter()
                                .filter(|&image| !self.image_reversed(image)),
                        );
                    }
                }
            }
        }
        if !demoted.is_empty() {
            self.propagate_demotions(demoted);
        }
    }

    /// Follows images just made native through the resolves seen between reversed images,
    /// until nothing changes: the other end of each such resolve becomes native too (a
    /// destination receives standard values from a native source; a source may not resolve
    /// reversed values into a native destination), and is followed in turn. Each pair is taken
    /// out once followed (both its ends are native then), and each image is made native once,
    /// so this ends after at most as many steps as there are pairs.
    fn propagate_demotions(&self, mut worklist: Vec<vk::Image>) {
        while let Some(image) = worklist.pop() {
            for pair in self.resolve_pairs.take_touching(image) {
                let (other, reason) = follows_demotion(pair, image);
                if self.demote(other, reason) {
                    worklist.push(other);
                }
            }
        }
    }

    /// Destroys the objects revz created on the device's behalf (swapped-resolve twins of
    /// render passes, reversed variants of pipelines and of fragment shader objects, and baked
    /// variants of pre-rasterization shader objects, the application did not destroy), before
    /// the device goes.
    pub fn destroy_own_objects(
        &self,
        device: vk::Device,
        next: &ash::Device,
        commands: &crate::state::DeviceCommands,
    ) {
        let shaders = self
            .fragment_shaders
            .0
            .read()
            .unwrap_or_else(PoisonError::into_inner);
        let position_shaders = self
            .position_shaders
            .0
            .read()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(destroy) = commands.destroy_shader_ext {
            let variants = shaders
                .values()
                .filter_map(|shader| shader.variant())
                .chain(
                    position_shaders
                        .values()
                        .filter_map(|shader| shader.variant()),
                );
            for variant in variants {
                // SAFETY: revz's own object; the device is idle.
                unsafe { destroy(device, variant, std::ptr::null()) };
            }
        }
        let pipelines = self
            .pipelines
            .0
            .read()
            .unwrap_or_else(PoisonError::into_inner);
        for variant in pipelines.values().flat_map(|p| p.variants()) {
            // SAFETY: revz's own object; the device is idle.
            unsafe { (next.fp_v1_0().destroy_pipeline)(device, variant, std::ptr::null()) };
        }
        let passes = self
            .render_passes
            .0
            .read()
            .unwrap_or_else(PoisonError::into_inner);
        for twin in passes.values().flat_map(|pass| pass.twins()) {
            // SAFETY: revz's own object; the device is idle (the application's contract for
            // vkDestroyDevice).
            unsafe { (next.fp_v1_0().destroy_render_pass)(device, twin, std::ptr::null()) };
        }
        let layouts = self
            .push_layouts
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        for &(_, layout) in layouts.iter() {
            // SAFETY: as above.
            unsafe { (next.fp_v1_0().destroy_pipeline_layout)(device, layout, std::ptr::null()) };
        }
    }

    /// [`Self::settle_depth_resolve`] for every depth resolve of `pass` over the framebuffer
    /// attachments `views`.
    pub fn settle_pass_resolves(&self, pass: &RenderPassInfo, views: &[vk::ImageView]) {
        for (source, resolve) in pass.depth_resolves() {
            let view = |index: u32| views.get(index as usize).copied();
            if let (Some(source), Some(destination)) = (view(source), view(resolve.attachment)) {
                let swappable = pass.resolve_swappable(resolve);
                self.settle_depth_resolve(source, destination, resolve.mode, swappable);
            }
        }
    }

    /// Whether an image is a reversed depth image.
    pub fn image_reversed(&self, image: vk::Image) -> bool {
        matches!(
            self.images.get(&image).map(|i| i.depth),
            Some(ImageDepth::Reversed)
        )
    }
}

/// The render pass instance a primary command buffer is inside, to follow `vkCmdNextSubpass`.
#[derive(Clone, Debug, Default)]
pub struct PassScope {
    /// The render pass begun (null for dynamic rendering or none).
    pub handle: vk::RenderPass,
    pub render_pass: Option<Arc<RenderPassInfo>>,
    /// The depth target of each attachment of the current framebuffer.
    pub attachment_targets: Vec<Target>,
    /// The framebuffer's attachments (the depth profile names the image draws go to; the end
    /// of the pass refreshes the read twins of those it leaves readable).
    pub attachment_views: Option<Arc<[vk::ImageView]>>,
    pub subpass: usize,
    /// The framebuffer's depth images are promoted: the pass was begun as its promoted twin.
    pub promoted: bool,
    /// Its reversed depth images (the n / f of the draws into them is remembered when the
    /// pass ends: [`DeviceObjects::near_over_far`]).
    pub reversed_images: Vec<vk::Image>,
}

impl PassScope {
    /// What draws of the current subpass know of promotion
    /// ([`crate::command_state::CommandState::set_promoted`]), as the policy decides it from
    /// the subpass's depth format ([`crate::policy::subpass_promoted_from`]).
    pub fn promoted_from(&self) -> Option<vk::Format> {
        // A twin is begun only for a pass revz tracks.
        let pass = self.render_pass.as_ref()?;
        let depth_format = pass
            .subpass_depth
            .get(self.subpass)
            .copied()
            .flatten()
            .and_then(|index| pass.attachments.get(index as usize).copied());
        crate::policy::subpass_promoted_from(self.promoted, depth_format)
    }

    /// Whether the current subpass reads a reversed depth image through an input attachment
    /// (its pipelines' input variants convert the reads), and whether one it reads that way
    /// is native while its depth attachment is reversed (the reversed variants convert every
    /// depth input read: logged by the caller).
    pub fn depth_inputs(&self) -> (bool, bool) {
        let Some(inputs) = self
            .render_pass
            .as_ref()
            .and_then(|pass| pass.subpass_depth_inputs.get(self.subpass))
        else {
            return (false, false);
        };
        let target = |input: &DepthInput| {
            self.attachment_targets
                .get(input.attachment as usize)
                .copied()
                .unwrap_or_default()
        };
        let reversed = inputs.iter().any(|i| target(i) == Target::Reversed);
        let native = inputs.iter().any(|i| target(i) == Target::Native);
        (reversed, native && self.target() == Target::Reversed)
    }

    /// The current subpass's depth attachment view (null: none or not known).
    pub fn depth_view(&self) -> vk::ImageView {
        let index = self
            .render_pass
            .as_ref()
            .and_then(|pass| pass.subpass_depth.get(self.subpass).copied().flatten());
        index
            .zip(self.attachment_views.as_ref())
            .and_then(|(index, views)| views.get(index as usize).copied())
            .unwrap_or_default()
    }

    pub fn target(&self) -> Target {
        let Some(pass) = &self.render_pass else {
            return Target::None;
        };
        pass.subpass_depth
            .get(self.subpass)
            .copied()
            .flatten()
            .and_then(|index| self.attachment_targets.get(index as usize).copied())
            .unwrap_or(Target::None)
    }
}

impl DeviceObjects {
    /// The generation of the pipeline table (see `pipeline_generation`).
    #[inline]
    pub fn pipeline_generation(&self) -> u64 {
        self.pipeline_generation.load(Ordering::Acquire)
    }

    /// Stops tracking a destroyed pipeline: its depth state, for its variants' destruction.
    pub fn forget_pipeline(&self, pipeline: vk::Pipeline) -> Option<Arc<PipelineDepth>> {
        let removed = self.pipelines.remove(&pipeline);
        // After the removal: a recording that reads the new generation finds the table
        // without it.
        self.pipeline_generation.fetch_add(1, Ordering::AcqRel);
        removed
    }
}

mod command_buffers;
mod recording_lock;

pub use command_buffers::*;

#[cfg(test)]
mod tests {
    use ash::vk::Handle;

    use super::*;

    #[test]
    fn a_destroyed_pipeline_moves_the_generation_recordings_keep_pipelines_under() {
        let objects = DeviceObjects::default();
        let pipeline = vk::Pipeline::from_raw(5);
        objects
            .pipelines
            .insert(pipeline, Arc::new(PipelineDepth::default()));
        let before = objects.pipeline_generation();
        assert!(objects.forget_pipeline(pipeline).is_some());
        assert!(objects.pipelines.get(&pipeline).is_none());
        assert_ne!(objects.pipeline_generation(), before);
    }

    /// `codes.get_or_make` of `words`, counting in `made` the codes made.
    fn made_once(codes: &CodeCache<usize>, made: &std::cell::Cell<usize>, words: &[u32]) -> usize {
        codes.get_or_make(words, || {
            made.set(made.get() + 1);
            words.len()
        })
    }

    #[test]
    fn code_is_made_once_per_distinct_code() {
        let (codes, made) = (CodeCache::default(), std::cell::Cell::new(0));
        let make = |words: &[u32]| made_once(&codes, &made, words);
        assert_eq!(make(&[1, 2, 3]), 3);
        assert_eq!(make(&[1, 2, 3]), 3);
        assert_eq!(made.get(), 1, "the same code again: kept");
        assert_eq!(make(&[1, 2, 4, 5]), 4);
        assert_eq!((made.get(), codes.len()), (2, 2));
    }

    #[test]
    fn codes_past_the_word_budget_are_made_each_time() {
        let (codes, made) = (CodeCache::default(), std::cell::Cell::new(0));
        let make = |words: &[u32]| made_once(&codes, &made, words);
        let half = CodeCache::<usize>::BUDGET_WORDS / 2 + 1;
        let (a, b) = (vec![1; half], vec![2; half]);
        assert_eq!(make(&a), half);
        assert_eq!(make(&b), half);
        assert_eq!(make(&b), half);
        assert_eq!((made.get(), codes.len()), (3, 1), "b does not fit beside a");
        assert_eq!(make(&a), half);
        assert_eq!(made.get(), 3, "a is kept");
    }

    /// A tracked D32 image with handle `raw`, and a view of it (handle `raw + 100`).
    fn track(objects: &DeviceObjects, raw: u64, depth: ImageDepth) -> (vk::Image, vk::ImageView) {
        let (image, view) = (vk::Image::from_raw(raw), vk::ImageView::from_raw(raw + 100));
        let format = vk::Format::D32_SFLOAT;
        objects.images.insert(
            image,
            ImageInfo {
                format,
                depth,
                promoted: None,
                extent: vk::Extent3D::default(),
                samples: vk::SampleCountFlags::TYPE_1,
                array_layers: 1,
                twin: None,
            },
        );
        objects.views.insert(view, image);
        (image, view)
    }

    #[test]
    fn a_reused_image_handle_does_not_inherit_the_resolve_pairs_of_the_destroyed_image() {
        let objects = DeviceObjects::default();
        let average = vk::ResolveModeFlags::AVERAGE;
        let (source, source_view) = track(&objects, 1, ImageDepth::Reversed);
        let (old, old_view) = track(&objects, 2, ImageDepth::Reversed);
        objects.settle_depth_resolve(source_view, old_view, average, true);
        assert_eq!(objects.resolve_pairs.count(), 1);
        // Destroyed (what the destroy hook does), and the handle comes back for a new image.
        objects.images.remove(&old);
        objects.resolve_pairs.remove(&old);
        let (reused, _) = track(&objects, 2, ImageDepth::Reversed);
        assert_eq!(reused, old);

        let native = ImageDepth::Native(NativeReason::CopiedFrom);
        let (observed, observed_view) = track(&objects, 3, native);
        objects.settle_depth_resolve(source_view, observed_view, average, true);
        assert_eq!(
            objects.images.get(&source).map(|i| i.depth),
            Some(ImageDepth::Native(NativeReason::ResolvedIntoNative(
                observed
            )))
        );
        assert!(
            objects.image_reversed(reused),
            "the new image is not touched"
        );
    }
}
