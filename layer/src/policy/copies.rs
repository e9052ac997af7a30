//! Transfers touching a reversed depth image (copies and blits): whether their depth values
//! are converted, and which way ([`CopyFacts::decide`] into a [`CopyDecision`]), or why one
//! that should be is not ([`Unconverted`]); and which texels a conversion reads and writes
//! ([`conversion_kinds`]); what each image end of a copy is ([`image_copy_end`],
//! [`copied_texels`], [`single_sampled`]).

use std::fmt;

use ash::vk;

use crate::command_state::Target;
use crate::depth_copy::plan::{TexelKind, TexelKinds};

/// Which end of a copy an image is: reversed where revz knows it (`effective`: `None` where it
/// does not) and its depth is reversed after the application's convention
/// (`crate::policy::Observed::effective` of `crate::policy::ImageDepth::target`); native
/// otherwise, unknown images included.
pub fn image_copy_end(effective: Option<Target>) -> CopyEnd {
    match effective {
        Some(Target::Reversed) => CopyEnd::Reversed,
        Some(Target::Native | Target::None) | None => CopyEnd::Native,
    }
}

/// The kind of depth texel a copy of an image of `format` reads or writes: that of the format
/// revz created it in, the float one (`promoted`) where it was promoted. `None`: no depth
/// aspect revz knows.
pub fn copied_texels(format: vk::Format, promoted: Option<vk::Format>) -> Option<TexelKind> {
    TexelKind::of(promoted.unwrap_or(format))
}

/// Whether an image of `samples` (`None`: an image revz does not know) has one sample per
/// texel. Unknown images count as single-sampled: revz converts only copies with a reversed
/// end, which it knows.
pub fn single_sampled(samples: Option<vk::SampleCountFlags>) -> bool {
    samples.is_none_or(|samples| samples == vk::SampleCountFlags::TYPE_1)
}

/// One end of a copy, blit or resolve, as [`CopyFacts`] sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyEnd {
    /// A buffer: the application's bytes, in standard depth.
    Buffer,
    /// A depth image revz stores reversed (and the application renders standard depth).
    Reversed,
    /// Any other image: native depth, or not a depth image.
    Native,
}

/// The direction a copy's depth values are converted in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyDirection {
    /// Reversed values leave revz: the application receives the standard ones.
    ToStandard,
    /// Standard values enter a reversed image: revz stores them reversed.
    ToReversed,
    /// The values keep their convention; only their format changes (a promoted image's
    /// float32 to or from the application's UNORM format).
    Keep,
    /// Between two reversed images of different maps (infinite mode: one stores complementary
    /// depth, `crate::policy::DevicePolicy::stores_complementary`): the values leave the
    /// source's map for the destination's.
    Remap,
}

/// Why a copy that should be converted is not (its values keep the source's convention;
/// logged once per reason).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unconverted {
    /// The command buffer's queue family lacks graphics or compute (the conversion is a
    /// dispatch, and copies into a depth aspect need graphics), or its pool is protected.
    NoCompute,
    /// The application bound compute descriptors revz cannot bind again after its dispatch
    /// (a bind whose layout is given in its `pNext` chain, pushed descriptors of a type revz
    /// does not copy, more than 16 binds that do not replace each other:
    /// `crate::depth_copy::compute_bindings`).
    ComputeBindings,
    /// The command or a region carries an extension structure revz does not know.
    Extended,
    /// A multisampled image: copies through a buffer cannot carry its samples.
    Multisampled,
    /// Conditional rendering is active: it could discard revz's dispatch and not the copies.
    Conditional,
    /// Its regions: an empty blit box, more texels than one conversion holds, or a layer count
    /// of `VK_REMAINING_ARRAY_LAYERS` of an image revz does not know.
    Regions,
    /// Too many texels for one conversion (past the device's `maxStorageBufferRange`), or
    /// revz could not create its conversion pipeline or scratch memory.
    Resources,
}

impl fmt::Display for Unconverted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unconverted::NoCompute => {
                "its command buffer's queue family lacks graphics or compute, or its pool is \
                 protected"
            }
            Unconverted::ComputeBindings => {
                "compute descriptors were bound in a way revz cannot restore after its \
                 dispatch (a layout given in a pNext chain, pushed descriptors of a type revz \
                 does not copy, or too many binds)"
            }
            Unconverted::Extended => "it carries an extension structure revz does not know",
            Unconverted::Multisampled => {
                "an image is multisampled (a conversion goes through a buffer)"
            }
            Unconverted::Conditional => {
                "conditional rendering is active (it could discard revz's dispatch)"
            }
            Unconverted::Regions => {
                "of its regions (VK_REMAINING_ARRAY_LAYERS, an empty blit box, or too many \
                 texels)"
            }
            Unconverted::Resources => {
                "revz could not get the scratch memory, staged image or pipeline for it (or it \
                 exceeds maxStorageBufferRange)"
            }
        })
    }
}

/// What decides whether a transfer's depth values are converted, gathered at its recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CopyFacts {
    pub source: CopyEnd,
    pub destination: CopyEnd,
    /// The transfer touches the depth aspect (stencil is never converted).
    pub depth_aspect: bool,
    /// The transfer moves stencil between two images stored in different formats (one
    /// promoted): it cannot go down as it is, and goes through revz's scratch as it is, with
    /// the depth or alone.
    pub stencil_apart: bool,
    /// The depth texels change format on the way: one end is a promoted image (float32
    /// storage) and the other holds the application's UNORM format (a buffer, or an image
    /// that kept it). Such a copy is converted whatever the conventions and `copy_values`:
    /// sent down as it is, it would hand over or take in bytes of the wrong format.
    pub repack: bool,
    /// The `copy_values` setting.
    pub values: crate::config::CopyValues,
    /// The command buffer's queue family can dispatch compute.
    pub dispatchable: bool,
    /// revz can bind the application's compute state again after its dispatch.
    pub restorable: bool,
    /// The command or one of its regions has a `pNext` chain.
    pub extended: bool,
    /// One of its images is multisampled (image copies and blits).
    pub multisampled: bool,
    /// Conditional rendering is active where it is recorded.
    pub conditional: bool,
    /// Both ends are reversed images whose maps differ ([`CopyDirection::Remap`]).
    pub remaps: bool,
}

/// The decision for one transfer touching a reversed or promoted depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyDecision {
    /// Nothing to convert: no depth aspect, or one format at both ends and no reversed end,
    /// both ends reversed, or `copy_values = stored`.
    Unchanged,
    Convert(CopyDirection),
    /// It should be converted and cannot be: it goes down as it is.
    Unconverted(Unconverted),
}

impl CopyFacts {
    /// Values change convention exactly where one end is reversed and the other is not:
    /// out of a reversed image into a buffer or a native image they become standard, into a
    /// reversed image from a buffer or a native image they become reversed (unless
    /// `copy_values = stored`). Their format changes wherever the texels do ([`Self::repack`]).
    pub fn decide(&self) -> CopyDecision {
        use crate::config::CopyValues;
        let direction = match (self.source, self.destination) {
            _ if self.values == CopyValues::Stored => None,
            (CopyEnd::Reversed, CopyEnd::Reversed) if self.remaps => Some(CopyDirection::Remap),
            (CopyEnd::Reversed, CopyEnd::Reversed) => None,
            (CopyEnd::Reversed, _) => Some(CopyDirection::ToStandard),
            (_, CopyEnd::Reversed) => Some(CopyDirection::ToReversed),
            _ => None,
        };
        let direction = match direction {
            Some(direction) => direction,
            None if self.repack => CopyDirection::Keep,
            None => return CopyDecision::Unchanged,
        };
        if !self.depth_aspect && !self.stencil_apart {
            return CopyDecision::Unchanged;
        }
        let refused = if self.extended {
            Some(Unconverted::Extended)
        } else if self.multisampled {
            Some(Unconverted::Multisampled)
        } else if self.conditional {
            Some(Unconverted::Conditional)
        } else if !self.dispatchable {
            Some(Unconverted::NoCompute)
        } else if !self.restorable {
            Some(Unconverted::ComputeBindings)
        } else {
            None
        };
        match refused {
            Some(why) => CopyDecision::Unconverted(why),
            None => CopyDecision::Convert(direction),
        }
    }
}

/// How one end of a converted copy holds its depth texels, for [`conversion_kinds`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Texels {
    /// A buffer: texels of the application's format (the image's as it created it, not the
    /// float one revz stores a promoted image in); `None`: no depth aspect revz knows.
    Buffer(Option<TexelKind>),
    /// An image whose depth has this kind in the format revz created it in (the float one of
    /// a promoted image); `None`: no depth aspect revz knows.
    Image(Option<TexelKind>),
}

impl Texels {
    fn kind(self) -> Option<TexelKind> {
        match self {
            Texels::Buffer(kind) | Texels::Image(kind) => kind,
        }
    }
}

/// The texel kinds a copy's conversion reads and writes: each end's own (a buffer's is the
/// application's format, an image's the one revz stores it in), so that a promoted image's
/// float32 is packed into or read from the application's UNORM bytes in the same pass that
/// converts the values. Between two images of different formats the depth goes through the
/// scratch buffer and a blit through a staged image of the destination's format. `None`: an
/// end whose depth revz does not know, or two buffers (`Unconverted::Regions`).
pub fn conversion_kinds(source: Texels, destination: Texels) -> Option<TexelKinds> {
    if matches!(
        (source, destination),
        (Texels::Buffer(_), Texels::Buffer(_))
    ) {
        return None;
    }
    Some(TexelKinds {
        source: source.kind()?,
        destination: destination.kind()?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_end_is_reversed_only_where_it_is_after_the_convention() {
        assert_eq!(image_copy_end(Some(Target::Reversed)), CopyEnd::Reversed);
        assert_eq!(image_copy_end(Some(Target::Native)), CopyEnd::Native);
        assert_eq!(image_copy_end(Some(Target::None)), CopyEnd::Native);
        assert_eq!(image_copy_end(None), CopyEnd::Native);
    }

    #[test]
    fn a_copy_reads_the_texels_of_the_promoted_format_where_there_is_one() {
        let d16 = TexelKind::of(vk::Format::D16_UNORM);
        let d32 = TexelKind::of(vk::Format::D32_SFLOAT);
        assert!(d16.is_some() && d16 != d32);
        assert_eq!(copied_texels(vk::Format::D16_UNORM, None), d16);
        assert_eq!(
            copied_texels(vk::Format::D16_UNORM, Some(vk::Format::D32_SFLOAT)),
            d32
        );
        assert_eq!(copied_texels(vk::Format::R8G8B8A8_UNORM, None), None);
    }

    #[test]
    fn unknown_images_count_as_single_sampled() {
        assert!(single_sampled(None));
        assert!(single_sampled(Some(vk::SampleCountFlags::TYPE_1)));
        assert!(!single_sampled(Some(vk::SampleCountFlags::TYPE_4)));
    }

    #[test]
    fn copies_convert_exactly_where_one_end_is_reversed() {
        use crate::config::CopyValues;
        let facts = |source, destination| CopyFacts {
            source,
            destination,
            depth_aspect: true,
            stencil_apart: false,
            repack: false,
            values: CopyValues::Standard,
            dispatchable: true,
            restorable: true,
            extended: false,
            multisampled: false,
            conditional: false,
            remaps: false,
        };
        use CopyEnd::{Buffer, Native, Reversed};
        let table = [
            (
                Reversed,
                Buffer,
                CopyDecision::Convert(CopyDirection::ToStandard),
            ),
            (
                Reversed,
                Native,
                CopyDecision::Convert(CopyDirection::ToStandard),
            ),
            (
                Buffer,
                Reversed,
                CopyDecision::Convert(CopyDirection::ToReversed),
            ),
            (
                Native,
                Reversed,
                CopyDecision::Convert(CopyDirection::ToReversed),
            ),
            (Reversed, Reversed, CopyDecision::Unchanged),
            (Native, Native, CopyDecision::Unchanged),
            (Native, Buffer, CopyDecision::Unchanged),
            (Buffer, Native, CopyDecision::Unchanged),
        ];
        for (source, destination, decision) in table {
            assert_eq!(
                facts(source, destination).decide(),
                decision,
                "{source:?} -> {destination:?}"
            );
        }
        // Two reversed images of different maps (infinite mode, one of complementary depth):
        // converted from one map to the other, unless the values are copied as stored.
        let remapped = CopyFacts {
            remaps: true,
            ..facts(Reversed, Reversed)
        };
        assert_eq!(
            remapped.decide(),
            CopyDecision::Convert(CopyDirection::Remap)
        );
        assert_eq!(
            CopyFacts {
                values: CopyValues::Stored,
                ..remapped
            }
            .decide(),
            CopyDecision::Unchanged
        );
        let out = facts(Reversed, Buffer);
        let stencil = CopyFacts {
            depth_aspect: false,
            ..out
        };
        assert_eq!(stencil.decide(), CopyDecision::Unchanged);
        // Stencil alone between a promoted image and one that kept its format: moved by revz.
        let stencil_apart = CopyFacts {
            depth_aspect: false,
            stencil_apart: true,
            repack: true,
            ..facts(Reversed, Reversed)
        };
        assert_eq!(
            stencil_apart.decide(),
            CopyDecision::Convert(CopyDirection::Keep)
        );
        let stored = CopyFacts {
            values: CopyValues::Stored,
            ..out
        };
        assert_eq!(stored.decide(), CopyDecision::Unchanged);
        let refusals = [
            (
                CopyFacts {
                    extended: true,
                    ..out
                },
                Unconverted::Extended,
            ),
            (
                CopyFacts {
                    multisampled: true,
                    ..out
                },
                Unconverted::Multisampled,
            ),
            (
                CopyFacts {
                    conditional: true,
                    ..out
                },
                Unconverted::Conditional,
            ),
            (
                CopyFacts {
                    dispatchable: false,
                    ..out
                },
                Unconverted::NoCompute,
            ),
            (
                CopyFacts {
                    restorable: false,
                    ..out
                },
                Unconverted::ComputeBindings,
            ),
        ];
        for (facts, why) in refusals {
            assert_eq!(facts.decide(), CopyDecision::Unconverted(why));
        }
    }

    #[test]
    fn a_promoted_end_repacks_whatever_the_conventions() {
        use crate::config::CopyValues;
        use CopyEnd::{Buffer, Native, Reversed};
        let facts = |source, destination, values| CopyFacts {
            source,
            destination,
            depth_aspect: true,
            stencil_apart: false,
            repack: true,
            values,
            dispatchable: true,
            restorable: true,
            extended: false,
            multisampled: false,
            conditional: false,
            remaps: false,
        };
        let keep = CopyDecision::Convert(CopyDirection::Keep);
        // A promoted native image read back, or written from a buffer: only the format.
        assert_eq!(facts(Native, Buffer, CopyValues::Standard).decide(), keep);
        assert_eq!(facts(Buffer, Native, CopyValues::Standard).decide(), keep);
        // Both reversed (a promoted image and one that kept its format), and stored values.
        assert_eq!(
            facts(Reversed, Reversed, CopyValues::Standard).decide(),
            keep
        );
        assert_eq!(facts(Reversed, Buffer, CopyValues::Stored).decide(), keep);
        // The convention changes too where one end is reversed.
        assert_eq!(
            facts(Reversed, Buffer, CopyValues::Standard).decide(),
            CopyDecision::Convert(CopyDirection::ToStandard)
        );
        // Stencil alone is laid out the same in both formats.
        let stencil = CopyFacts {
            depth_aspect: false,
            ..facts(Native, Buffer, CopyValues::Standard)
        };
        assert_eq!(stencil.decide(), CopyDecision::Unchanged);
        // A repack that cannot be recorded is refused like a conversion.
        let multisampled = CopyFacts {
            multisampled: true,
            ..facts(Native, Native, CopyValues::Standard)
        };
        assert_eq!(
            multisampled.decide(),
            CopyDecision::Unconverted(Unconverted::Multisampled)
        );
    }

    #[test]
    fn a_conversion_reads_each_end_s_own_texels() {
        use TexelKind::{Float32, Unorm16, Unorm24};
        use Texels::{Buffer, Image};
        let kinds = |source, destination| {
            Some(TexelKinds {
                source,
                destination,
            })
        };
        for kind in [Unorm16, Unorm24, Float32] {
            assert_eq!(
                conversion_kinds(Image(Some(kind)), Buffer(Some(kind))),
                Some(TexelKinds::same(kind))
            );
            assert_eq!(
                conversion_kinds(Image(Some(kind)), Image(Some(kind))),
                Some(TexelKinds::same(kind))
            );
            assert_eq!(conversion_kinds(Image(Some(kind)), Image(None)), None);
            assert_eq!(conversion_kinds(Image(None), Buffer(Some(kind))), None);
        }
        // A promoted image read into the application's D16 buffer, and written from D24 bytes.
        assert_eq!(
            conversion_kinds(Image(Some(Float32)), Buffer(Some(Unorm16))),
            kinds(Float32, Unorm16)
        );
        assert_eq!(
            conversion_kinds(Buffer(Some(Unorm24)), Image(Some(Float32))),
            kinds(Unorm24, Float32)
        );
        // A promoted image and one that kept its UNORM format.
        assert_eq!(
            conversion_kinds(Image(Some(Float32)), Image(Some(Unorm24))),
            kinds(Float32, Unorm24)
        );
        assert_eq!(
            conversion_kinds(Buffer(Some(Unorm16)), Buffer(Some(Unorm16))),
            None
        );
    }
}
