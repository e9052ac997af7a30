//! Fragment shaders that read depth as an input attachment (`subpassLoad`), rewritten for
//! reversed attachments.
//!
//! Deferred renderers read the depth their geometry subpass wrote as an input attachment of a
//! later subpass of the same render pass, or, with dynamic rendering
//! (`VK_KHR_dynamic_rendering_local_read`), later in the same rendering instance. No read twin
//! can be refreshed inside a pass, so the read itself converts: [`reverse_input_depth`]
//! rewrites every `OpImageRead` of a `SubpassData` image that reads the depth attachment (the
//! caller knows which, [`DepthInputs`]: the input attachment indices of a render pass's
//! subpass, or of a pipeline's `VkRenderingInputAttachmentIndexInfo`, or dynamic rendering's
//! default mapping, input attachments without an `InputAttachmentIndex` decoration) so that
//! its first component, the depth read, becomes `1 - d`. The shader then computes with the
//! standard depth it reads natively.
//!
//! The map is the complementary one, exact in the flip and complementary modes (an attachment
//! there holds `1 - D`). Infinite mode stores `n / w = 1 - (1 - n/f) D`, whose inverse needs the
//! camera's n/f at draw time: images read as input attachments store complementary depth
//! `1 - D` in that mode instead (`DevicePolicy::stores_complementary`), so the same map holds.
//!
//! Word manipulation only, no Vulkan and no full parse. What the rewrite does not recognise (an
//! array of input attachments, a depth input attachment handed to a function or copied into a
//! variable) is refused with a reason, never guessed at: the pipeline then keeps its reads
//! unconverted and the caller logs it.

use std::collections::{HashMap, HashSet};

use crate::shader::fragment_depth::Unsupported;
use crate::shader::scan::op::*;
use crate::shader::scan::{
    instructions, instructions_at, is_literal, push, FreshIds, Instruction, HEADER_WORDS,
};

const OP_TYPE_IMAGE: u32 = 25;
const OP_IMAGE_READ: u32 = 98;
const OP_IMAGE_SPARSE_READ: u32 = 320;
const DECORATION_INPUT_ATTACHMENT_INDEX: u32 = 43;
const DIM_SUBPASS_DATA: u32 = 6;
const STORAGE_CLASS_UNIFORM_CONSTANT: u32 = 0;

/// Whether `words` declare an image of dimension `SubpassData` (an input attachment): only
/// such fragment modules are kept for [`reverse_input_depth`] at pipeline creation. Words
/// that are not SPIR-V answer `false` (the driver judges them).
pub fn reads_input_attachments(words: &[u32]) -> bool {
    let Some(instructions) = instructions(words) else {
        return false;
    };
    instructions
        .map_while(Result::ok)
        .any(|i| i.opcode == OP_TYPE_IMAGE && i.operands.get(2) == Some(&DIM_SUBPASS_DATA))
}

/// Which input attachment variables of a fragment shader read the depth attachment.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DepthInputs {
    /// Those whose `InputAttachmentIndex` is one of these: a render pass's subpass (its input
    /// attachments that read a depth aspect), or dynamic rendering's depth attachment mapped
    /// to an index (`VkRenderingInputAttachmentIndexInfo::pDepthInputAttachmentIndex`).
    Indices(Vec<u32>),
    /// Those without an `InputAttachmentIndex` decoration: dynamic rendering's depth
    /// attachment where the pipeline maps it to no index (no
    /// `VkRenderingInputAttachmentIndexInfo`, or a null `pDepthInputAttachmentIndex`). The
    /// stencil attachment maps there too; it is read as integers.
    Undecorated,
}

impl DepthInputs {
    /// Whether a variable decorated with `index` (`None`: undecorated) reads depth, and
    /// whether an array of them starting there may.
    fn reads(&self, index: Option<u32>, array: bool) -> bool {
        match (self, index) {
            // Element i reads input attachment index + i.
            (DepthInputs::Indices(depth), Some(index)) if array => {
                depth.iter().any(|&depth| depth >= index)
            }
            (DepthInputs::Indices(depth), Some(index)) => depth.contains(&index),
            (DepthInputs::Undecorated, None) => true,
            (DepthInputs::Indices(_), None) | (DepthInputs::Undecorated, Some(_)) => false,
        }
    }

    fn is_empty(&self) -> bool {
        matches!(self, DepthInputs::Indices(depth) if depth.is_empty())
    }
}

/// The module with the depth read from every input attachment `depth_inputs` names converted
/// (d -> 1 - d); `None` when it reads none of them as floats (a stencil aspect is read as
/// integers and stays as it is).
pub fn reverse_input_depth(
    words: &[u32],
    depth_inputs: &DepthInputs,
) -> Result<Option<Vec<u32>>, Unsupported> {
    if depth_inputs.is_empty() {
        return Ok(None);
    }
    let Some(module) = Module::read(words, depth_inputs)? else {
        return Ok(None);
    };
    module.rewrite(words)
}

/// What the rewrite needs of a module's declarations.
#[derive(Debug, Default)]
struct Module {
    /// The depth input attachments: variables whose reads convert.
    depth_inputs: HashSet<u32>,
    /// The 32-bit float type their images sample (one constant 1.0 of it is added).
    float: u32,
    /// Vector types: (component, count).
    vectors: HashMap<u32, (u32, u32)>,
    floats: HashSet<u32>,
    /// Word index of the first `OpFunction`.
    functions_at: usize,
}

impl Module {
    fn read(words: &[u32], depth_inputs: &DepthInputs) -> Result<Option<Module>, Unsupported> {
        let Some(instructions) = instructions(words) else {
            return Ok(None);
        };
        let mut module = Module::default();
        let mut indices = HashMap::new();
        // SubpassData image types (their sampled type), pointers to them and arrays of them.
        let mut images = HashMap::new();
        let mut pointers = HashMap::new();
        let mut arrays = HashSet::new();
        let mut at = HEADER_WORDS;
        for instruction in instructions {
            let Instruction { opcode, operands } =
                instruction.map_err(|_| Unsupported("a malformed instruction"))?;
            // Advanced first: the arms below `continue`.
            let here = at;
            at += operands.len() + 1;
            match (opcode, operands) {
                (OP_DECORATE, &[target, DECORATION_INPUT_ATTACHMENT_INDEX, index]) => {
                    indices.insert(target, index);
                }
                (OP_TYPE_FLOAT, &[id, 32, ..]) => {
                    module.floats.insert(id);
                }
                (OP_TYPE_VECTOR, &[id, component, count]) => {
                    module.vectors.insert(id, (component, count));
                }
                (OP_TYPE_IMAGE, &[id, sampled, DIM_SUBPASS_DATA, ..]) => {
                    images.insert(id, sampled);
                }
                (OP_TYPE_ARRAY | OP_TYPE_RUNTIME_ARRAY, &[id, element, ..])
                    if images.contains_key(&element) =>
                {
                    arrays.insert(id);
                }
                (OP_TYPE_POINTER, &[id, STORAGE_CLASS_UNIFORM_CONSTANT, pointee]) => {
                    pointers.insert(id, pointee);
                }
                (OP_VARIABLE, &[ty, id, STORAGE_CLASS_UNIFORM_CONSTANT, ..])
                    if module.functions_at == 0 =>
                {
                    let Some(&pointee) = pointers.get(&ty) else {
                        continue;
                    };
                    let index = indices.get(&id).copied();
                    if arrays.contains(&pointee) {
                        // Which element a read takes may be known only at run time.
                        if depth_inputs.reads(index, true) {
                            return Err(Unsupported(
                                "an array of input attachments may hold depth",
                            ));
                        }
                        continue;
                    }
                    let Some(&sampled) = images.get(&pointee) else {
                        continue;
                    };
                    // A stencil aspect is read as integers: it stays as it is.
                    if depth_inputs.reads(index, false) && module.floats.contains(&sampled) {
                        if module.float != 0 && module.float != sampled {
                            return Err(Unsupported("depth input attachments of two float types"));
                        }
                        module.float = sampled;
                        module.depth_inputs.insert(id);
                    }
                }
                (OP_FUNCTION, _) if module.functions_at == 0 => module.functions_at = here,
                _ => {}
            }
        }
        if module.depth_inputs.is_empty() || module.functions_at == 0 {
            return Ok(None);
        }
        Ok(Some(module))
    }

    /// The reads of the depth input attachments: the result ids of each `OpImageRead` of one.
    /// Every use of such a variable must be a load, and every use of a loaded image a read,
    /// a copy, or an image query.
    fn reads(&self, words: &[u32]) -> Result<HashSet<u32>, Unsupported> {
        let all = || instructions_at(words, self.functions_at).map_while(Result::ok);
        let mut images: HashSet<u32> = HashSet::new();
        let mut reads = HashSet::new();
        // Every image read's result: the rewrite converts the reads by result id, so one
        // defined twice (malformed) would take more fresh ids than it reserves.
        let mut read_results: HashSet<u32> = HashSet::new();
        for Instruction { opcode, operands } in all() {
            if let (OP_IMAGE_READ, &[_, result, ..]) = (opcode, operands) {
                if !read_results.insert(result) {
                    return Err(Unsupported("a result id is defined twice"));
                }
            }
            let ids = || {
                operands
                    .iter()
                    .enumerate()
                    .filter(|&(index, _)| !is_literal(opcode, index))
                    .map(|(_, word)| *word)
            };
            match (opcode, operands) {
                (OP_LINE | OP_NO_LINE, _) => {}
                (OP_LOAD, &[_, result, pointer, ..]) if self.depth_inputs.contains(&pointer) => {
                    images.insert(result);
                }
                (OP_COPY_OBJECT, &[_, result, image]) if images.contains(&image) => {
                    images.insert(result);
                }
                (OP_IMAGE_READ, &[ty, result, image, ..]) if images.contains(&image) => {
                    // Vulkan reads input attachments as 4-vectors.
                    if self.vectors.get(&ty).map(|&(component, _)| component) != Some(self.float) {
                        return Err(Unsupported("a depth read is not of 32-bit floats"));
                    }
                    reads.insert(result);
                }
                (OP_IMAGE_SPARSE_READ, &[_, _, image, ..]) if images.contains(&image) => {
                    return Err(Unsupported("a sparse read of a depth input attachment"));
                }
                _ if ids().any(|id| self.depth_inputs.contains(&id)) => {
                    return Err(Unsupported(
                        "a depth input attachment is used other than by a load",
                    ));
                }
                (OP_FUNCTION_CALL, _) if ids().any(|id| images.contains(&id)) => {
                    return Err(Unsupported(
                        "a depth input attachment is handed to a function",
                    ));
                }
                _ => {}
            }
        }
        Ok(reads)
    }

    fn rewrite(&self, words: &[u32]) -> Result<Option<Vec<u32>>, Unsupported> {
        let reads = self.reads(words)?;
        if reads.is_empty() {
            return Ok(None);
        }
        // One constant, and at most three ids per read.
        let needed = 1 + 3 * reads.len();
        let mut ids =
            FreshIds::new(words, needed).ok_or(Unsupported("its id bound leaves no room"))?;
        let mut fresh = || ids.take();
        let one = fresh();
        let mut out = Vec::with_capacity(words.len() + 16 * reads.len());
        out.extend_from_slice(&words[..self.functions_at]);
        push(&mut out, OP_CONSTANT, &[self.float, one, 1.0f32.to_bits()]);
        for Instruction { opcode, operands } in
            instructions_at(words, self.functions_at).map_while(Result::ok)
        {
            match (opcode, operands) {
                (OP_IMAGE_READ, &[ty, result, ..]) if reads.contains(&result) => {
                    // The read goes to a fresh id; `result` becomes its conversion, so every
                    // use of it reads standard depth.
                    let read = fresh();
                    let mut image_read = operands.to_vec();
                    image_read[1] = read;
                    push(&mut out, opcode, &image_read);
                    let (depth, reversed) = (fresh(), fresh());
                    push(
                        &mut out,
                        OP_COMPOSITE_EXTRACT,
                        &[self.float, depth, read, 0],
                    );
                    push(&mut out, OP_F_SUB, &[self.float, reversed, one, depth]);
                    push(
                        &mut out,
                        OP_COMPOSITE_INSERT,
                        &[ty, result, reversed, read, 0],
                    );
                }
                _ => push(&mut out, opcode, operands),
            }
        }
        out[3] = ids.bound();
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::test_spirv;

    /// The depth inputs of a render pass's subpass reading depth at `indices`.
    fn at(indices: &[u32]) -> DepthInputs {
        DepthInputs::Indices(indices.to_vec())
    }

    /// A deferred lighting shader in SPIR-V assembly as glslang writes `subpassLoad`: a color
    /// input at index 0, depth at index 1, a stencil input (integers) at index 2, and the
    /// output's red from depth, green from color, blue from stencil.
    fn deferred(body: &str) -> Vec<u32> {
        test_spirv::input_attachment_fragment(
            "OpDecorate %albedo InputAttachmentIndex 0
             OpDecorate %albedo DescriptorSet 0
             OpDecorate %albedo Binding 0
             OpDecorate %depth InputAttachmentIndex 1
             OpDecorate %depth DescriptorSet 0
             OpDecorate %depth Binding 1
             OpDecorate %stencil InputAttachmentIndex 2
             OpDecorate %stencil DescriptorSet 0
             OpDecorate %stencil Binding 2",
            "%uv4 = OpTypeVector %uint 4
             %uimage = OpTypeImage %uint SubpassData 0 0 0 2 Unknown
             %pu = OpTypePointer UniformConstant %uimage
             %albedo = OpVariable %pf UniformConstant
             %depth = OpVariable %pf UniformConstant
             %stencil = OpVariable %pu UniformConstant",
            body,
        )
    }

    const READS: &str = "%a = OpLoad %fimage %albedo
             %ar = OpImageRead %v4 %a %origin
             %d = OpLoad %fimage %depth
             %dr = OpImageRead %v4 %d %origin
             %s = OpLoad %uimage %stencil
             %sr = OpImageRead %uv4 %s %origin
             %dx = OpCompositeExtract %float %dr 0
             %ag = OpCompositeExtract %float %ar 1
             %sx = OpCompositeExtract %uint %sr 0
             %sf = OpConvertUToF %float %sx
             %c = OpCompositeConstruct %v4 %dx %ag %sf %dx
             OpStore %out %c";

    /// The reads the rewrite converted: each `OpImageRead` followed by the conversion.
    fn converted_reads(words: &[u32]) -> usize {
        let code: Vec<_> = instructions(words).unwrap().map(Result::unwrap).collect();
        code.windows(4)
            .filter(|w| {
                w[0].opcode == OP_IMAGE_READ
                    && w[1].opcode == OP_COMPOSITE_EXTRACT
                    && w[2].opcode == OP_F_SUB
                    && w[3].opcode == OP_COMPOSITE_INSERT
                    // The conversion's result is the read's old id.
                    && w[3].operands[1] != w[0].operands[1]
            })
            .count()
    }

    #[test]
    fn only_the_depth_index_is_converted() {
        let words = deferred(READS);
        assert!(reads_input_attachments(&words));
        let out = reverse_input_depth(&words, &at(&[1])).unwrap().unwrap();
        test_spirv::validate(&out);
        assert_eq!(converted_reads(&out), 1);
        // The converted read feeds what the read fed: the old id is the insert's result.
        let code: Vec<_> = instructions(&out).unwrap().map(Result::unwrap).collect();
        let insert = code
            .iter()
            .find(|i| i.opcode == OP_COMPOSITE_INSERT)
            .unwrap();
        let read = code
            .iter()
            .filter(|i| i.opcode == OP_IMAGE_READ)
            .nth(1)
            .unwrap();
        assert_eq!(insert.operands[3], read.operands[1]);
    }

    #[test]
    fn modules_reading_no_depth_index_are_left_alone() {
        let words = deferred(READS);
        // Index 0 is a color, index 2 a stencil (integers): nothing to convert.
        assert_eq!(reverse_input_depth(&words, &at(&[])), Ok(None));
        assert_eq!(reverse_input_depth(&words, &at(&[5])), Ok(None));
        assert_eq!(reverse_input_depth(&words, &at(&[2])), Ok(None));
        let both = reverse_input_depth(&words, &at(&[0, 1])).unwrap().unwrap();
        test_spirv::validate(&both);
        assert_eq!(converted_reads(&both), 2);
        // A module without input attachments.
        let plain = test_spirv::fragment(
            "#version 450\nlayout(location = 0) out vec4 c;\nvoid main() { c = vec4(1.0); }",
        );
        assert!(!reads_input_attachments(&plain));
        assert_eq!(reverse_input_depth(&plain, &at(&[0])), Ok(None));
        assert!(!reads_input_attachments(&[1, 2, 3]));
    }

    #[test]
    fn copies_of_the_loaded_image_are_followed() {
        let body = "%d = OpLoad %fimage %depth
             %e = OpCopyObject %fimage %d
             %dr = OpImageRead %v4 %e %origin
             %dr2 = OpImageRead %v4 %d %origin
             %sum = OpFAdd %v4 %dr %dr2
             OpStore %out %sum";
        let out = reverse_input_depth(&deferred(body), &at(&[1]))
            .unwrap()
            .unwrap();
        test_spirv::validate(&out);
        assert_eq!(converted_reads(&out), 2);
    }

    #[test]
    fn uses_it_cannot_follow_are_refused() {
        let text = |body: &str| deferred(body);
        // The variable handed on as a pointer.
        let copied = "%x = OpCopyObject %pf %depth
             %d = OpLoad %fimage %x
             %dr = OpImageRead %v4 %d %origin
             OpStore %out %dr";
        assert!(reverse_input_depth(&text(copied), &at(&[1])).is_err());
        // The image handed to a function.
        let called = "%d = OpLoad %fimage %depth
             %r = OpFunctionCall %v4 %main %d
             OpStore %out %r";
        assert!(reverse_input_depth(&text(called), &at(&[1])).is_err());
    }

    #[test]
    fn arrays_of_input_attachments_that_may_hold_depth_are_refused() {
        let words = test_spirv::input_attachment_fragment(
            "OpDecorate %inputs InputAttachmentIndex 0
             OpDecorate %inputs DescriptorSet 0
             OpDecorate %inputs Binding 0",
            "%two = OpConstant %uint 2
             %array = OpTypeArray %fimage %two
             %pa = OpTypePointer UniformConstant %array
             %inputs = OpVariable %pa UniformConstant",
            "%p = OpAccessChain %pf %inputs %zero
             %d = OpLoad %fimage %p
             %dr = OpImageRead %v4 %d %origin
             OpStore %out %dr",
        );
        assert!(reverse_input_depth(&words, &at(&[1])).is_err());
        assert_eq!(reverse_input_depth(&words, &at(&[])), Ok(None));
    }

    /// A lighting shader of dynamic rendering's default mapping: a color input at index 0
    /// (the color attachment at location 0), and the depth and stencil attachments read
    /// through input attachments without an `InputAttachmentIndex`; the output's red from
    /// depth, green from color, blue from stencil.
    fn local_read(body: &str) -> Vec<u32> {
        test_spirv::input_attachment_fragment(
            "OpDecorate %albedo InputAttachmentIndex 0
             OpDecorate %albedo DescriptorSet 0
             OpDecorate %albedo Binding 0
             OpDecorate %depth DescriptorSet 0
             OpDecorate %depth Binding 1
             OpDecorate %stencil DescriptorSet 0
             OpDecorate %stencil Binding 2",
            "%uv4 = OpTypeVector %uint 4
             %uimage = OpTypeImage %uint SubpassData 0 0 0 2 Unknown
             %pu = OpTypePointer UniformConstant %uimage
             %albedo = OpVariable %pf UniformConstant
             %depth = OpVariable %pf UniformConstant
             %stencil = OpVariable %pu UniformConstant",
            body,
        )
    }

    #[test]
    fn undecorated_inputs_read_depth_under_dynamic_renderings_default_mapping() {
        let words = local_read(READS);
        test_spirv::validate(&words);
        let out = reverse_input_depth(&words, &DepthInputs::Undecorated)
            .unwrap()
            .unwrap();
        test_spirv::validate(&out);
        // The depth read alone: the color input is decorated, the stencil one reads integers.
        assert_eq!(converted_reads(&out), 1);
        let code: Vec<_> = instructions(&out).unwrap().map(Result::unwrap).collect();
        let insert = code
            .iter()
            .find(|i| i.opcode == OP_COMPOSITE_INSERT)
            .unwrap();
        let depth_read = code
            .iter()
            .filter(|i| i.opcode == OP_IMAGE_READ)
            .nth(1)
            .unwrap();
        assert_eq!(insert.operands[3], depth_read.operands[1]);
        // Mapped to an index (here the color's), the undecorated inputs read no depth.
        assert_eq!(reverse_input_depth(&words, &at(&[3])), Ok(None));
        let color = reverse_input_depth(&words, &at(&[0])).unwrap().unwrap();
        assert_eq!(converted_reads(&color), 1);
        // A render pass's shader, every input decorated: none reads the default mapping.
        assert_eq!(
            reverse_input_depth(&deferred(READS), &DepthInputs::Undecorated),
            Ok(None)
        );
    }

    #[test]
    fn an_undecorated_array_of_inputs_is_refused_under_the_default_mapping() {
        let words = test_spirv::input_attachment_fragment(
            "OpDecorate %inputs DescriptorSet 0
             OpDecorate %inputs Binding 0",
            "%two = OpConstant %uint 2
             %array = OpTypeArray %fimage %two
             %pa = OpTypePointer UniformConstant %array
             %inputs = OpVariable %pa UniformConstant",
            "%p = OpAccessChain %pf %inputs %zero
             %d = OpLoad %fimage %p
             %dr = OpImageRead %v4 %d %origin
             OpStore %out %dr",
        );
        assert!(reverse_input_depth(&words, &DepthInputs::Undecorated).is_err());
        assert_eq!(reverse_input_depth(&words, &at(&[0])), Ok(None));
    }

    #[test]
    fn other_resources_declared_before_the_depth_input_leave_the_rewrite_whole() {
        // A lighting shader with a texture declared first (a UniformConstant variable that is
        // no input attachment). Until session 37 the declaration walk skipped counting its
        // words, so the functions' start came early by them: the rewrite inserted its constant
        // there, among the declarations, or, where that fell inside an instruction, walked no
        // function and converted nothing (the reads saw reversed depth).
        let words = test_spirv::input_attachment_fragment(
            "OpDecorate %shadow DescriptorSet 0
             OpDecorate %shadow Binding 1
             OpDecorate %depth InputAttachmentIndex 0
             OpDecorate %depth DescriptorSet 0
             OpDecorate %depth Binding 0",
            "%simage = OpTypeImage %float 2D 0 0 0 1 Unknown
             %sampled = OpTypeSampledImage %simage
             %ps = OpTypePointer UniformConstant %sampled
             %shadow = OpVariable %ps UniformConstant
             %depth = OpVariable %pf UniformConstant",
            "%d = OpLoad %fimage %depth
             %dr = OpImageRead %v4 %d %origin
             OpStore %out %dr",
        );
        test_spirv::validate(&words);
        let out = reverse_input_depth(&words, &at(&[0])).unwrap().unwrap();
        test_spirv::validate(&out);
        assert_eq!(converted_reads(&out), 1);
        // The constant goes right before the first function, after every declaration.
        let code: Vec<_> = instructions(&out).unwrap().map(Result::unwrap).collect();
        let function = code.iter().position(|i| i.opcode == OP_FUNCTION).unwrap();
        assert_eq!(code[function - 1].opcode, OP_CONSTANT);
    }

    #[test]
    fn a_function_variable_whose_storage_class_is_the_inputs_id_is_no_use_of_it() {
        // The tester's undecorated depth input (glslang's `depth_input.frag` without its
        // `InputAttachmentIndex`): the input's id is 7, the storage class `Function` of its
        // locals too. Until session 37 `scan::is_literal` took that operand for an id, and the
        // module was refused ("used other than by a load").
        let words = test_spirv::words(include_bytes!(
            "../../../shaders/spvasm/depth_input_undecorated.frag.spv"
        ));
        let out = reverse_input_depth(&words, &DepthInputs::Undecorated)
            .unwrap()
            .unwrap();
        test_spirv::validate(&out);
        assert_eq!(converted_reads(&out), 1);
    }

    #[test]
    fn a_read_defined_twice_is_refused_not_counted_twice() {
        // Malformed: the depth read's result id defined twice, and a bound that leaves room
        // for exactly the ids one read takes. Until session 37 (found by the fuzzer) the
        // rewrite reserved ids per distinct read and took them per instruction: past the
        // bound, an id wrapped around.
        let mut words = deferred(READS);
        let code: Vec<(usize, Instruction<'_>)> = {
            let mut at = HEADER_WORDS;
            instructions(&words)
                .unwrap()
                .map(Result::unwrap)
                .map(|i| {
                    let here = at;
                    at += i.operands.len() + 1;
                    (here, i)
                })
                .collect()
        };
        let (start, len) = code
            .iter()
            .filter(|(_, i)| i.opcode == OP_IMAGE_READ)
            .nth(1)
            .map(|&(start, i)| (start, i.operands.len() + 1))
            .unwrap();
        let copy: Vec<u32> = words[start..start + len].to_vec();
        words.splice(start..start, copy);
        words[3] = u32::MAX - 4;
        assert_eq!(
            reverse_input_depth(&words, &at(&[1])),
            Err(Unsupported("a result id is defined twice"))
        );
    }
}
