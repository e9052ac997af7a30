//! Graphics pipeline libraries (`VK_EXT_graphics_pipeline_library`), by the spec's rules:
//! which state subsets a create info defines itself ([`own_subsets`]), which of its dynamic
//! states count ([`subset_states`]: those of its own subsets), and which library's state a
//! link takes for each subset ([`inherit_libraries`]). `crate::hooks::pipeline` reads the
//! create info's chain and the libraries revz recorded, and applies these.

use std::sync::Arc;

use ash::vk;

use crate::command_state::{PipelineDepth, States};

/// The state subsets of a graphics pipeline.
pub type Subsets = vk::GraphicsPipelineLibraryFlagsEXT;

/// Every subset: what an ordinary pipeline defines.
pub const ALL_SUBSETS: Subsets = Subsets::from_raw(
    Subsets::VERTEX_INPUT_INTERFACE.as_raw()
        | Subsets::PRE_RASTERIZATION_SHADERS.as_raw()
        | Subsets::FRAGMENT_SHADER.as_raw()
        | Subsets::FRAGMENT_OUTPUT_INTERFACE.as_raw(),
);

/// The subsets a create info defines itself (not those of the libraries it links): those its
/// `VkGraphicsPipelineLibraryCreateInfoEXT` names (`named`), else none for a link of at least
/// one library (`links_libraries`) or a library (`is_library`), and all of them for an
/// ordinary pipeline. The two are asked only without named subsets, in that order.
#[must_use]
pub fn own_subsets(
    named: Option<Subsets>,
    links_libraries: impl FnOnce() -> bool,
    is_library: impl FnOnce() -> bool,
) -> Subsets {
    if let Some(named) = named {
        return named;
    }
    let links_libraries = links_libraries();
    if is_library() || links_libraries {
        Subsets::empty()
    } else {
        ALL_SUBSETS
    }
}

/// The depth-related states of `subsets`: a dynamic state listed by a create info that does
/// not define its subset is ignored (the spec's rule for libraries). Viewports, depth bias,
/// depth clip control, the depth clamp and its range are pre-rasterization state; the compare op and depth bounds fragment
/// shader state.
#[must_use]
pub fn subset_states(subsets: Subsets) -> States {
    let mut states = States::NONE;
    if subsets.contains(Subsets::PRE_RASTERIZATION_SHADERS) {
        states |= States::VIEWPORT | States::VIEWPORT_WITH_COUNT | States::BIAS;
        // Depth clip control and the clamp range are viewport state; the depth clamp
        // rasterization state.
        states |= States::CLIP_CONTROL | States::DEPTH_CLAMP | States::CLAMP_RANGE;
    }
    if subsets.contains(Subsets::FRAGMENT_SHADER) {
        states |= States::COMPARE_OP | States::BOUNDS;
    }
    states
}

/// A linked pipeline's (or a library's that links others) depth state: each subset's from
/// the library that defines it, with the dynamic states each library recorded for its own
/// subsets ([`subset_states`]); the linking pipeline defines those subsets from then on.
/// What every library says (module identifiers, promotion, dynamic states, an unreversed
/// fragment stage) adds up; pre-rasterization state (viewports, bias, clamp range, the precise path's
/// projection, range, store and layout) comes from the library that defines it, as does
/// fragment shader state (compare op, bounds).
pub fn inherit_libraries(depth: &mut PipelineDepth, libraries: &[Arc<PipelineDepth>]) {
    for library in libraries {
        depth.subsets |= library.subsets;
        depth.module_identifiers |= library.module_identifiers;
        depth.promotable |= library.promotable;
        depth.app_dynamic |= library.app_dynamic;
        depth.injected |= library.injected;
        if library.subsets.contains(Subsets::PRE_RASTERIZATION_SHADERS) {
            depth.viewports.clone_from(&library.viewports);
            depth.bias = library.bias;
            depth.clamp_range = library.clamp_range;
            depth.static_clamp = library.static_clamp;
            depth.depth_clip = library.depth_clip;
            depth.projection = library.projection;
            depth.derived_range = library.derived_range;
            depth.position_store = library.position_store;
            depth.layout = library.layout;
        }
        if library.subsets.contains(Subsets::FRAGMENT_SHADER) {
            depth.compare_op = library.compare_op;
            depth.bounds = library.bounds;
            depth.unreversed_fragment |= library.unreversed_fragment;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conv::DepthBias;

    #[test]
    fn a_create_info_defines_the_named_subsets_else_none_as_a_library_or_link_else_all() {
        let fragment = Some(Subsets::FRAGMENT_SHADER);
        // Named subsets count whatever else the create info is, which is not asked then.
        assert_eq!(
            own_subsets(fragment, || unreachable!(), || unreachable!()),
            Subsets::FRAGMENT_SHADER
        );
        assert_eq!(
            own_subsets(Some(Subsets::empty()), || unreachable!(), || unreachable!()),
            Subsets::empty()
        );
        let of = |links: bool, library: bool| {
            let asked = std::cell::RefCell::new(Vec::new());
            let subsets = own_subsets(
                None,
                || {
                    asked.borrow_mut().push("links");
                    links
                },
                || {
                    asked.borrow_mut().push("library");
                    library
                },
            );
            // Both are asked, the links first.
            assert_eq!(*asked.borrow(), ["links", "library"]);
            subsets
        };
        assert_eq!(of(false, true), Subsets::empty());
        assert_eq!(of(true, false), Subsets::empty());
        assert_eq!(of(true, true), Subsets::empty());
        assert_eq!(of(false, false), ALL_SUBSETS);
    }

    #[test]
    fn each_subset_owns_its_depth_states() {
        let pre_rasterization = States::VIEWPORT
            | States::VIEWPORT_WITH_COUNT
            | States::BIAS
            | States::CLIP_CONTROL
            | States::DEPTH_CLAMP
            | States::CLAMP_RANGE;
        let fragment = States::COMPARE_OP | States::BOUNDS;
        assert_eq!(
            subset_states(Subsets::PRE_RASTERIZATION_SHADERS),
            pre_rasterization
        );
        assert_eq!(subset_states(Subsets::FRAGMENT_SHADER), fragment);
        assert_eq!(subset_states(ALL_SUBSETS), pre_rasterization | fragment);
        assert_eq!(
            subset_states(Subsets::VERTEX_INPUT_INTERFACE | Subsets::FRAGMENT_OUTPUT_INTERFACE),
            States::NONE
        );
        assert_eq!(subset_states(Subsets::empty()), States::NONE);
    }

    #[test]
    fn a_link_takes_each_subsets_state_from_the_library_that_defines_it() {
        let pre_rasterization = Arc::new(PipelineDepth {
            subsets: Subsets::PRE_RASTERIZATION_SHADERS,
            app_dynamic: States::VIEWPORT_WITH_COUNT,
            injected: States::BIAS,
            bias: DepthBias {
                constant: 3.0,
                clamp: 0.0,
                slope: 1.0,
                representation: None,
            },
            promotable: true,
            // What a fragment shader library would own is ignored from this one.
            compare_op: vk::CompareOp::NEVER,
            unreversed_fragment: true,
            ..PipelineDepth::default()
        });
        let fragment = Arc::new(PipelineDepth {
            subsets: Subsets::FRAGMENT_SHADER,
            injected: States::COMPARE_OP | States::BOUNDS,
            compare_op: vk::CompareOp::LESS,
            bounds: (0.25, 0.5),
            module_identifiers: true,
            bias: DepthBias {
                constant: 99.0,
                clamp: 0.0,
                slope: 0.0,
                representation: None,
            },
            ..PipelineDepth::default()
        });
        let mut link = PipelineDepth::default();
        inherit_libraries(&mut link, &[pre_rasterization, fragment]);
        assert_eq!(link.app_dynamic, States::VIEWPORT_WITH_COUNT);
        assert_eq!(
            link.injected,
            States::BIAS | States::COMPARE_OP | States::BOUNDS
        );
        assert_eq!(link.bias.constant, 3.0);
        assert_eq!(link.compare_op, vk::CompareOp::LESS);
        assert_eq!(link.bounds, (0.25, 0.5));
        assert!(link.promotable && link.module_identifiers);
        // Only the fragment shader library's fragment stage counts.
        assert!(!link.unreversed_fragment);

        // A library that links the two passes their state on to what links it.
        let mut outer = PipelineDepth::default();
        inherit_libraries(&mut outer, &[Arc::new(link)]);
        assert_eq!(
            outer.subsets,
            Subsets::PRE_RASTERIZATION_SHADERS | Subsets::FRAGMENT_SHADER
        );
        assert_eq!(outer.bias.constant, 3.0);
        assert_eq!(outer.compare_op, vk::CompareOp::LESS);

        // ... and a fragment shader library's unreversed fragment stage does.
        let unreversed = Arc::new(PipelineDepth {
            subsets: Subsets::FRAGMENT_SHADER,
            unreversed_fragment: true,
            ..PipelineDepth::default()
        });
        let mut link = PipelineDepth::default();
        inherit_libraries(&mut link, &[unreversed]);
        assert!(link.unreversed_fragment);

        // No libraries: nothing changes.
        let mut alone = PipelineDepth::default();
        inherit_libraries(&mut alone, &[]);
        assert_eq!(alone.subsets, Subsets::empty());
        assert_eq!(alone.injected, States::NONE);
    }
}
