//! What revz makes of a graphics pipeline (and of a fragment shader object): which of its
//! static states become dynamic ([`StaticStateFacts::decide`]).
//!
//! The facts come from `vkCreateGraphicsPipelines`: `crate::hooks::pipeline::plan` reads the
//! create info (only the state the spec says to read, in its order) and records the static
//! values itself; this module only decides.

use ash::vk;

use crate::command_state::States;
use crate::conv::flip_compare_op;

/// Whether a pipeline's draws can reach a depth attachment: it has one, and does not
/// statically discard every primitive. Otherwise the spec ignores its viewport and depth
/// state (possibly dangling), and nothing about its depth matters.
#[must_use]
pub fn renders_depth(
    has_depth_attachment: bool,
    rasterizer_discard: bool,
    app_dynamic: &[vk::DynamicState],
) -> bool {
    // A discard the application sets dynamically may be off at draw time.
    let discards =
        rasterizer_discard && !app_dynamic.contains(&vk::DynamicState::RASTERIZER_DISCARD_ENABLE);
    has_depth_attachment && !discards
}

/// Whether a pipeline's viewports are static (the application made neither `VIEWPORT` nor
/// `VIEWPORT_WITH_COUNT` dynamic): only then are they read, and made dynamic.
#[must_use]
pub fn viewports_static(app_dynamic: &[vk::DynamicState]) -> bool {
    !app_dynamic.contains(&vk::DynamicState::VIEWPORT)
        && !app_dynamic.contains(&vk::DynamicState::VIEWPORT_WITH_COUNT)
}

/// What [`StaticStateFacts::decide`] reads of a pipeline's depth-stencil state (given where
/// the pipeline renders depth and defines fragment shader state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthStencilFacts {
    pub compare_op: vk::CompareOp,
    pub depth_test_enable: bool,
    pub depth_bounds_test_enable: bool,
}

/// What [`StaticStateFacts::decide`] reads of a pipeline's depth bias (its rasterization
/// state, given where the pipeline renders depth and defines pre-rasterization state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthBiasFacts {
    /// `depthBiasEnable`.
    pub enable: bool,
    /// The bias has an explicit representation (`VkDepthBiasRepresentationInfoEXT`).
    pub represented: bool,
}

/// What revz knows of a pipeline's static depth-related state, gathered by the pipeline hook
/// from the subsets its create info defines.
#[derive(Clone, Copy, Debug)]
pub struct StaticStateFacts<'a> {
    pub has_depth_attachment: bool,
    /// The dynamic states the application listed.
    pub app_dynamic: &'a [vk::DynamicState],
    /// `rasterizerDiscardEnable` (false where the create info defines no rasterization state).
    pub rasterizer_discard: bool,
    /// Its depth-stencil state, where it defines fragment shader state.
    pub depth_stencil: Option<DepthStencilFacts>,
    /// Its depth bias, where it defines pre-rasterization state.
    pub depth_bias: Option<DepthBiasFacts>,
    /// How many static viewports it has (0 where it defines none, or they are dynamic).
    pub static_viewports: usize,
    /// The flipped compare op comes from a pipeline variant, not dynamic state
    /// (`DevicePolicy::compare_op_variants`).
    pub compare_op_variants: bool,
    /// The device has `vkCmdSetDepthBias2EXT`: a bias with an explicit representation can be
    /// sent again with it.
    pub bias_with_representation: bool,
}

/// What revz does with a pipeline's static depth state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StaticStatePlan {
    /// Whether its draws can reach a depth attachment ([`renders_depth`]).
    pub renders_depth: bool,
    /// The states revz makes dynamic (the application left them static).
    pub made_dynamic: States,
    /// Whether the reversed variant flips the static compare op (the compare op is not made
    /// dynamic, and flipping changes it).
    pub compare_op_variant: bool,
    /// The static compare op of a pipeline that tests depth (`None` where it does not, or
    /// where the application sets the compare op dynamically): evidence of the application's
    /// depth convention (`crate::policy::ConventionEvidence`).
    pub tested_compare_op: Option<vk::CompareOp>,
}

impl StaticStatePlan {
    /// The dynamic states revz adds to the application's list, in the order they are added.
    pub fn added_dynamic_states(&self) -> impl Iterator<Item = vk::DynamicState> {
        let made = self.made_dynamic;
        [
            (States::COMPARE_OP, vk::DynamicState::DEPTH_COMPARE_OP),
            (States::BOUNDS, vk::DynamicState::DEPTH_BOUNDS),
            (States::VIEWPORT, vk::DynamicState::VIEWPORT),
            (States::BIAS, vk::DynamicState::DEPTH_BIAS),
        ]
        .into_iter()
        .filter_map(move |(state, dynamic)| made.contains(state).then_some(dynamic))
    }
}

impl StaticStateFacts<'_> {
    /// Which static states become dynamic: in a pipeline that renders depth, the compare op of
    /// a depth test (unless it comes from a variant), the bounds of a bounds test, static
    /// viewports, and an enabled bias (unless its explicit representation cannot be sent
    /// again). State the application made dynamic is left to it.
    pub fn decide(&self) -> StaticStatePlan {
        let has = |state: vk::DynamicState| self.app_dynamic.contains(&state);
        let mut plan = StaticStatePlan {
            renders_depth: renders_depth(
                self.has_depth_attachment,
                self.rasterizer_discard,
                self.app_dynamic,
            ),
            ..StaticStatePlan::default()
        };
        if !plan.renders_depth {
            return plan;
        }
        if let Some(depth_stencil) = self.depth_stencil {
            let depth_test =
                depth_stencil.depth_test_enable || has(vk::DynamicState::DEPTH_TEST_ENABLE);
            if depth_test && !has(vk::DynamicState::DEPTH_COMPARE_OP) {
                plan.tested_compare_op = Some(depth_stencil.compare_op);
                if self.compare_op_variants {
                    plan.compare_op_variant =
                        flip_compare_op(depth_stencil.compare_op) != depth_stencil.compare_op;
                } else {
                    plan.made_dynamic |= States::COMPARE_OP;
                }
            }
            let bounds = depth_stencil.depth_bounds_test_enable
                || has(vk::DynamicState::DEPTH_BOUNDS_TEST_ENABLE);
            if bounds && !has(vk::DynamicState::DEPTH_BOUNDS) {
                plan.made_dynamic |= States::BOUNDS;
            }
        }
        if self.static_viewports > 0 && viewports_static(self.app_dynamic) {
            plan.made_dynamic |= States::VIEWPORT;
        }
        if let Some(bias) = self.depth_bias {
            let enabled = bias.enable || has(vk::DynamicState::DEPTH_BIAS_ENABLE);
            // A bias with an explicit representation (VK_EXT_depth_bias_control) goes down
            // again with vkCmdSetDepthBias2EXT and its representation; without that command it
            // cannot, and the pipeline keeps its static (unflipped) bias.
            let resendable = !bias.represented || self.bias_with_representation;
            if enabled && resendable && !has(vk::DynamicState::DEPTH_BIAS) {
                plan.made_dynamic |= States::BIAS;
            }
        }
        plan
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TESTED: DepthStencilFacts = DepthStencilFacts {
        compare_op: vk::CompareOp::LESS_OR_EQUAL,
        depth_test_enable: true,
        depth_bounds_test_enable: true,
    };

    const BIASED: DepthBiasFacts = DepthBiasFacts {
        enable: true,
        represented: false,
    };

    /// A pipeline that renders depth with every depth state static and enabled.
    fn all_static() -> StaticStateFacts<'static> {
        StaticStateFacts {
            has_depth_attachment: true,
            app_dynamic: &[],
            rasterizer_discard: false,
            depth_stencil: Some(TESTED),
            depth_bias: Some(BIASED),
            static_viewports: 1,
            compare_op_variants: false,
            bias_with_representation: false,
        }
    }

    #[test]
    fn a_pipeline_renders_depth_with_an_attachment_unless_it_statically_discards() {
        assert!(renders_depth(true, false, &[]));
        assert!(!renders_depth(false, false, &[]));
        assert!(!renders_depth(true, true, &[]));
        assert!(renders_depth(
            true,
            true,
            &[vk::DynamicState::RASTERIZER_DISCARD_ENABLE]
        ));
        assert!(!renders_depth(
            false,
            true,
            &[vk::DynamicState::RASTERIZER_DISCARD_ENABLE]
        ));
    }

    #[test]
    fn every_enabled_static_state_becomes_dynamic_in_order() {
        let plan = all_static().decide();
        assert!(plan.renders_depth);
        assert_eq!(
            plan.made_dynamic,
            States::COMPARE_OP | States::BOUNDS | States::VIEWPORT | States::BIAS
        );
        assert!(!plan.compare_op_variant);
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::LESS_OR_EQUAL));
        assert_eq!(
            plan.added_dynamic_states().collect::<Vec<_>>(),
            [
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::DEPTH_BOUNDS,
                vk::DynamicState::VIEWPORT,
                vk::DynamicState::DEPTH_BIAS,
            ]
        );
    }

    #[test]
    fn a_pipeline_that_renders_no_depth_keeps_its_state() {
        for facts in [
            StaticStateFacts {
                has_depth_attachment: false,
                ..all_static()
            },
            StaticStateFacts {
                rasterizer_discard: true,
                ..all_static()
            },
        ] {
            assert_eq!(facts.decide(), StaticStatePlan::default());
        }
        let dynamic_discard = [vk::DynamicState::RASTERIZER_DISCARD_ENABLE];
        let facts = StaticStateFacts {
            rasterizer_discard: true,
            app_dynamic: &dynamic_discard,
            ..all_static()
        };
        assert!(facts.decide().renders_depth);
    }

    #[test]
    fn state_the_application_made_dynamic_is_left_to_it() {
        let app = [
            vk::DynamicState::DEPTH_COMPARE_OP,
            vk::DynamicState::DEPTH_BOUNDS,
            vk::DynamicState::DEPTH_BIAS,
        ];
        let facts = StaticStateFacts {
            app_dynamic: &app,
            static_viewports: 0,
            ..all_static()
        };
        let plan = facts.decide();
        assert!(plan.renders_depth);
        assert!(plan.made_dynamic.is_empty());
        assert_eq!(plan.added_dynamic_states().count(), 0);
        // A dynamic compare op is no evidence of the convention.
        assert_eq!(plan.tested_compare_op, None);
        for viewport in [
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::VIEWPORT_WITH_COUNT,
        ] {
            let app = [viewport];
            assert!(!viewports_static(&app));
            let facts = StaticStateFacts {
                app_dynamic: &app,
                ..all_static()
            };
            assert!(!facts.decide().made_dynamic.contains(States::VIEWPORT));
        }
        assert!(viewports_static(&[vk::DynamicState::SCISSOR]));
    }

    #[test]
    fn disabled_tests_and_bias_stay_static_unless_enabled_dynamically() {
        let off = StaticStateFacts {
            depth_stencil: Some(DepthStencilFacts {
                depth_test_enable: false,
                depth_bounds_test_enable: false,
                ..TESTED
            }),
            depth_bias: Some(DepthBiasFacts {
                enable: false,
                represented: false,
            }),
            static_viewports: 0,
            ..all_static()
        };
        let plan = off.decide();
        assert!(plan.made_dynamic.is_empty());
        assert_eq!(plan.tested_compare_op, None);
        let enables = [
            vk::DynamicState::DEPTH_TEST_ENABLE,
            vk::DynamicState::DEPTH_BOUNDS_TEST_ENABLE,
            vk::DynamicState::DEPTH_BIAS_ENABLE,
        ];
        let enabled = StaticStateFacts {
            app_dynamic: &enables,
            ..off
        };
        let plan = enabled.decide();
        assert_eq!(
            plan.made_dynamic,
            States::COMPARE_OP | States::BOUNDS | States::BIAS
        );
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::LESS_OR_EQUAL));
        // Without the states of other subsets, nothing of theirs is made dynamic.
        let none = StaticStateFacts {
            depth_stencil: None,
            depth_bias: None,
            static_viewports: 0,
            ..all_static()
        };
        assert!(none.decide().made_dynamic.is_empty());
    }

    #[test]
    fn with_variants_a_flipping_compare_op_stays_static_and_gets_a_variant() {
        let variants = StaticStateFacts {
            compare_op_variants: true,
            ..all_static()
        };
        let plan = variants.decide();
        assert!(plan.compare_op_variant);
        assert!(!plan.made_dynamic.contains(States::COMPARE_OP));
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::LESS_OR_EQUAL));
        // EQUAL reads the same reversed: no variant.
        let equal = StaticStateFacts {
            depth_stencil: Some(DepthStencilFacts {
                compare_op: vk::CompareOp::EQUAL,
                ..TESTED
            }),
            ..variants
        };
        let plan = equal.decide();
        assert!(!plan.compare_op_variant);
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::EQUAL));
    }

    #[test]
    fn an_explicit_bias_representation_is_made_dynamic_only_where_it_can_be_sent_again() {
        let represented = StaticStateFacts {
            depth_bias: Some(DepthBiasFacts {
                enable: true,
                represented: true,
            }),
            ..all_static()
        };
        assert!(!represented.decide().made_dynamic.contains(States::BIAS));
        let resendable = StaticStateFacts {
            bias_with_representation: true,
            ..represented
        };
        assert!(resendable.decide().made_dynamic.contains(States::BIAS));
    }
}
