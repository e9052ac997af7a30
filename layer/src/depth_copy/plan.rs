//! The arithmetic of a converted copy, without Vulkan calls: how a depth format's texels lie in
//! a buffer, the map between the stored and the standard values, the header the conversion
//! shader reads, where each copied region sits in revz's scratch buffer, and the buffer
//! copies between that scratch and the application's buffer.

use ash::vk;

use crate::conv::Reversal;

/// How the depth aspect of a format lies in a buffer (Vulkan spec, "Copying Data Between
/// Buffers and Images": D16 two bytes, X8_D24 and D24_S8 a 32-bit word with the depth in its
/// low 24 bits, D32 a float32; the stencil aspect is copied on its own).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelKind {
    Unorm16,
    Unorm24,
    Float32,
}

impl TexelKind {
    /// The kind of `format`'s depth aspect; `None` without one.
    pub fn of(format: vk::Format) -> Option<TexelKind> {
        match format {
            vk::Format::D16_UNORM | vk::Format::D16_UNORM_S8_UINT => Some(TexelKind::Unorm16),
            vk::Format::X8_D24_UNORM_PACK32 | vk::Format::D24_UNORM_S8_UINT => {
                Some(TexelKind::Unorm24)
            }
            vk::Format::D32_SFLOAT | vk::Format::D32_SFLOAT_S8_UINT => Some(TexelKind::Float32),
            _ => None,
        }
    }

    /// Bytes per texel in a buffer.
    pub fn bytes(self) -> u64 {
        match self {
            TexelKind::Unorm16 => 2,
            TexelKind::Unorm24 | TexelKind::Float32 => 4,
        }
    }

    /// The largest integer of a UNORM kind (the value of depth 1); `None` for float.
    pub fn unorm_max(self) -> Option<u32> {
        match self {
            TexelKind::Unorm16 => Some(0xFFFF),
            TexelKind::Unorm24 => Some(0x00FF_FFFF),
            TexelKind::Float32 => None,
        }
    }

    /// The value of depth 1 in this kind's units (its largest integer, 1 for float).
    fn unit(self) -> f64 {
        self.unorm_max().map_or(1.0, f64::from)
    }

    /// The shader's kind (`SOURCE_KIND`, `DESTINATION_KIND` in
    /// `shaders/depth_convert.comp.spvasm`).
    fn shader_kind(self) -> u32 {
        match self {
            TexelKind::Unorm16 => 0,
            TexelKind::Unorm24 => 1,
            TexelKind::Float32 => 2,
        }
    }
}

/// What a conversion reads and what it writes: the texels of the copy's source as they lie in
/// the scratch buffer, and those its destination takes. They differ where one end is a promoted
/// image (float32 storage) and the other holds the application's own format (a buffer, or an
/// image that kept its UNORM format).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TexelKinds {
    pub source: TexelKind,
    pub destination: TexelKind,
}

impl TexelKinds {
    /// One kind at both ends: the conversion is in place.
    pub fn same(kind: TexelKind) -> TexelKinds {
        TexelKinds {
            source: kind,
            destination: kind,
        }
    }
}

/// An affine map of depth values, d -> offset + scale * d, in depth units, and whether float
/// results are clamped to [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthMap {
    pub offset: f64,
    pub scale: f64,
    /// Float results clamped to [0, 1] (the shader's `CLAMP_UNIT`): where depth can only be
    /// there, the clamp takes away the float32 rounding that lands just outside. Not on a
    /// device that enabled `VK_EXT_depth_range_unrestricted`, whose float depth images hold
    /// what viewports, clears and fragment shaders put there, outside [0, 1] included
    /// ([`DepthMap::unrestricted`]). UNORM results are always clamped to their range.
    pub clamp: bool,
}

impl DepthMap {
    /// Values that keep their convention (only their format changes).
    pub const IDENTITY: DepthMap = DepthMap {
        offset: 0.0,
        scale: 1.0,
        clamp: true,
    };

    /// The same map, its float results clamped to [0, 1] unless `unrestricted` (a device that
    /// enabled `VK_EXT_depth_range_unrestricted`).
    pub fn unrestricted(self, unrestricted: bool) -> DepthMap {
        DepthMap {
            clamp: !unrestricted,
            ..self
        }
    }

    /// From stored (reversed) values to the standard ones the application would have had
    /// without revz: the inverse of `reversal` (d -> 1 - d, or for infinite mode's
    /// v = 1 - (1 - r) d, d = (1 - v) / (1 - r)).
    pub fn to_standard(reversal: Reversal) -> DepthMap {
        let keep = keep_factor(reversal);
        DepthMap {
            offset: 1.0 / keep,
            scale: -1.0 / keep,
            clamp: true,
        }
    }

    /// From standard values to the reversed ones revz stores: `reversal` itself.
    pub fn to_reversed(reversal: Reversal) -> DepthMap {
        let keep = keep_factor(reversal);
        DepthMap {
            offset: 1.0,
            scale: -keep,
            clamp: true,
        }
    }

    /// This map followed by `next` (`next`'s clamp applies to the result).
    #[must_use]
    pub fn then(self, next: DepthMap) -> DepthMap {
        DepthMap {
            offset: next.offset + next.scale * self.offset,
            scale: next.scale * self.scale,
            clamp: next.clamp,
        }
    }

    /// Whether this is d -> 1 - d (exact on UNORM integers as a bit complement).
    pub fn is_flip(self) -> bool {
        self.offset == 1.0 && self.scale == -1.0
    }

    /// The map applied in f64, clamped to [0, 1] where [`DepthMap::clamp`] says (what the
    /// shader computes in float32).
    pub fn apply(self, depth: f64) -> f64 {
        let mapped = self.offset + self.scale * depth;
        if self.clamp {
            mapped.clamp(0.0, 1.0)
        } else {
            mapped
        }
    }
}

/// 1 - r of `reversal` (1 for the plain flip).
fn keep_factor(reversal: Reversal) -> f64 {
    match reversal {
        Reversal::Complementary => 1.0,
        Reversal::Infinite { near_over_far } => {
            let r = f64::from(near_over_far);
            // r is n / f of a camera, in [0, 1); anything else is not a range: plain flip.
            if (0.0..1.0).contains(&r) {
                1.0 - r
            } else {
                1.0
            }
        }
    }
}

/// Which of the conversion shader's pipelines a conversion runs: its specialization constants
/// (the source kind, the destination kind, the exact flip, and whether float results are
/// clamped to [0, 1]), so that each pipeline holds only its own arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Specialization {
    pub kinds: TexelKinds,
    /// UNORM values of one kind flipped d -> 1 - d: a bit complement (`ShaderHeader::mask`).
    pub complement: bool,
    /// Float results clamped to [0, 1] ([`DepthMap::clamp`]).
    pub clamp: bool,
}

impl Specialization {
    /// How many there are: three source kinds, three destination kinds, complement or not,
    /// clamped or not (a device uses one of the last two: whether it enabled
    /// `VK_EXT_depth_range_unrestricted`).
    pub const COUNT: usize = 36;

    /// Its place among the [`Self::COUNT`] (for a table of pipelines).
    pub fn index(self) -> usize {
        let kinds = self.kinds.source.shader_kind() * 3 + self.kinds.destination.shader_kind();
        (kinds as usize * 2 + usize::from(self.complement)) * 2 + usize::from(self.clamp)
    }

    /// The values of constants 0 to 3, as `VkSpecializationInfo` reads them.
    pub fn constants(self) -> [u32; 4] {
        [
            self.kinds.source.shader_kind(),
            self.kinds.destination.shader_kind(),
            u32::from(self.complement),
            u32::from(self.clamp),
        ]
    }
}

/// The header of the conversion shader's buffer (`shaders/depth_convert.comp.spvasm`): 32
/// bytes before the texels. A source texel x becomes c0 + c1 * (x + t) / c2 in the
/// destination's units. `specialization` is not in the header: it picks the pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShaderHeader {
    /// Blocks of [`TEXELS_PER_BLOCK`] texels to convert.
    pub blocks: u32,
    /// Quad (16 bytes) of the first source texel, counted from the first quad past the
    /// header.
    pub in_quad: u32,
    /// Quad of the first destination texel (`in_quad`: in place).
    pub out_quad: u32,
    /// Bits complemented (the exact flip of UNORM values), 0 for the affine map. For the flip
    /// of float values into UNORM ones, 1: the shader then unflips, reading a float back as
    /// the integer whose flip into float it is where a neighbour of the rounded value is one
    /// (a D24 value stored in a promoted image as (max - u) / max, rounded once, is up to half
    /// a unit from u once flipped back in float32: rounding alone got 1 in 3,000 of them one
    /// unit off, measured on lavapipe; unflipped, every one comes back).
    pub mask: u32,
    pub c0: f32,
    pub c1: f32,
    pub t: f32,
    /// The source's unit where it is UNORM (a division, not a multiplication by its rounded
    /// reciprocal: u / max correctly rounded is what brings every D24 value back from float32
    /// unchanged), 1 for float.
    pub c2: f32,
    pub specialization: Specialization,
}

/// Bytes before the first texel in the scratch buffer.
pub const HEADER_BYTES: u64 = 32;

/// Texels one invocation of the shader converts: whole quads of words in and out (one of
/// UNORM16, two of the other kinds). A CPU device (lavapipe) reads and writes storage buffers
/// one invocation at a time and pays per access, not per byte, so a quad per access is what
/// makes the conversion cheap there (session 25: the dispatch took 40% of the time words
/// a texel took, pairs did before).
pub const TEXELS_PER_BLOCK: u64 = 8;

impl ShaderHeader {
    /// The header converting the texels of `layout` from `kinds.source` to
    /// `kinds.destination` with `map`. Values are mapped in the kinds' own units (UNORM
    /// integers, float depth), the constants computed in f64 before the one rounding to
    /// float32: a flip between UNORM values of one kind is exact (a bit complement), every
    /// other map within half a unit of the destination plus one float32 rounding each for the
    /// product and the quotient. The map offset + scale d is written scale (d - 1) where
    /// offset is -scale (the maps to standard depth): d - 1 is exact on integers and on floats
    /// of [0.5, 1].
    pub fn new(kinds: TexelKinds, map: DepthMap, layout: &ScratchLayout) -> ShaderHeader {
        let (unit_in, unit_out) = (kinds.source.unit(), kinds.destination.unit());
        let (c0, t) = if map.offset == -map.scale {
            (0.0, -unit_in)
        } else {
            (map.offset * unit_out, 0.0)
        };
        let complement = kinds.source == kinds.destination && map.is_flip();
        // A float's flip into UNORM values: the word asks the shader to unflip
        // ([`ShaderHeader::mask`]).
        let unflip = kinds.source == TexelKind::Float32
            && kinds.destination.unorm_max().is_some()
            && map.is_flip();
        let mask = match kinds.source {
            TexelKind::Unorm16 if complement => 0xFFFF_FFFF,
            TexelKind::Unorm24 if complement => 0x00FF_FFFF,
            TexelKind::Float32 if unflip => 1,
            _ => 0,
        };
        ShaderHeader {
            blocks: layout.blocks,
            in_quad: layout.in_quad,
            out_quad: layout.out_quad,
            mask,
            c0: c0 as f32,
            c1: (map.scale * unit_out) as f32,
            t: t as f32,
            c2: unit_in as f32,
            specialization: Specialization {
                kinds,
                complement: mask != 0 && !unflip,
                clamp: map.clamp,
            },
        }
    }

    /// The header as `vkCmdUpdateBuffer` writes it.
    pub fn to_bytes(self) -> [u8; HEADER_BYTES as usize] {
        let mut bytes = [0u8; HEADER_BYTES as usize];
        let words = [
            self.blocks,
            self.in_quad,
            self.out_quad,
            self.mask,
            self.c0.to_bits(),
            self.c1.to_bits(),
            self.t.to_bits(),
            self.c2.to_bits(),
        ];
        for (chunk, word) in bytes.chunks_exact_mut(4).zip(words) {
            chunk.copy_from_slice(&word.to_ne_bytes());
        }
        bytes
    }

    /// What the shader computes for one source texel (a UNORM integer, or float bits), on
    /// the host (the reference its tests use).
    pub fn convert_texel(self, x: u32) -> u32 {
        let kinds = self.specialization.kinds;
        if self.specialization.complement {
            return x ^ self.mask;
        }
        let x = match kinds.source {
            TexelKind::Unorm16 => x as f32,
            TexelKind::Unorm24 => (x & 0x00FF_FFFF) as f32,
            TexelKind::Float32 => f32::from_bits(x),
        };
        let y = self.c0 + self.c1 * (x + self.t) / self.c2;
        let unorm = |top: f32| {
            let mut v = y.round_ties_even().clamp(0.0, top);
            if kinds.source == TexelKind::Float32 && self.mask != 0 {
                // The shader's unflip: the neighbour whose flip is x, where one is.
                for candidate in [(v - 1.0).max(0.0), (v + 1.0).min(top)] {
                    if (top - candidate) / top == x {
                        v = candidate;
                    }
                }
            }
            v as u32
        };
        match kinds.destination {
            TexelKind::Unorm16 => unorm(65535.0),
            TexelKind::Unorm24 => unorm(16_777_215.0),
            TexelKind::Float32 if self.specialization.clamp => y.clamp(0.0, 1.0).to_bits(),
            TexelKind::Float32 => y.to_bits(),
        }
    }

    /// What the shader does to the words past the header, on the host: every block of source
    /// texels converted into the destination's words (texel i of a UNORM16 block in the low
    /// half of its word i / 2 where i is even, the high half where odd; one word a texel of
    /// the other kinds).
    pub fn convert_words(self, words: &mut [u32]) {
        let kinds = self.specialization.kinds;
        let block = TEXELS_PER_BLOCK as usize;
        let (source, destination) = (self.in_quad as usize * 4, self.out_quad as usize * 4);
        for texel in 0..self.blocks as usize * block {
            let x = match kinds.source {
                TexelKind::Unorm16 => (words[source + texel / 2] >> (16 * (texel % 2))) & 0xFFFF,
                _ => words[source + texel],
            };
            let y = self.convert_texel(x);
            match kinds.destination {
                TexelKind::Unorm16 => {
                    let word = &mut words[destination + texel / 2];
                    let shift = 16 * (texel % 2);
                    // A complement keeps no bit apart: both halves complemented as a word.
                    *word = (*word & !(0xFFFF << shift)) | ((y & 0xFFFF) << shift);
                }
                _ => words[destination + texel] = y,
            }
        }
    }
}

/// Blocks one invocation converts in turn (`BLOCKS_PER_INVOCATION`): fewer workgroups, and
/// the header read once for all of them.
const BLOCKS_PER_INVOCATION: u32 = 4;

/// The workgroups of a dispatch over `blocks` blocks of texels (64 invocations per group,
/// each converting [`BLOCKS_PER_INVOCATION`]; a second dimension past the 65535 groups every
/// device allows in x).
pub fn workgroups(blocks: u32) -> (u32, u32) {
    let groups = blocks.div_ceil(BLOCKS_PER_INVOCATION * 64).max(1);
    let x = groups.min(65535);
    (x, groups.div_ceil(x))
}

/// `subresource` with an explicit layer count: `VK_REMAINING_ARRAY_LAYERS`
/// (`VK_KHR_maintenance5`) counts from its base layer to the last of an image of
/// `array_layers` (`None`: an image revz does not know, left as it is, which the plans then
/// refuse).
pub fn explicit_layers(
    subresource: vk::ImageSubresourceLayers,
    array_layers: Option<u32>,
) -> vk::ImageSubresourceLayers {
    match array_layers {
        Some(layers) if subresource.layer_count == vk::REMAINING_ARRAY_LAYERS => {
            vk::ImageSubresourceLayers {
                layer_count: layers.saturating_sub(subresource.base_array_layer),
                ..subresource
            }
        }
        _ => subresource,
    }
}

/// One region of a copy between an image's depth aspect and a buffer, as the application
/// gave it (`VkBufferImageCopy`): where its texels are in the application's buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferRegion {
    pub offset: u64,
    /// Texels per row in the buffer (0: the width).
    pub row_length: u32,
    /// Rows per image in the buffer (0: the height).
    pub image_height: u32,
    pub extent: vk::Extent3D,
    /// Array layers (each one `image_height` rows times the depth).
    pub layers: u32,
}

/// A region's texels packed tightly in the scratch buffer: where the source's texels are
/// copied in (`input`) and where the destination's are copied out from (`output`; the same
/// place where both ends have one kind). Byte offsets from the scratch buffer's start, past
/// the header, 4-aligned as depth copies require.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScratchRegion {
    pub input: u64,
    pub output: u64,
}

/// Where every region of a copy lies in the scratch buffer, and its size.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScratchLayout {
    pub regions: Vec<ScratchRegion>,
    /// Bytes the scratch buffer needs, header included.
    pub size: u64,
    /// Blocks of [`TEXELS_PER_BLOCK`] texels to convert (from the first region to the end).
    pub blocks: u32,
    /// Quads (16 bytes), past the header, of the first source and the first destination
    /// texel.
    pub in_quad: u32,
    pub out_quad: u32,
}

/// Texels of a region (rows of `width` texels, images of `height` rows).
fn texels(extent: vk::Extent3D, layers: u32) -> u64 {
    u64::from(extent.width) * u64::from(extent.height) * u64::from(extent.depth) * u64::from(layers)
}

/// Lays regions of `extents` (extent, layers) out one after another past the header, each on
/// a whole block of texels (so that every region starts on a quad and the shader's blocks
/// never straddle two regions; the texels past a region's end to its block's end are
/// converted and never copied): the source texels, then, where the destination's kind
/// differs, the destination texels at the same texel positions. `None` when the texels would
/// not fit the shader's 32-bit word indices.
pub fn scratch_layout(
    extents: impl IntoIterator<Item = (vk::Extent3D, u32)>,
    kinds: TexelKinds,
) -> Option<ScratchLayout> {
    let mut slot = 0u64;
    let mut starts = Vec::new();
    for (extent, layers) in extents {
        starts.push(slot);
        slot = slot
            .checked_add(texels(extent, layers))?
            .checked_next_multiple_of(TEXELS_PER_BLOCK)?;
    }
    let input_bytes = slot.checked_mul(kinds.source.bytes())?;
    let in_place = kinds.source == kinds.destination;
    let output_start = if in_place {
        HEADER_BYTES
    } else {
        HEADER_BYTES + input_bytes
    };
    let regions = starts
        .iter()
        .map(|&start| ScratchRegion {
            input: HEADER_BYTES + start * kinds.source.bytes(),
            output: output_start + start * kinds.destination.bytes(),
        })
        .collect();
    let size = output_start.checked_add(slot.checked_mul(kinds.destination.bytes())?)?;
    // Every word index the shader computes fits 32 bits.
    u32::try_from((size - HEADER_BYTES) / 4).ok()?;
    Some(ScratchLayout {
        regions,
        size,
        blocks: u32::try_from(slot / TEXELS_PER_BLOCK).ok()?,
        in_quad: 0,
        out_quad: ((output_start - HEADER_BYTES) / 16) as u32,
    })
}

/// The buffer copies moving a region between the application's buffer (laid out as the
/// application said) and its tight copy in the scratch buffer (`scratch_offset`): one per run
/// of contiguous rows, so that the padding between the application's rows is never written.
/// `src_is_scratch`: the direction. Appends to `copies`.
pub fn row_copies(
    region: BufferRegion,
    scratch_offset: u64,
    kind: TexelKind,
    src_is_scratch: bool,
    copies: &mut Vec<vk::BufferCopy>,
) {
    let texel = kind.bytes();
    let vk::Extent3D {
        width,
        height,
        depth,
    } = region.extent;
    let row_length = u64::from(if region.row_length == 0 {
        width
    } else {
        region.row_length
    });
    let image_height = u64::from(if region.image_height == 0 {
        height
    } else {
        region.image_height
    });
    let (width, height) = (u64::from(width), u64::from(height));
    let slices = u64::from(depth) * u64::from(region.layers);
    let row_bytes = width * texel;
    let mut push = |app: u64, scratch: u64, size: u64| {
        if size == 0 {
            return;
        }
        let (src_offset, dst_offset) = if src_is_scratch {
            (scratch, app)
        } else {
            (app, scratch)
        };
        copies.push(vk::BufferCopy {
            src_offset,
            dst_offset,
            size,
        });
    };
    let slice_bytes = row_bytes * height;
    if row_length == width && image_height == height {
        push(region.offset, scratch_offset, slice_bytes * slices);
        return;
    }
    for slice in 0..slices {
        let app_slice = region.offset + slice * image_height * row_length * texel;
        let scratch_slice = scratch_offset + slice * slice_bytes;
        if row_length == width {
            push(app_slice, scratch_slice, slice_bytes);
            continue;
        }
        for row in 0..height {
            push(
                app_slice + row * row_length * texel,
                scratch_slice + row * row_bytes,
                row_bytes,
            );
        }
    }
}

/// A copy between an image and a buffer, split: its depth regions go through the scratch
/// buffer, the others (stencil) go down as they are.
#[derive(Clone, Debug)]
pub struct BufferCopyPlan {
    pub layout: ScratchLayout,
    /// The depth regions between the image and the scratch buffer (tightly packed).
    pub image_regions: Vec<vk::BufferImageCopy>,
    /// The copies between the scratch buffer and the application's buffer.
    pub buffer_copies: Vec<vk::BufferCopy>,
    /// Indices of the application's regions that are not depth: sent down unchanged.
    pub rest: Vec<usize>,
}

/// Plans a copy between a depth image and a buffer (either way: `to_buffer`): `image`, the
/// texels of the image as it is stored (float32 where promoted), `buffer` those of the
/// application's format, laid out as it said. `None` when no region copies depth, or a
/// region's layer count is not explicit (`VK_REMAINING_ARRAY_LAYERS`) or its texels do not fit
/// one conversion.
pub fn plan_buffer_copy(
    regions: &[vk::BufferImageCopy],
    image: TexelKind,
    buffer: TexelKind,
    to_buffer: bool,
) -> Option<BufferCopyPlan> {
    let is_depth =
        |r: &vk::BufferImageCopy| r.image_subresource.aspect_mask == vk::ImageAspectFlags::DEPTH;
    let depth: Vec<&vk::BufferImageCopy> = regions.iter().filter(|r| is_depth(r)).collect();
    let kinds = if to_buffer {
        TexelKinds {
            source: image,
            destination: buffer,
        }
    } else {
        TexelKinds {
            source: buffer,
            destination: image,
        }
    };
    if depth.is_empty()
        || depth
            .iter()
            .any(|r| r.image_subresource.layer_count == vk::REMAINING_ARRAY_LAYERS)
    {
        return None;
    }
    let layout = scratch_layout(
        depth
            .iter()
            .map(|r| (r.image_extent, r.image_subresource.layer_count)),
        kinds,
    )?;
    let mut buffer_copies = Vec::new();
    let image_regions = depth
        .iter()
        .zip(&layout.regions)
        .map(|(region, scratch)| {
            let application = BufferRegion {
                offset: region.buffer_offset,
                row_length: region.buffer_row_length,
                image_height: region.buffer_image_height,
                extent: region.image_extent,
                layers: region.image_subresource.layer_count,
            };
            // Out of the image into the input, and from the output to the buffer; or from the
            // buffer into the input, and out of the output into the image.
            let (image_side, buffer_side) = if to_buffer {
                (scratch.input, scratch.output)
            } else {
                (scratch.output, scratch.input)
            };
            row_copies(
                application,
                buffer_side,
                buffer,
                to_buffer,
                &mut buffer_copies,
            );
            vk::BufferImageCopy {
                buffer_offset: image_side,
                buffer_row_length: 0,
                buffer_image_height: 0,
                ..**region
            }
        })
        .collect();
    let rest = (0..regions.len())
        .filter(|&i| !is_depth(&regions[i]))
        .collect();
    Some(BufferCopyPlan {
        layout,
        image_regions,
        buffer_copies,
        rest,
    })
}

/// A copy between two depth images of different conventions, split: the depth aspect of each
/// region goes through the scratch buffer (and the stencil, between two stored formats), the
/// rest (stencil) goes down.
#[derive(Clone, Debug)]
pub struct ImageCopyPlan {
    pub layout: ScratchLayout,
    /// Source image -> scratch.
    pub from_source: Vec<vk::BufferImageCopy>,
    /// Scratch -> destination image.
    pub to_destination: Vec<vk::BufferImageCopy>,
    /// The application's regions still sent down, with the aspects left to them (`STENCIL`
    /// where a region copied depth and stencil; unchanged where it copied no depth).
    pub rest: Vec<(usize, vk::ImageAspectFlags)>,
}

/// The extent one side of an image copy region covers: the region's, except on the 2D side
/// of a copy between a 3D image and a 2D (array) image (`VK_KHR_maintenance1`), where the
/// region's depth counts that side's array layers and its own extent is one deep. The 2D side
/// is the one with several layers (a 3D image's subresource has one); with one layer and one
/// slice the two readings agree. Slices and layers are packed alike in the scratch buffer, so
/// slice k of one side meets layer k of the other.
fn side_extent(extent: vk::Extent3D, side: vk::ImageSubresourceLayers) -> vk::Extent3D {
    if side.layer_count > 1 && extent.depth == side.layer_count {
        vk::Extent3D { depth: 1, ..extent }
    } else {
        extent
    }
}

/// Plans an image copy whose depth must change convention or format (`kinds`: the texels each
/// image is stored in). `None` as for [`plan_buffer_copy`]. Where the two images are stored in
/// different formats (one promoted, one not) the stencil goes through the scratch buffer as
/// well, as it is: an image copy of it between the two formats would be invalid.
pub fn plan_image_copy(regions: &[vk::ImageCopy], kinds: TexelKinds) -> Option<ImageCopyPlan> {
    let depth = vk::ImageAspectFlags::DEPTH;
    let copies_depth = |r: &vk::ImageCopy| r.src_subresource.aspect_mask.contains(depth);
    let converted: Vec<&vk::ImageCopy> = regions.iter().filter(|r| copies_depth(r)).collect();
    let stencil_between_formats = kinds.source != kinds.destination
        && regions.iter().any(|r| {
            r.src_subresource
                .aspect_mask
                .contains(vk::ImageAspectFlags::STENCIL)
        });
    let through_scratch = |r: &&vk::ImageCopy| {
        copies_depth(r)
            || (stencil_between_formats
                && r.src_subresource
                    .aspect_mask
                    .contains(vk::ImageAspectFlags::STENCIL))
    };
    // Stencil alone between two formats goes through the scratch without depth to convert.
    if (converted.is_empty() && !stencil_between_formats)
        || regions
            .iter()
            .filter(through_scratch)
            .any(|r| r.src_subresource.layer_count == vk::REMAINING_ARRAY_LAYERS)
    {
        return None;
    }
    let mut layout = scratch_layout(
        converted.iter().map(|r| {
            (
                side_extent(r.extent, r.src_subresource),
                r.src_subresource.layer_count,
            )
        }),
        kinds,
    )?;
    let only_depth = |subresource: vk::ImageSubresourceLayers| vk::ImageSubresourceLayers {
        aspect_mask: depth,
        ..subresource
    };
    let (mut from_source, mut to_destination) = (Vec::new(), Vec::new());
    for (region, scratch) in converted.iter().zip(&layout.regions) {
        let packed = |buffer_offset, subresource, offset| vk::BufferImageCopy {
            buffer_offset,
            buffer_row_length: 0,
            buffer_image_height: 0,
            image_subresource: only_depth(subresource),
            image_offset: offset,
            image_extent: side_extent(region.extent, subresource),
        };
        from_source.push(packed(
            scratch.input,
            region.src_subresource,
            region.src_offset,
        ));
        to_destination.push(packed(
            scratch.output,
            region.dst_subresource,
            region.dst_offset,
        ));
    }
    let stencil = vk::ImageAspectFlags::STENCIL;
    if stencil_between_formats {
        // Between two formats the stencil cannot go down as an image copy: it goes through
        // the scratch too.
        let side = |region: &vk::ImageCopy, subresource: vk::ImageSubresourceLayers, offset| {
            vk::BufferImageCopy {
                buffer_offset: 0,
                buffer_row_length: 0,
                buffer_image_height: 0,
                image_subresource: subresource,
                image_offset: offset,
                image_extent: side_extent(region.extent, subresource),
            }
        };
        let sides = regions
            .iter()
            .filter(|r| r.src_subresource.aspect_mask.contains(stencil))
            .map(|r| {
                (
                    side(r, r.src_subresource, r.src_offset),
                    side(r, r.dst_subresource, r.dst_offset),
                )
            });
        stencil_through_scratch(sides, &mut layout, &mut from_source, &mut to_destination)?;
    }
    let rest = regions
        .iter()
        .enumerate()
        .filter_map(|(i, region)| {
            let mut left = region.src_subresource.aspect_mask & !depth;
            if stencil_between_formats {
                left &= !stencil;
            }
            match (copies_depth(region), left.is_empty()) {
                (false, true) => None,
                (false, false) | (true, false) => Some((i, left)),
                (true, true) => None,
            }
        })
        .collect();
    Some(ImageCopyPlan {
        layout,
        from_source,
        to_destination,
        rest,
    })
}

/// A blit whose depth must change convention or format: each region's source box is copied,
/// converted, into a staged image of the destination's (stored) format, and blitted from there
/// (a blit may scale or mirror, so the conversion happens before it, on the texels it reads).
/// The staged image is 2D with each region in layers of its own, or 3D where a box is more than
/// one slice deep (a 3D source), each region in slices of its own.
#[derive(Clone, Debug)]
pub struct BlitPlan {
    pub layout: ScratchLayout,
    /// Source image -> scratch, one per converted region (its box, tightly packed).
    pub from_source: Vec<vk::BufferImageCopy>,
    /// Scratch -> staged image: region i at the origin of its own layers (slices where the
    /// staged image is 3D). With the stencil staged too, its copies first (`from_source`
    /// lists them last).
    pub to_staged: Vec<vk::BufferImageCopy>,
    /// The staged image's size (the largest box; in 3D as deep as every region's slices in
    /// turn) and layers (every region's in turn in 2D, one in 3D).
    pub staged_extent: vk::Extent3D,
    pub staged_layers: u32,
    /// The depth blits, from the staged image.
    pub blits: Vec<vk::ImageBlit>,
    /// The application's regions still sent down with the aspects left to them, as for
    /// [`ImageCopyPlan::rest`].
    pub rest: Vec<(usize, vk::ImageAspectFlags)>,
}

/// Moves the stencil of `sides` (each the copy of a region's box out of an image into the
/// scratch and the copy back into an image, whose aspect and buffer offset are set here)
/// through the scratch as it is: 1 byte a texel, past `layout`'s texels on 4-byte offsets (as
/// depth/stencil buffer copies need), which `layout` grows to hold. The fills go after
/// `fills`; the drains before `drains`: a stencil write must not be the last to touch a
/// texel's depth (lavapipe writes both aspects of a packed texel). `None` past `u64`.
fn stencil_through_scratch(
    sides: impl IntoIterator<Item = (vk::BufferImageCopy, vk::BufferImageCopy)>,
    layout: &mut ScratchLayout,
    fills: &mut Vec<vk::BufferImageCopy>,
    drains: &mut Vec<vk::BufferImageCopy>,
) -> Option<()> {
    let mut offset = layout.size.checked_next_multiple_of(4)?;
    let mut stencil_drains = Vec::new();
    for (fill, drain) in sides {
        let stencil = |copy: vk::BufferImageCopy| vk::BufferImageCopy {
            buffer_offset: offset,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::STENCIL,
                ..copy.image_subresource
            },
            ..copy
        };
        fills.push(stencil(fill));
        stencil_drains.push(stencil(drain));
        let bytes = texels(fill.image_extent, fill.image_subresource.layer_count);
        offset = offset.checked_add(bytes)?.checked_next_multiple_of(4)?;
    }
    if !stencil_drains.is_empty() {
        stencil_drains.append(drains);
        *drains = stencil_drains;
        layout.size = offset;
    }
    Some(())
}

impl BlitPlan {
    /// The staged image's type: 3D where a source box is several slices deep (a 3D source
    /// image's; the staged extent is then as deep as every region's slices), which a 2D
    /// image's layers cannot hold in one copy; 2D otherwise.
    pub fn staged_type(&self) -> vk::ImageType {
        if self.staged_extent.depth > 1 {
            vk::ImageType::TYPE_3D
        } else {
            vk::ImageType::TYPE_2D
        }
    }
}

/// Plans a converted blit (`kinds`: the texels the source and the destination are stored in;
/// `None` where no region blits depth and none stencil between two formats, or a staged region's layer count is not explicit or its
/// source box is empty). With `stage_stencil` (both formats have stencil, and a region of the
/// blit names it, so it is in the layout the blit names) each box's stencil goes into the
/// staged image too, through the scratch as it is: a driver that blits whole depth/stencil
/// texels (lavapipe writes the stencil of a depth-only blit of D24_S8) then writes the
/// source's stencil, as the application's blit would, not the staged image's undefined one.
/// Where the two formats differ (one promoted) and a region blits stencil, the application's
/// blit of it would be invalid (a depth/stencil blit needs one format at both ends): revz
/// stages every region that names stencil and blits all of their aspects itself.
pub fn plan_blit(
    regions: &[vk::ImageBlit],
    kinds: TexelKinds,
    stage_stencil: bool,
) -> Option<BlitPlan> {
    let depth = vk::ImageAspectFlags::DEPTH;
    let stencil = vk::ImageAspectFlags::STENCIL;
    let names = |r: &vk::ImageBlit, aspect| r.src_subresource.aspect_mask.contains(aspect);
    let take_stencil =
        kinds.source != kinds.destination && regions.iter().any(|r| names(r, stencil));
    // Stencil alone between two formats is staged without depth to convert.
    if !regions.iter().any(|r| names(r, depth)) && !take_stencil {
        return None;
    }
    let stage_stencil = stage_stencil || take_stencil;
    // The regions revz blits from its staged image, with their index.
    let staged_regions: Vec<(usize, &vk::ImageBlit)> = regions
        .iter()
        .enumerate()
        .filter(|(_, r)| names(r, depth) || (take_stencil && names(r, stencil)))
        .collect();
    // Each region's source box: its smallest corner and size.
    let boxes: Vec<(vk::Offset3D, vk::Extent3D)> = staged_regions
        .iter()
        .map(|(_, r)| {
            let [a, b] = r.src_offsets;
            let lo = vk::Offset3D {
                x: a.x.min(b.x),
                y: a.y.min(b.y),
                z: a.z.min(b.z),
            };
            let extent = vk::Extent3D {
                width: a.x.abs_diff(b.x),
                height: a.y.abs_diff(b.y),
                depth: a.z.abs_diff(b.z),
            };
            (lo, extent)
        })
        .collect();
    if staged_regions
        .iter()
        .any(|(_, r)| r.src_subresource.layer_count == vk::REMAINING_ARRAY_LAYERS)
        || boxes
            .iter()
            .any(|(_, e)| e.width == 0 || e.height == 0 || e.depth == 0)
    {
        return None;
    }
    // A box several slices deep comes from a 3D image, whose subresources have one layer: the
    // staged image is 3D, the regions one after the other in depth.
    let volume = boxes.iter().any(|(_, e)| e.depth > 1);
    if volume
        && staged_regions
            .iter()
            .any(|(_, r)| r.src_subresource.layer_count != 1)
    {
        return None;
    }
    // Every staged region has its place in the scratch (a stencil-only one's texels are
    // converted for nothing, never copied), so that the places line up with the regions.
    let mut layout = scratch_layout(
        staged_regions
            .iter()
            .zip(&boxes)
            .map(|((_, r), (_, extent))| (*extent, r.src_subresource.layer_count)),
        kinds,
    )?;
    let staged_extent = vk::Extent3D {
        width: boxes.iter().map(|(_, e)| e.width).max()?,
        height: boxes.iter().map(|(_, e)| e.height).max()?,
        depth: if volume {
            boxes
                .iter()
                .try_fold(0u32, |sum, (_, e)| sum.checked_add(e.depth))?
        } else {
            1
        },
    };
    let (mut from_source, mut to_staged, mut blits) = (Vec::new(), Vec::new(), Vec::new());
    // The boxes whose stencil is staged too: their fill and drain.
    let mut stencil_sides = Vec::new();
    // The next free layer (2D) or slice (3D) of the staged image.
    let mut base = 0u32;
    for (((_, region), (lo, extent)), scratch) in
        staged_regions.iter().zip(&boxes).zip(&layout.regions)
    {
        let count = region.src_subresource.layer_count;
        let (staged, staged_z) = if volume {
            (
                vk::ImageSubresourceLayers {
                    aspect_mask: depth,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                },
                i32::try_from(base).ok()?,
            )
        } else {
            (
                vk::ImageSubresourceLayers {
                    aspect_mask: depth,
                    mip_level: 0,
                    base_array_layer: base,
                    layer_count: count,
                },
                0,
            )
        };
        let fill = vk::BufferImageCopy {
            buffer_offset: scratch.input,
            buffer_row_length: 0,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: depth,
                ..region.src_subresource
            },
            image_offset: *lo,
            image_extent: *extent,
        };
        let drain = vk::BufferImageCopy {
            buffer_offset: scratch.output,
            image_subresource: staged,
            image_offset: vk::Offset3D {
                x: 0,
                y: 0,
                z: staged_z,
            },
            ..fill
        };
        if names(region, depth) {
            from_source.push(fill);
            to_staged.push(drain);
        }
        if stage_stencil {
            stencil_sides.push((fill, drain));
        }
        let shift = |o: vk::Offset3D| vk::Offset3D {
            x: o.x - lo.x,
            y: o.y - lo.y,
            z: o.z - lo.z + staged_z,
        };
        // What revz blits: the depth, and where it takes the stencil the region's aspects.
        let aspect_mask = if take_stencil {
            region.src_subresource.aspect_mask & (depth | stencil)
        } else {
            depth
        };
        blits.push(vk::ImageBlit {
            src_subresource: vk::ImageSubresourceLayers {
                aspect_mask,
                ..staged
            },
            src_offsets: region.src_offsets.map(shift),
            dst_subresource: vk::ImageSubresourceLayers {
                aspect_mask,
                ..region.dst_subresource
            },
            dst_offsets: region.dst_offsets,
        });
        base = base.checked_add(if volume { extent.depth } else { count })?;
    }
    stencil_through_scratch(stencil_sides, &mut layout, &mut from_source, &mut to_staged)?;
    let taken = if take_stencil { depth | stencil } else { depth };
    let rest = regions
        .iter()
        .enumerate()
        .filter_map(|(i, region)| {
            let aspects = region.src_subresource.aspect_mask;
            let staged = staged_regions.iter().any(|&(j, _)| j == i);
            let left = if staged { aspects & !taken } else { aspects };
            (!left.is_empty()).then_some((i, left))
        })
        .collect();
    Some(BlitPlan {
        layout,
        from_source,
        to_staged,
        staged_extent,
        staged_layers: if volume { 1 } else { base },
        blits,
        rest,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn extent(width: u32, height: u32) -> vk::Extent3D {
        vk::Extent3D {
            width,
            height,
            depth: 1,
        }
    }

    /// The header of a one-pair conversion from `kinds.source` to `kinds.destination`.
    fn header(kinds: TexelKinds, map: DepthMap) -> ShaderHeader {
        let layout = scratch_layout([(extent(2, 1), 1)], kinds).unwrap();
        ShaderHeader::new(kinds, map, &layout)
    }

    fn same(kind: TexelKind, map: DepthMap) -> ShaderHeader {
        header(TexelKinds::same(kind), map)
    }

    fn kinds(source: TexelKind, destination: TexelKind) -> TexelKinds {
        TexelKinds {
            source,
            destination,
        }
    }

    #[test]
    fn flips_of_unorm_values_are_exact_bit_complements() {
        let map = DepthMap::to_standard(Reversal::Complementary);
        assert!(map.is_flip());
        let d16 = same(TexelKind::Unorm16, map);
        assert!(d16.specialization.complement);
        let mut words = [0x1234_0001, 0, 0, 0];
        d16.convert_words(&mut words);
        assert_eq!(words[0], 0xEDCB_FFFE);
        let d24 = same(TexelKind::Unorm24, map);
        // The top byte (undefined in X8_D24, not depth) is kept.
        assert_eq!(d24.convert_texel(0xAB00_0001), 0xABFF_FFFE);
        for u in [0u32, 1, 0x7F_FFFF, 0xFF_FFFE, 0xFF_FFFF] {
            assert_eq!(d24.convert_texel(u), 0xFF_FFFF - u);
        }
    }

    #[test]
    fn float_flips_are_one_rounding_of_one_minus_d() {
        let header = same(
            TexelKind::Float32,
            DepthMap::to_standard(Reversal::Complementary),
        );
        assert!(!header.specialization.complement);
        for d in [0.0f32, 1.0, 0.5, 1e-7, 0.999_999_9, 0.3] {
            let got = f32::from_bits(header.convert_texel(d.to_bits()));
            assert_eq!(got, 1.0 - d, "{d}");
        }
    }

    #[test]
    fn a_remap_leaves_one_map_for_the_other() {
        // Infinite mode's n / w into an image of complementary depth, and back.
        let infinite = Reversal::Infinite {
            near_over_far: 1e-3,
        };
        let complementary = Reversal::Infinite { near_over_far: 0.0 };
        let there = DepthMap::to_standard(infinite).then(DepthMap::to_reversed(complementary));
        let back = DepthMap::to_standard(complementary).then(DepthMap::to_reversed(infinite));
        for d in [0.0f32, 0.25, 0.5, 0.999, 1.0] {
            let stored = f64::from(infinite.depth(d));
            let moved = there.apply(stored);
            assert!((moved - (1.0 - f64::from(d))).abs() < 1e-7, "{d}: {moved}");
            assert!((back.apply(moved) - stored).abs() < 1e-7, "{d}");
        }
        assert!(there.clamp);
        let unclamped = DepthMap::IDENTITY.then(DepthMap::IDENTITY.unrestricted(true));
        assert!(!unclamped.clamp);
    }

    #[test]
    fn infinite_maps_invert_each_other() {
        let reversal = Reversal::Infinite {
            near_over_far: 1e-4,
        };
        let (out, into) = (
            DepthMap::to_standard(reversal),
            DepthMap::to_reversed(reversal),
        );
        for d in [0.0, 0.25, 0.5, 0.999, 1.0] {
            let stored = into.apply(d);
            assert!((stored - f64::from(reversal.depth(d as f32))).abs() < 1e-7);
            assert!((out.apply(stored) - d).abs() < 1e-12, "{d}");
        }
        // UNORM24 in infinite mode: within one unit of the f64 inverse.
        let header = same(TexelKind::Unorm24, out);
        for u in [0u32, 1, 12_345, 8_000_000, 16_777_000, 16_777_215] {
            let exact = out.apply(f64::from(u) / 16_777_215.0) * 16_777_215.0;
            let got = f64::from(header.convert_texel(u));
            assert!((got - exact).abs() <= 1.0, "{u}: {got} vs {exact}");
        }
        let header = same(TexelKind::Unorm16, into);
        let mut words = [(40_000 << 16) | 7, 0, 0, 0];
        header.convert_words(&mut words);
        let exact = |u: f64| into.apply(u / 65535.0) * 65535.0;
        assert!((f64::from(words[0] >> 16) - exact(40_000.0)).abs() <= 0.5);
        assert!((f64::from(words[0] & 0xFFFF) - exact(7.0)).abs() <= 0.5);
    }

    /// A promoted image's float32 read into the application's UNORM bytes rounds to the
    /// nearest integer, as the device's own conversion would; and the application's UNORM
    /// bytes written into a promoted image come back as they were, for every value of D16 and
    /// of D24 (each way one float32 rounding, far from half a unit).
    #[test]
    fn promoted_texels_round_trip_through_the_applications_unorm_bytes() {
        use TexelKind::{Float32, Unorm16, Unorm24};
        for (unorm, max) in [(Unorm16, 65_535u32), (Unorm24, 16_777_215)] {
            let into = header(kinds(unorm, Float32), DepthMap::IDENTITY);
            let out = header(kinds(Float32, unorm), DepthMap::IDENTITY);
            for u in 0..=max {
                let stored = into.convert_texel(u);
                let d = f64::from(f32::from_bits(stored));
                assert!(
                    (d - f64::from(u) / f64::from(max)).abs() <= 6e-8,
                    "{u}: {d}"
                );
                assert_eq!(out.convert_texel(stored), u, "{unorm:?} {u}");
            }
            // Rounded to the nearest integer, clamped.
            for (d, u) in [(0.0f32, 0), (1.0, max), (2.0, max), (-1.0, 0)] {
                assert_eq!(out.convert_texel(d.to_bits()), u, "{d}");
            }
            let half = (0.5 + 0.49) / f64::from(max);
            assert_eq!(out.convert_texel((half as f32).to_bits()), 1);
        }
    }

    /// Every UNORM value written into a reversed promoted image (complementary: flipped into
    /// float32, one rounding) reads back unchanged: the unflip finds the integer the float came
    /// from (without it, 1 in 3,000 D24 values of [0.25, 0.5] came back one unit off). And a
    /// float the flip never wrote reads back within half a unit of its f64 value, plus a unit
    /// where the unflip took a neighbour.
    #[test]
    fn unorm_values_flipped_into_float_storage_read_back_unchanged() {
        use TexelKind::{Float32, Unorm16, Unorm24};
        for (unorm, max) in [(Unorm16, 65_535u32), (Unorm24, 16_777_215)] {
            let into = header(
                kinds(unorm, Float32),
                DepthMap::to_reversed(Reversal::Complementary),
            );
            let out = header(
                kinds(Float32, unorm),
                DepthMap::to_standard(Reversal::Complementary),
            );
            assert_eq!(into.mask, 0);
            assert_eq!(out.mask, 1);
            for u in 0..=max {
                let stored = into.convert_texel(u);
                assert_eq!(out.convert_texel(stored), u, "{unorm:?} {u}");
            }
            for v in [0.0f32, 1e-7, 0.3, 0.3333333, 0.5, 0.7, 1.0] {
                let exact = (1.0 - f64::from(v)) * f64::from(max);
                let got = f64::from(out.convert_texel(v.to_bits()));
                assert!(
                    (got - exact).abs() <= 1.5,
                    "{unorm:?} {v}: {got} vs {exact}"
                );
            }
        }
        // Maps other than the flip are not unflipped.
        let infinite = DepthMap::to_standard(Reversal::Infinite {
            near_over_far: 1e-3,
        });
        assert_eq!(header(kinds(Float32, Unorm24), infinite).mask, 0);
        assert_eq!(header(kinds(Float32, Unorm24), DepthMap::IDENTITY).mask, 0);
    }

    /// A reversed promoted image read into UNORM bytes: the values are undone and packed in
    /// one pass, within half a unit and one float32 rounding of the f64 value.
    #[test]
    fn reversed_promoted_texels_are_undone_and_packed_in_one_pass() {
        use TexelKind::{Float32, Unorm16, Unorm24};
        let maps = [
            DepthMap::to_standard(Reversal::Complementary),
            DepthMap::to_standard(Reversal::Infinite {
                near_over_far: 1e-3,
            }),
        ];
        for map in maps {
            for (unorm, max) in [(Unorm16, 65_535.0), (Unorm24, 16_777_215.0)] {
                let out = header(kinds(Float32, unorm), map);
                for v in [0.0f32, 1e-6, 0.001, 0.25, 0.5, 0.75, 0.999_99, 1.0] {
                    let exact = map.apply(f64::from(v)) * max;
                    let got = f64::from(out.convert_texel(v.to_bits()));
                    assert!(
                        (got - exact).abs() <= 0.5 + exact * 2.4e-7,
                        "{map:?} {unorm:?} {v}: {got} vs {exact}"
                    );
                }
                // And back: the application's bytes written into the reversed promoted image.
                let into = header(
                    kinds(unorm, Float32),
                    DepthMap::to_reversed(map_reversal(map)),
                );
                for u in [0u32, 1, 1000, (max / 2.0) as u32, max as u32] {
                    let stored = f32::from_bits(into.convert_texel(u));
                    let exact = DepthMap::to_reversed(map_reversal(map)).apply(f64::from(u) / max);
                    assert!((f64::from(stored) - exact).abs() <= 1.2e-7, "{u}");
                }
            }
        }
    }

    /// The reversal behind a map to standard depth (for the test above).
    fn map_reversal(map: DepthMap) -> Reversal {
        if map.is_flip() {
            Reversal::Complementary
        } else {
            Reversal::Infinite {
                near_over_far: (1.0 - 1.0 / map.offset) as f32,
            }
        }
    }

    /// Pairs of UNORM16 share a word: one invocation writes a block's words whole, from
    /// two quads of float32 source words, and the other way round.
    #[test]
    fn unorm16_pairs_are_packed_into_and_unpacked_from_one_word() {
        use TexelKind::{Float32, Unorm16};
        let layout = scratch_layout([(extent(3, 1), 1)], kinds(Float32, Unorm16)).unwrap();
        // Three texels take one block: eight float32 words (two quads) in, four words (one
        // quad) out after them.
        assert_eq!((layout.blocks, layout.in_quad, layout.out_quad), (1, 0, 2));
        let header = ShaderHeader::new(kinds(Float32, Unorm16), DepthMap::IDENTITY, &layout);
        let mut words = [0u32; 12];
        words[..3].copy_from_slice(&[0.0f32.to_bits(), 1.0f32.to_bits(), 0.5f32.to_bits()]);
        header.convert_words(&mut words);
        assert_eq!(&words[8..10], [0xFFFF_0000, 0x0000_8000]);
        let layout = scratch_layout([(extent(3, 1), 1)], kinds(Unorm16, Float32)).unwrap();
        assert_eq!((layout.blocks, layout.in_quad, layout.out_quad), (1, 0, 1));
        let header = ShaderHeader::new(kinds(Unorm16, Float32), DepthMap::IDENTITY, &layout);
        let mut words = [0u32; 12];
        words[..2].copy_from_slice(&[0xFFFF_0000, 0x0000_8000]);
        header.convert_words(&mut words);
        let floats: Vec<f32> = words[4..].iter().map(|&w| f32::from_bits(w)).collect();
        assert_eq!(floats[..3], [0.0, 1.0, 32768.0 / 65535.0]);
    }

    #[test]
    fn unrestricted_float_depth_converts_without_the_unit_clamp() {
        // A device that enabled VK_EXT_depth_range_unrestricted: reversed values outside
        // [0, 1] (a clear to 2.0 stores -1.0, a viewport [0, 1.5] stores down to -0.5) come
        // back as the application wrote them; elsewhere the clamp stays.
        let kinds = TexelKinds::same(TexelKind::Float32);
        let layout = scratch_layout([(extent(4, 1), 1)], kinds).unwrap();
        let map = DepthMap::to_standard(Reversal::Complementary);
        let unclamped = ShaderHeader::new(kinds, map.unrestricted(true), &layout);
        let clamped = ShaderHeader::new(kinds, map.unrestricted(false), &layout);
        assert!(!unclamped.specialization.clamp && clamped.specialization.clamp);
        for (stored, standard) in [(-1.0f32, 2.0f32), (-0.5, 1.5), (1.25, -0.25), (0.25, 0.75)] {
            let x = stored.to_bits();
            assert_eq!(f32::from_bits(unclamped.convert_texel(x)), standard);
            assert_eq!(
                f32::from_bits(clamped.convert_texel(x)),
                standard.clamp(0.0, 1.0)
            );
        }
        assert_eq!(map.unrestricted(true).apply(-1.0), 2.0);
        assert_eq!(map.apply(-1.0), 1.0);
    }

    #[test]
    fn each_specialization_has_its_own_index() {
        use TexelKind::{Float32, Unorm16, Unorm24};
        let mut seen = std::collections::HashSet::new();
        for source in [Unorm16, Unorm24, Float32] {
            for destination in [Unorm16, Unorm24, Float32] {
                for (complement, clamp) in
                    [(false, false), (false, true), (true, false), (true, true)]
                {
                    let specialization = Specialization {
                        kinds: kinds(source, destination),
                        complement,
                        clamp,
                    };
                    assert!(specialization.index() < Specialization::COUNT);
                    assert!(seen.insert(specialization.index()));
                    assert_eq!(
                        specialization.constants(),
                        [
                            source.shader_kind(),
                            destination.shader_kind(),
                            u32::from(complement),
                            u32::from(clamp)
                        ]
                    );
                }
            }
        }
    }

    #[test]
    fn headers_are_laid_out_as_the_shader_reads_them() {
        let header = ShaderHeader {
            blocks: 7,
            in_quad: 3,
            out_quad: 9,
            mask: 0,
            c0: 1.0,
            c1: -1.0,
            t: 0.5,
            c2: 2.0,
            specialization: Specialization {
                kinds: TexelKinds::same(TexelKind::Float32),
                complement: false,
                clamp: true,
            },
        };
        let bytes = header.to_bytes();
        let word = |i: usize| u32::from_ne_bytes(bytes[i * 4..i * 4 + 4].try_into().unwrap());
        assert_eq!([word(0), word(1), word(2), word(3)], [7, 3, 9, 0]);
        assert_eq!(f32::from_bits(word(4)), 1.0);
        assert_eq!(f32::from_bits(word(5)), -1.0);
        assert_eq!(f32::from_bits(word(6)), 0.5);
        assert_eq!(f32::from_bits(word(7)), 2.0);
    }

    #[test]
    fn wide_dispatches_use_a_second_dimension() {
        assert_eq!(workgroups(1), (1, 1));
        let per_group = BLOCKS_PER_INVOCATION * 64;
        assert_eq!(workgroups(per_group * 65535), (65535, 1));
        let (x, y) = workgroups(u32::MAX);
        assert!(u64::from(x) * u64::from(y) * u64::from(per_group) >= u64::from(u32::MAX));
    }

    #[test]
    fn scratch_regions_start_on_whole_blocks_past_the_header() {
        let layout = scratch_layout(
            [(extent(3, 1), 1), (extent(2, 2), 1)],
            TexelKinds::same(TexelKind::Unorm16),
        )
        .unwrap();
        // In place: 3 texels (part of a block), then 4 from texel 8.
        assert_eq!(
            layout.regions,
            [
                ScratchRegion {
                    input: 32,
                    output: 32
                },
                ScratchRegion {
                    input: 48,
                    output: 48
                }
            ]
        );
        assert_eq!((layout.size, layout.blocks), (64, 2));
        // From float32 to UNORM16: the output after the input, at the same texels.
        let layout = scratch_layout(
            [(extent(3, 1), 1), (extent(2, 2), 1)],
            kinds(TexelKind::Float32, TexelKind::Unorm16),
        )
        .unwrap();
        assert_eq!(
            layout.regions,
            [
                ScratchRegion {
                    input: 32,
                    output: 96
                },
                ScratchRegion {
                    input: 64,
                    output: 112
                }
            ]
        );
        assert_eq!((layout.size, layout.blocks, layout.out_quad), (128, 2, 4));
    }

    fn layers(aspect: vk::ImageAspectFlags, count: u32) -> vk::ImageSubresourceLayers {
        vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: count,
        }
    }

    #[test]
    fn buffer_copies_split_depth_from_stencil_regions() {
        let region = |aspect, offset| vk::BufferImageCopy {
            buffer_offset: offset,
            buffer_row_length: 8,
            buffer_image_height: 0,
            image_subresource: layers(aspect, 1),
            image_offset: vk::Offset3D { x: 1, y: 2, z: 0 },
            image_extent: extent(4, 2),
        };
        let regions = [
            region(vk::ImageAspectFlags::STENCIL, 0),
            region(vk::ImageAspectFlags::DEPTH, 256),
        ];
        let f32 = TexelKind::Float32;
        let plan = plan_buffer_copy(&regions, f32, f32, true).unwrap();
        assert_eq!(plan.rest, [0]);
        assert_eq!(plan.image_regions.len(), 1);
        let packed = plan.image_regions[0];
        assert_eq!(
            (
                packed.buffer_offset,
                packed.buffer_row_length,
                packed.image_offset.x
            ),
            (HEADER_BYTES, 0, 1)
        );
        // Two rows of 16 bytes, the application's 32 bytes apart.
        let copies: Vec<_> = plan
            .buffer_copies
            .iter()
            .map(|c| (c.src_offset, c.dst_offset, c.size))
            .collect();
        assert_eq!(copies, [(32, 256, 16), (48, 288, 16)]);
        assert!(plan_buffer_copy(&regions[..1], f32, f32, true).is_none());
        let remaining = vk::BufferImageCopy {
            image_subresource: layers(vk::ImageAspectFlags::DEPTH, vk::REMAINING_ARRAY_LAYERS),
            ..regions[1]
        };
        assert!(plan_buffer_copy(&[remaining], f32, f32, true).is_none());
        // A promoted image read into D16 bytes: the image's float32 words in, the
        // application's 8-byte rows out after them.
        let plan = plan_buffer_copy(&regions, f32, TexelKind::Unorm16, true).unwrap();
        assert_eq!(plan.image_regions[0].buffer_offset, HEADER_BYTES);
        let copies: Vec<_> = plan
            .buffer_copies
            .iter()
            .map(|c| (c.src_offset, c.dst_offset, c.size))
            .collect();
        assert_eq!(copies, [(64, 256, 8), (72, 272, 8)]);
        // And written from D16 bytes: the buffer's rows in, the float32 words out.
        let plan = plan_buffer_copy(&regions, f32, TexelKind::Unorm16, false).unwrap();
        assert_eq!(plan.image_regions[0].buffer_offset, HEADER_BYTES + 16);
        let copies: Vec<_> = plan
            .buffer_copies
            .iter()
            .map(|c| (c.src_offset, c.dst_offset, c.size))
            .collect();
        assert_eq!(copies, [(256, 32, 8), (272, 40, 8)]);
    }

    #[test]
    fn copies_between_3d_and_2d_array_images_cover_slices_and_layers_alike() {
        // VK_KHR_maintenance1: the region's depth counts the 2D side's layers; that side's
        // own copy is one deep, the 3D side's as deep as the region.
        let depth = vk::ImageAspectFlags::DEPTH;
        let slab = vk::Extent3D {
            width: 4,
            height: 2,
            depth: 3,
        };
        let kinds = TexelKinds::same(TexelKind::Float32);
        let three_to_two = vk::ImageCopy {
            src_subresource: layers(depth, 1),
            src_offset: vk::Offset3D { x: 0, y: 0, z: 2 },
            dst_subresource: layers(depth, 3),
            dst_offset: vk::Offset3D::default(),
            extent: slab,
        };
        let plan = plan_image_copy(&[three_to_two], kinds).unwrap();
        assert_eq!(plan.layout.blocks, 4 * 2 * 3 / 8);
        let (from, to) = (plan.from_source[0], plan.to_destination[0]);
        assert_eq!(
            (from.image_extent, from.image_subresource.layer_count),
            (slab, 1)
        );
        assert_eq!(from.image_offset.z, 2);
        assert_eq!(
            (to.image_extent, to.image_subresource.layer_count),
            (vk::Extent3D { depth: 1, ..slab }, 3)
        );
        let two_to_three = vk::ImageCopy {
            src_subresource: layers(depth, 3),
            dst_subresource: layers(depth, 1),
            ..three_to_two
        };
        let plan = plan_image_copy(&[two_to_three], kinds).unwrap();
        assert_eq!(plan.layout.blocks, 4 * 2 * 3 / 8);
        let (from, to) = (plan.from_source[0], plan.to_destination[0]);
        assert_eq!(from.image_extent.depth, 1);
        assert_eq!(
            (to.image_extent, to.image_subresource.layer_count),
            (slab, 1)
        );
        // 3D to 3D: both sides as deep as the region, one layer each.
        let three_to_three = vk::ImageCopy {
            dst_subresource: layers(depth, 1),
            ..three_to_two
        };
        let plan = plan_image_copy(&[three_to_three], kinds).unwrap();
        assert_eq!(plan.layout.blocks, 4 * 2 * 3 / 8);
        assert_eq!(plan.to_destination[0].image_extent, slab);
    }

    #[test]
    fn image_copies_convert_depth_and_leave_stencil_to_the_application_s_copy() {
        let both = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
        let region = |aspect| vk::ImageCopy {
            src_subresource: layers(aspect, 2),
            src_offset: vk::Offset3D::default(),
            dst_subresource: vk::ImageSubresourceLayers {
                base_array_layer: 3,
                ..layers(aspect, 2)
            },
            dst_offset: vk::Offset3D { x: 5, y: 0, z: 0 },
            extent: extent(4, 4),
        };
        let regions = [region(both), region(vk::ImageAspectFlags::STENCIL)];
        let d24 = TexelKinds::same(TexelKind::Unorm24);
        let plan = plan_image_copy(&regions, d24).unwrap();
        assert_eq!(
            plan.rest,
            [
                (0, vk::ImageAspectFlags::STENCIL),
                (1, vk::ImageAspectFlags::STENCIL)
            ]
        );
        assert_eq!(plan.layout.blocks, 4 * 4 * 2 / 8);
        let (from, to) = (plan.from_source[0], plan.to_destination[0]);
        assert_eq!(
            from.image_subresource.aspect_mask,
            vk::ImageAspectFlags::DEPTH
        );
        assert_eq!(to.image_subresource.base_array_layer, 3);
        assert_eq!((from.buffer_offset, to.buffer_offset), (32, 32));
        assert_eq!(to.image_offset.x, 5);
        assert!(plan_image_copy(&regions[1..], d24).is_none());
        // Between a promoted image and one that kept D24: the depth goes through the scratch
        // buffer, converted, and so does the stencil (it could not go down between two
        // formats): past the converted texels (header 32, 2 x 16 float texels in, as many
        // D24 words out), 1 byte a texel, each region on 4 bytes; drained before the depth.
        let apart = kinds(TexelKind::Float32, TexelKind::Unorm24);
        let plan = plan_image_copy(&regions, apart).unwrap();
        assert!(plan.rest.is_empty(), "{:?}", plan.rest);
        let stencil_start = 32 + 2 * 32 * 4;
        let aspects = |copies: &[vk::BufferImageCopy]| -> Vec<(vk::ImageAspectFlags, u64)> {
            copies
                .iter()
                .map(|c| (c.image_subresource.aspect_mask, c.buffer_offset))
                .collect()
        };
        let (d, st) = (vk::ImageAspectFlags::DEPTH, vk::ImageAspectFlags::STENCIL);
        assert_eq!(
            aspects(&plan.from_source),
            [(d, 32), (st, stencil_start), (st, stencil_start + 32)]
        );
        assert_eq!(
            aspects(&plan.to_destination),
            [
                (st, stencil_start),
                (st, stencil_start + 32),
                (d, 32 + 32 * 4)
            ]
        );
        assert_eq!(plan.to_destination[0].image_subresource.base_array_layer, 3);
        assert_eq!(plan.layout.size, stencil_start + 64);
        let depth_only = [region(vk::ImageAspectFlags::DEPTH)];
        let plan = plan_image_copy(&depth_only, apart).unwrap();
        assert!(plan.rest.is_empty());
        assert_eq!(
            (
                plan.from_source[0].buffer_offset,
                plan.to_destination[0].buffer_offset
            ),
            (32, 32 + 32 * 4)
        );
    }

    #[test]
    fn blits_read_their_converted_box_from_a_staged_image_mirrors_kept() {
        let offset = |x, y, z| vk::Offset3D { x, y, z };
        let region = vk::ImageBlit {
            src_subresource: layers(vk::ImageAspectFlags::DEPTH, 2),
            // Mirrored in x: from (10, 2) to (4, 8).
            src_offsets: [offset(10, 2, 0), offset(4, 8, 1)],
            dst_subresource: layers(vk::ImageAspectFlags::DEPTH, 2),
            dst_offsets: [offset(0, 0, 0), offset(12, 12, 1)],
        };
        let f32 = TexelKinds::same(TexelKind::Float32);
        let plan = plan_blit(&[region], f32, false).unwrap();
        assert!(plan.rest.is_empty());
        assert_eq!(
            (plan.staged_extent.width, plan.staged_extent.height),
            (6, 6)
        );
        assert_eq!(plan.staged_layers, 2);
        assert_eq!(plan.from_source[0].image_offset.x, 4);
        assert_eq!(plan.to_staged[0].image_offset.x, 0);
        assert_eq!(plan.blits[0].src_offsets[0].x, 6);
        assert_eq!(plan.blits[0].src_offsets[1].x, 0);
        assert_eq!(plan.blits[0].dst_offsets[1].x, 12);
        assert_eq!(plan.layout.blocks, 6 * 6 * 2 / 8);
        let empty = vk::ImageBlit {
            src_offsets: [offset(3, 3, 0), offset(3, 9, 1)],
            ..region
        };
        assert!(plan_blit(&[empty], f32, false).is_none());
        // Into an image of another format: staged in its format.
        let apart = kinds(TexelKind::Float32, TexelKind::Unorm16);
        let plan = plan_blit(&[region], apart, false).unwrap();
        assert_eq!(plan.to_staged[0].buffer_offset, 32 + 6 * 6 * 2 * 4);
        // The stencil between two formats (D32_S8 storage, a D24_S8 image that kept its
        // format) cannot go down as the application's blit: revz stages it and blits both
        // aspects itself, a stencil-only region too, leaving nothing to the application.
        let both_aspects = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
        let both = vk::ImageBlit {
            src_subresource: layers(both_aspects, 2),
            dst_subresource: layers(both_aspects, 2),
            ..region
        };
        let stencil_only = vk::ImageBlit {
            src_subresource: layers(vk::ImageAspectFlags::STENCIL, 2),
            dst_subresource: layers(vk::ImageAspectFlags::STENCIL, 2),
            ..region
        };
        let d24 = kinds(TexelKind::Float32, TexelKind::Unorm24);
        let plan = plan_blit(&[both, stencil_only], d24, false).unwrap();
        assert!(plan.rest.is_empty(), "{:?}", plan.rest);
        let blitted: Vec<_> = plan
            .blits
            .iter()
            .map(|b| (b.src_subresource.aspect_mask, b.dst_subresource.aspect_mask))
            .collect();
        assert_eq!(
            blitted,
            [
                (both_aspects, both_aspects),
                (vk::ImageAspectFlags::STENCIL, vk::ImageAspectFlags::STENCIL)
            ]
        );
        // Depth fills for the one region naming depth, stencil fills for both; the stencil
        // drains first, into each region's own layers.
        let aspects = |copies: &[vk::BufferImageCopy]| -> Vec<vk::ImageAspectFlags> {
            copies
                .iter()
                .map(|c| c.image_subresource.aspect_mask)
                .collect()
        };
        let (d, s) = (vk::ImageAspectFlags::DEPTH, vk::ImageAspectFlags::STENCIL);
        assert_eq!(aspects(&plan.from_source), [d, s, s]);
        assert_eq!(aspects(&plan.to_staged), [s, s, d]);
        assert_eq!(plan.to_staged[1].image_subresource.base_array_layer, 2);
        assert_eq!(plan.blits[1].src_subresource.base_array_layer, 2);
        assert_eq!(plan.staged_layers, 4);
        // Between one format, a stencil-only region is the application's.
        let same = TexelKinds::same(TexelKind::Unorm24);
        let plan = plan_blit(&[both, stencil_only], same, false).unwrap();
        assert_eq!(plan.rest, [(0, s), (1, s)]);
    }

    /// A 3D source's boxes several slices deep are staged in a 3D image, one region after the
    /// other in depth (a 2D image's layers cannot take a deep box in one copy); a box one slice
    /// deep keeps the 2D staged image.
    #[test]
    fn deep_boxes_of_a_3d_source_are_staged_in_a_3d_image() {
        let offset = |x, y, z| vk::Offset3D { x, y, z };
        let deep = vk::ImageBlit {
            src_subresource: layers(vk::ImageAspectFlags::DEPTH, 1),
            // Mirrored in x, slices 1 to 3 of the source.
            src_offsets: [offset(8, 0, 1), offset(0, 4, 4)],
            dst_subresource: layers(vk::ImageAspectFlags::DEPTH, 1),
            dst_offsets: [offset(0, 0, 0), offset(8, 4, 3)],
        };
        let thin = vk::ImageBlit {
            src_offsets: [offset(0, 0, 5), offset(2, 2, 6)],
            dst_offsets: [offset(0, 0, 3), offset(2, 2, 4)],
            ..deep
        };
        let f32 = TexelKinds::same(TexelKind::Float32);
        let plan = plan_blit(&[deep, thin], f32, false).unwrap();
        assert_eq!(plan.staged_type(), vk::ImageType::TYPE_3D);
        assert_eq!(plan.staged_layers, 1);
        assert_eq!(
            (
                plan.staged_extent.width,
                plan.staged_extent.height,
                plan.staged_extent.depth
            ),
            (8, 4, 4)
        );
        // Region 0 in slices 0..3, region 1 in slice 3.
        assert_eq!(plan.from_source[0].image_offset, offset(0, 0, 1));
        assert_eq!(plan.from_source[0].image_extent.depth, 3);
        assert_eq!(plan.to_staged[0].image_offset, offset(0, 0, 0));
        assert_eq!(plan.to_staged[1].image_offset, offset(0, 0, 3));
        assert_eq!(plan.to_staged[1].image_subresource.layer_count, 1);
        assert_eq!(
            plan.blits[0].src_offsets,
            [offset(8, 0, 0), offset(0, 4, 3)]
        );
        assert_eq!(
            plan.blits[1].src_offsets,
            [offset(0, 0, 3), offset(2, 2, 4)]
        );
        assert_eq!(plan.blits[1].dst_offsets, thin.dst_offsets);
        // 96 texels, then 4 on a block of their own.
        assert_eq!(plan.layout.blocks, 8 * 4 * 3 / TEXELS_PER_BLOCK as u32 + 1);
        // Alone, a box one slice deep keeps the 2D staged image.
        let plan = plan_blit(&[thin], f32, false).unwrap();
        assert_eq!(plan.staged_type(), vk::ImageType::TYPE_2D);
        assert_eq!(plan.to_staged[0].image_offset, offset(0, 0, 0));
        assert_eq!(
            plan.blits[0].src_offsets,
            [offset(0, 0, 0), offset(2, 2, 1)]
        );
        // A deep box cannot come from several layers (a 3D image has one).
        let layered = vk::ImageBlit {
            src_subresource: layers(vk::ImageAspectFlags::DEPTH, 2),
            ..deep
        };
        assert!(plan_blit(&[layered], f32, false).is_none());
    }

    /// The stencil alone between two formats (a D24_S8 image that kept its format, one stored
    /// as D32_S8) goes through the scratch with nothing to convert: copies drain it into the
    /// destination, blits stage it and blit it themselves; between one format it is the
    /// application's (no plan).
    #[test]
    fn stencil_alone_between_two_formats_goes_through_the_scratch() {
        let stencil = vk::ImageAspectFlags::STENCIL;
        let apart = kinds(TexelKind::Unorm24, TexelKind::Float32);
        let copy = vk::ImageCopy {
            src_subresource: layers(stencil, 1),
            src_offset: vk::Offset3D::default(),
            dst_subresource: layers(stencil, 1),
            dst_offset: vk::Offset3D { x: 2, y: 0, z: 0 },
            extent: extent(3, 2),
        };
        let plan = plan_image_copy(&[copy], apart).unwrap();
        assert_eq!(plan.layout.blocks, 0);
        assert!(plan.rest.is_empty());
        assert_eq!(plan.from_source.len(), 1);
        assert_eq!(plan.from_source[0].image_subresource.aspect_mask, stencil);
        assert_eq!(plan.to_destination[0].image_offset.x, 2);
        assert!(plan_image_copy(&[copy], TexelKinds::same(TexelKind::Unorm24)).is_none());
        let offset = |x, y, z| vk::Offset3D { x, y, z };
        let blit = vk::ImageBlit {
            src_subresource: layers(stencil, 1),
            src_offsets: [offset(0, 0, 0), offset(4, 4, 1)],
            dst_subresource: layers(stencil, 1),
            dst_offsets: [offset(0, 0, 0), offset(2, 2, 1)],
        };
        let plan = plan_blit(&[blit], apart, true).unwrap();
        // Its place in the scratch is converted for nothing: no depth is filled or drained.
        assert_eq!(plan.from_source.len(), 1);
        assert_eq!(plan.from_source[0].image_subresource.aspect_mask, stencil);
        assert!(plan.rest.is_empty());
        assert_eq!(plan.blits[0].dst_subresource.aspect_mask, stencil);
        assert_eq!(plan.to_staged.len(), 1);
        assert_eq!(plan.to_staged[0].image_subresource.aspect_mask, stencil);
        assert!(plan_blit(&[blit], TexelKinds::same(TexelKind::Unorm24), true).is_none());
    }

    #[test]
    fn remaining_array_layers_count_to_the_last_layer() {
        let remaining = vk::ImageSubresourceLayers {
            base_array_layer: 2,
            ..layers(vk::ImageAspectFlags::DEPTH, vk::REMAINING_ARRAY_LAYERS)
        };
        assert_eq!(explicit_layers(remaining, Some(6)).layer_count, 4);
        assert_eq!(explicit_layers(remaining, Some(6)).base_array_layer, 2);
        // Unknown image: left, for the plans to refuse.
        assert_eq!(
            explicit_layers(remaining, None).layer_count,
            vk::REMAINING_ARRAY_LAYERS
        );
        let explicit = layers(vk::ImageAspectFlags::DEPTH, 3);
        assert_eq!(explicit_layers(explicit, Some(6)).layer_count, 3);
    }

    /// With the stencil staged, each box's stencil goes from the source into the scratch past
    /// the converted texels (4-byte offsets, 1 byte a texel) and into the staged image before
    /// the depth; the blits and what is left to the application are unchanged.
    #[test]
    fn a_staged_stencil_follows_each_box_into_the_staged_image_first() {
        let offset = |x, y, z| vk::Offset3D { x, y, z };
        let region = vk::ImageBlit {
            src_subresource: layers(
                vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
                1,
            ),
            src_offsets: [offset(0, 0, 0), offset(5, 3, 1)],
            dst_subresource: layers(
                vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
                1,
            ),
            dst_offsets: [offset(0, 0, 0), offset(10, 6, 1)],
        };
        let kinds = TexelKinds::same(TexelKind::Unorm24);
        let plain = plan_blit(&[region], kinds, false).unwrap();
        let staged = plan_blit(&[region], kinds, true).unwrap();
        assert_eq!(format!("{:?}", staged.blits), format!("{:?}", plain.blits));
        assert_eq!(staged.rest, plain.rest);
        assert_eq!(staged.from_source.len(), 2);
        let stencil = vk::ImageAspectFlags::STENCIL;
        let (fill, drain) = (staged.from_source[1], staged.to_staged[0]);
        assert_eq!(fill.image_subresource.aspect_mask, stencil);
        assert_eq!(drain.image_subresource.aspect_mask, stencil);
        assert_eq!(fill.buffer_offset, plain.layout.size.next_multiple_of(4));
        assert_eq!(drain.buffer_offset, fill.buffer_offset);
        assert_eq!(fill.image_extent, plain.from_source[0].image_extent);
        assert_eq!(
            format!("{:?}", staged.to_staged[1]),
            format!("{:?}", plain.to_staged[0])
        );
        assert_eq!(
            staged.layout.size,
            fill.buffer_offset + (5 * 3u64).next_multiple_of(4)
        );
    }

    /// Every byte the application's copy would write is written once, nothing else (padding
    /// rows and images stay untouched), and each lands on its tight scratch position.
    #[test]
    fn row_copies_cover_exactly_the_regions_bytes() {
        let cases = [
            (0, 0, extent(5, 3), 1),
            (7, 0, extent(5, 3), 1),
            (0, 4, extent(5, 3), 2),
            (6, 5, extent(4, 2), 3),
        ];
        for kind in [TexelKind::Unorm16, TexelKind::Float32] {
            for (row_length, image_height, extent, layers) in cases {
                let region = BufferRegion {
                    offset: 100,
                    row_length,
                    image_height,
                    extent,
                    layers,
                };
                let mut copies = Vec::new();
                row_copies(region, HEADER_BYTES, kind, true, &mut copies);
                let t = kind.bytes();
                let rl = u64::from(if row_length == 0 {
                    extent.width
                } else {
                    row_length
                });
                let ih = u64::from(if image_height == 0 {
                    extent.height
                } else {
                    image_height
                });
                let mut expected = Vec::new();
                for layer in 0..u64::from(layers) {
                    for y in 0..u64::from(extent.height) {
                        for x in 0..u64::from(extent.width) {
                            let app = 100 + ((layer * ih + y) * rl + x) * t;
                            let tight = HEADER_BYTES
                                + ((layer * u64::from(extent.height) + y)
                                    * u64::from(extent.width)
                                    + x)
                                    * t;
                            for b in 0..t {
                                expected.push((tight + b, app + b));
                            }
                        }
                    }
                }
                let mut got: Vec<_> = copies
                    .iter()
                    .flat_map(|c| (0..c.size).map(move |b| (c.src_offset + b, c.dst_offset + b)))
                    .collect();
                got.sort_unstable();
                expected.sort_unstable();
                assert_eq!(
                    got, expected,
                    "{kind:?} {row_length} {image_height} {layers}"
                );
            }
        }
    }
}
