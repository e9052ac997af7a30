//! SPIR-V: what revz reads in the application's shaders and how it rewrites them. Nothing here
//! calls Vulkan; each file takes words and returns facts or new words.
//!
//! | file | owns |
//! |---|---|
//! | [`scan`] | the header and the few instructions read without parsing (entry points, push-constant blocks) |
//! | [`analysis`] (`layout.rs`: read from the words; `walker.rs`: the walk through naga's IR) | which push-constant bytes of a vertex stage hold the projection that reaches `Position` (naga) |
//! | [`position_store`] (`declarations.rs`, `body.rs`, `rewrite.rs`) | the `Position` store rewrite: the stage stores depth on the carrier's line |
//! | [`derived_range`] | the in-shader fit of the range for projections in uniform or storage buffers |
//! | [`fragment_depth`] | the rewrite of fragment shaders that compute with or write depth |
//! | [`input_depth`] | the rewrite of fragment shaders that read depth as an input attachment |
//! | [`tessellation_positions`] | whether tessellation stages only copy and interpolate the vertex stage's clip positions (it is then the one rewritten) |
//!
//! Which pipelines get which rewrite is decided in `crate::policy`; when modules are read and
//! rewritten (once per module or distinct inline code) in `crate::hooks::pipeline`.

pub mod analysis;
pub mod derived_range;
pub mod fragment_depth;
pub mod input_depth;
pub mod position_store;
pub mod scan;
pub mod tessellation_positions;
#[cfg(test)]
pub(crate) mod test_spirv;
