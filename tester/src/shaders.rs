//! The SPIR-V modules compiled by `build.rs` from `shaders/*.vert|frag` (GLSL 450, naga,
//! SPIR-V 1.0, no y flip), embedded in the binary.

use std::io::Cursor;

use anyhow::{Context, Result};

/// One embedded shader module.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    /// `<name>.<stage>`, e.g. `scene.vert`.
    pub name: &'static str,
    /// The SPIR-V, as bytes.
    pub bytes: &'static [u8],
}

impl ShaderSource {
    /// The SPIR-V words (checks the magic number and alignment).
    pub fn words(&self) -> Result<Vec<u32>> {
        ash::util::read_spv(&mut Cursor::new(self.bytes))
            .with_context(|| format!("embedded SPIR-V of {} is malformed", self.name))
    }
}

macro_rules! shader {
    ($name:literal) => {
        ShaderSource {
            name: $name,
            bytes: include_bytes!(concat!(env!("OUT_DIR"), "/", $name, ".spv")),
        }
    };
}

/// `scene.vert`: `gl_Position = pc.mvp * vec4(position, 1.0)`.
pub const SCENE_VERT: ShaderSource = shader!("scene.vert");
/// `scene.frag`: writes `pc.color`.
pub const SCENE_FRAG: ShaderSource = shader!("scene.frag");

/// `shadow_receiver.vert`: `scene.vert` plus the light-space position (a uniform-buffer light
/// MVP indexed by `gl_InstanceIndex`).
pub const SHADOW_RECEIVER_VERT: ShaderSource = shader!("shadow_receiver.vert");
/// `shadow_receiver.frag`: `pc.color` darkened where a comparison sample of the shadow map
/// says the fragment is shadowed.
pub const SHADOW_RECEIVER_FRAG: ShaderSource = shader!("shadow_receiver.frag");

/// Every embedded module.
#[cfg(test)]
pub const ALL: &[ShaderSource] = &[
    SCENE_VERT,
    SCENE_FRAG,
    SHADOW_RECEIVER_VERT,
    SHADOW_RECEIVER_FRAG,
];

#[cfg(test)]
mod tests {
    use super::*;
    use spirv_tools::val::{self, Validator as _};
    use spirv_tools::TargetEnv;

    #[test]
    fn every_module_passes_spirv_val() {
        let validator = val::create(Some(TargetEnv::Vulkan_1_1));
        let mut failures = Vec::new();
        for shader in ALL {
            let words = shader.words().expect("readable SPIR-V");
            if let Err(error) = validator.validate(&words, None) {
                failures.push(format!("{}: {error}", shader.name));
            }
        }
        assert!(
            failures.is_empty(),
            "spirv-val failed:\n{}",
            failures.join("\n")
        );
    }

    #[test]
    fn the_validator_rejects_a_broken_module() {
        // The SPIR-V header with a zero id bound and no instructions: invalid. Guards against a
        // validator that silently accepts everything.
        let broken = [0x0723_0203u32, 0x0001_0000, 0, 0, 0];
        let validator = val::create(Some(TargetEnv::Vulkan_1_1));
        assert!(validator.validate(broken, None).is_err());
    }

    #[test]
    fn every_shader_source_is_embedded() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders");
        let mut sources: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".vert") || n.ends_with(".frag"))
            .collect();
        sources.sort();
        let mut embedded: Vec<&str> = ALL.iter().map(|s| s.name).collect();
        embedded.sort();
        assert_eq!(sources, embedded);
    }
}
