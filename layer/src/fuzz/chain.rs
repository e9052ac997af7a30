//! The `pNext` chain target: random but valid chains of the structure types revz copies, of
//! real types it does not know and of unknown sTypes, each filled with random bytes; then
//! random [`splice`]s, stacked [`Spliced::edit`]s, [`find`]s and [`structures`] walks, each
//! checked against a model of the chain: the structure replaced or left out, the ones before
//! it copied (same bytes, new places), the rest shared and in order, nothing spliced behind a
//! structure of unknown size, and the application's chain untouched, byte for byte.
//!
//! The input is an 8-byte seed from which the case is generated.

use std::ffi::c_void;
use std::ops::Range;

use ash::vk;

use super::{hash_of, Counter, Rng, Target};
use crate::chain::{find, has, splice, structures, Spliced, Unspliceable};

macro_rules! kinds {
    ($($structure:ty),* $(,)?) => {
        &[$((
            <$structure as vk::TaggedStructure>::STRUCTURE_TYPE,
            std::mem::size_of::<$structure>(),
        )),*]
    };
}

/// The structures revz knows the size of (those `chain::splice` copies).
const COPYABLE: &[(vk::StructureType, usize)] = crate::chain::KNOWN_SIZES;

/// Real structures revz does not know the size of.
const UNCOPYABLE: &[(vk::StructureType, usize)] = kinds!(
    vk::PipelineViewportDepthClipControlCreateInfoEXT<'static>,
    vk::PipelineRasterizationStateStreamCreateInfoEXT<'static>,
    vk::PipelineSampleLocationsStateCreateInfoEXT<'static>,
);

/// Where a structure's `pNext` is.
const P_NEXT: Range<usize> = 8..16;
/// The header's padding (after the 4-byte sType).
const HEADER_PADDING: Range<usize> = 4..8;

/// One structure of the model: what the chain must hold at its place.
#[derive(Clone, Debug)]
struct Entry {
    s_type: vk::StructureType,
    size: usize,
    copyable: bool,
    bytes: Vec<u8>,
    /// Bytes not compared: `pNext`, and the padding of a replacement passed by value.
    ignored: Vec<Range<usize>>,
    /// Where it must be: `Some` for a structure shared with the application's chain (or an
    /// earlier copy), `None` for a new copy.
    at: Option<usize>,
}

/// A structure type the case splices, with the generic operations on it.
struct Spliceable {
    s_type: vk::StructureType,
    size: usize,
    /// The padding bytes of the type after its header (lost when it is moved by value).
    padding: Option<Range<usize>>,
    splice: unsafe fn(&mut Case, &mut Rng) -> Result<String, String>,
    edit: unsafe fn(&mut Case, &mut Spliced, &mut Vec<Entry>, &mut Rng) -> Result<String, String>,
    find: unsafe fn(&Case, *const c_void, &[Entry]) -> Result<(), String>,
}

macro_rules! spliceable {
    ($structure:ty, $padding:expr) => {
        Spliceable {
            s_type: <$structure as vk::TaggedStructure>::STRUCTURE_TYPE,
            size: std::mem::size_of::<$structure>(),
            padding: $padding,
            splice: splice_op::<$structure>,
            edit: edit_op::<$structure>,
            find: find_op::<$structure>,
        }
    };
}

fn spliceables() -> [Spliceable; 6] {
    [
        spliceable!(vk::PipelineCreateFlags2CreateInfoKHR<'static>, None),
        spliceable!(vk::PipelineLibraryCreateInfoKHR<'static>, Some(20..24)),
        spliceable!(vk::ShaderModuleCreateInfo<'static>, Some(20..24)),
        spliceable!(vk::PipelineRenderingCreateInfo<'static>, None),
        spliceable!(vk::DebugUtilsObjectNameInfoEXT<'static>, Some(20..24)),
        // Of a size revz does not know: spliced itself, it may still be replaced.
        spliceable!(
            vk::PipelineViewportDepthClipControlCreateInfoEXT<'static>,
            Some(20..24)
        ),
    ]
}

/// One case: the application's chain (buffers, built back to front) and its model.
struct Case {
    buffers: Vec<Vec<u64>>,
    model: Vec<Entry>,
    /// Every structure of the application's chain, as built.
    snapshot: Vec<Vec<u64>>,
    /// Replacement structures kept alive for the case.
    replacements: Vec<Vec<u64>>,
}

fn bytes_of(buffer: &[u64], size: usize) -> Vec<u8> {
    buffer
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take(size)
        .collect()
}

/// A structure of `size` bytes with random contents, its sType and `pNext` set.
fn random_structure(
    rng: &mut Rng,
    s_type: vk::StructureType,
    size: usize,
    p_next: usize,
) -> Vec<u64> {
    let mut buffer = vec![0u64; size.div_ceil(8)];
    for word in &mut buffer {
        *word = rng.u64();
    }
    let low = buffer[0] & 0xffff_ffff_0000_0000;
    buffer[0] = low | u64::from(s_type.as_raw() as u32);
    buffer[1] = p_next as u64;
    buffer
}

impl Case {
    fn build(rng: &mut Rng, spliceables: &[Spliceable]) -> Case {
        let count = rng.below(9);
        let mut kinds = Vec::new();
        for _ in 0..count {
            let kind = match rng.below(10) {
                0..=4 => {
                    let s = rng.pick(spliceables);
                    (s.s_type, s.size)
                }
                5..=6 => *rng.pick(COPYABLE),
                7 => *rng.pick(UNCOPYABLE),
                _ => (
                    vk::StructureType::from_raw(1_000_999_000 + rng.below(1000) as i32),
                    16 + 8 * rng.below(10),
                ),
            };
            kinds.push(kind);
        }
        let mut buffers: Vec<Vec<u64>> = Vec::new();
        let mut model = Vec::new();
        let mut next = 0usize;
        for &(s_type, size) in kinds.iter().rev() {
            let buffer = random_structure(rng, s_type, size, next);
            next = buffer.as_ptr() as usize;
            model.push(Entry {
                s_type,
                size,
                copyable: COPYABLE.iter().any(|&(known, _)| known == s_type),
                bytes: bytes_of(&buffer, size),
                ignored: vec![P_NEXT],
                at: Some(next),
            });
            buffers.push(buffer);
        }
        model.reverse();
        Case {
            snapshot: buffers.clone(),
            buffers,
            model,
            replacements: Vec::new(),
        }
    }

    fn head(&self) -> *const c_void {
        self.model.first().and_then(|entry| entry.at).unwrap_or(0) as *const c_void
    }

    fn is_application_structure(&self, at: usize) -> bool {
        self.buffers.iter().any(|b| b.as_ptr() as usize == at)
    }

    /// The chain at `head` holds what `model` says, in order.
    ///
    /// # Safety
    /// `head` is a chain made of this case's structures and copies of them.
    unsafe fn compare(&self, head: *const c_void, model: &[Entry]) -> Result<Vec<usize>, String> {
        let mut at = head.cast::<u8>();
        let mut walked = Vec::new();
        for (index, entry) in model.iter().enumerate() {
            if at.is_null() {
                return Err(format!(
                    "the chain ends after {index} structures, {} expected",
                    model.len()
                ));
            }
            // SAFETY: the caller's contract: every structure starts with the header.
            let (s_type, next) = unsafe {
                (
                    at.cast::<vk::StructureType>().read(),
                    at.add(8).cast::<*const u8>().read(),
                )
            };
            if s_type != entry.s_type {
                return Err(format!(
                    "structure {index} is {s_type:?}, {:?} expected",
                    entry.s_type
                ));
            }
            // SAFETY: the type matches, so the structure has `entry.size` bytes.
            let bytes = unsafe { std::slice::from_raw_parts(at, entry.size) };
            let differs = (0..entry.size)
                .filter(|&i| !entry.ignored.iter().any(|r| r.contains(&i)))
                .find(|&i| bytes[i] != entry.bytes[i]);
            if let Some(byte) = differs {
                return Err(format!(
                    "structure {index} ({s_type:?}) differs from what it copies at byte {byte}"
                ));
            }
            match entry.at {
                Some(expected) if expected != at as usize => {
                    return Err(format!(
                        "structure {index} ({s_type:?}) should be shared, it is elsewhere"
                    ))
                }
                None if self.is_application_structure(at as usize) => {
                    return Err(format!(
                        "structure {index} ({s_type:?}) should be a copy, it is the \
                         application's"
                    ))
                }
                None if at as usize % 8 != 0 => {
                    return Err(format!("copy {index} is not 8-byte aligned"));
                }
                _ => {}
            }
            walked.push(at as usize);
            at = next;
        }
        if !at.is_null() {
            return Err(format!(
                "the chain goes on after the {} structures expected",
                model.len()
            ));
        }
        // `structures` walks the same chain.
        // SAFETY: as above.
        let listed: Vec<usize> = unsafe { structures(head) }
            .take(model.len() + 1)
            .map(|base| base as *const vk::BaseInStructure<'_> as usize)
            .collect();
        if listed != walked {
            return Err("structures() walks another chain".to_owned());
        }
        Ok(walked)
    }

    fn untouched(&self) -> Result<(), String> {
        if self.buffers != self.snapshot {
            return Err("the application's chain was written".to_owned());
        }
        Ok(())
    }
}

/// The model of `model` with its first structure of type `s_type` replaced (or left out):
/// `Err(())` when a structure of unknown size comes before it, `Ok(None)` when there is none.
fn expected_splice(
    model: &[Entry],
    s_type: vk::StructureType,
    replacement: Option<Entry>,
) -> Result<Option<Vec<Entry>>, ()> {
    let Some(index) = model.iter().position(|e| e.s_type == s_type) else {
        return Ok(None);
    };
    if model[..index].iter().any(|e| !e.copyable) {
        return Err(());
    }
    let mut out: Vec<Entry> = model[..index]
        .iter()
        .map(|e| Entry {
            at: None,
            ..e.clone()
        })
        .collect();
    out.extend(replacement);
    out.extend(model[index + 1..].iter().cloned());
    Ok(Some(out))
}

fn spliceable_of(s_type: vk::StructureType) -> Spliceable {
    spliceables()
        .into_iter()
        .find(|s| s.s_type == s_type)
        .expect("a spliceable type")
}

/// A replacement `T` with random contents (and a `pNext` that must be ignored) and its model.
fn replacement<T: vk::TaggedStructure>(case: &mut Case, rng: &mut Rng) -> (*const T, Entry) {
    let size = std::mem::size_of::<T>();
    let ignored_next = 0x10 | (rng.u64() as usize & !7);
    let buffer = random_structure(rng, T::STRUCTURE_TYPE, size, ignored_next);
    let entry = Entry {
        s_type: T::STRUCTURE_TYPE,
        size,
        copyable: COPYABLE.iter().any(|&(s, _)| s == T::STRUCTURE_TYPE),
        bytes: bytes_of(&buffer, size),
        ignored: vec![P_NEXT],
        at: None,
    };
    let pointer = buffer.as_ptr().cast::<T>();
    case.replacements.push(buffer);
    (pointer, entry)
}

/// One [`splice`] of the application's chain.
///
/// # Safety
/// `T` is one of [`spliceables`] (plain data: every bit pattern is a value).
unsafe fn splice_op<T: vk::TaggedStructure>(
    case: &mut Case,
    rng: &mut Rng,
) -> Result<String, String> {
    let head = case.head();
    let (spliced, expected) = if rng.one_in(3) {
        // SAFETY: a valid chain that outlives the splice.
        let spliced = unsafe { splice::<T>(head, None) };
        (
            spliced,
            expected_splice(&case.model, T::STRUCTURE_TYPE, None),
        )
    } else {
        let (pointer, entry) = replacement::<T>(case, rng);
        // SAFETY: as above; the replacement is a `T` of random plain data.
        let spliced = unsafe { splice(head, Some(&*pointer)) };
        (
            spliced,
            expected_splice(&case.model, T::STRUCTURE_TYPE, Some(entry)),
        )
    };
    let outcome = match (spliced, expected) {
        (None, Ok(None)) => "absent",
        (None, Err(())) => "unspliceable",
        (Some(spliced), Ok(Some(model))) => {
            // SAFETY: the spliced chain lives as long as `spliced`, the application's with it.
            unsafe { case.compare(spliced.head(), &model) }?;
            "spliced"
        }
        (spliced, expected) => {
            return Err(format!(
                "splice of {:?}: {} where the model expects {}",
                T::STRUCTURE_TYPE,
                if spliced.is_some() { "a chain" } else { "None" },
                match expected {
                    Ok(Some(_)) => "a chain",
                    Ok(None) => "None (no such structure)",
                    Err(()) => "None (a structure of unknown size before it)",
                }
            ))
        }
    };
    case.untouched()?;
    Ok(format!("splice {outcome}"))
}

/// One [`Spliced::edit`] of a chain being edited, whose model is `model`.
///
/// # Safety
/// As [`splice_op`].
unsafe fn edit_op<T: vk::TaggedStructure>(
    case: &mut Case,
    spliced: &mut Spliced,
    model: &mut Vec<Entry>,
    rng: &mut Rng,
) -> Result<String, String> {
    let padding = spliceable_of(T::STRUCTURE_TYPE).padding;
    let declines = rng.one_in(4);
    let (pointer, mut entry) = replacement::<T>(case, rng);
    entry.ignored.push(HEADER_PADDING);
    entry.ignored.extend(padding);
    let expected_seen = model
        .iter()
        .find(|e| e.s_type == T::STRUCTURE_TYPE)
        .cloned();
    let before = spliced.head();
    let mut seen = Err("the edit was not called".to_owned());
    // SAFETY: the chain and every copy outlive `spliced`; the replacement is plain data.
    let result = unsafe {
        spliced.edit(|current: &T| {
            seen = match &expected_seen {
                None => Err("the edit was called without such a structure".to_owned()),
                Some(expected) => {
                    let bytes = std::slice::from_raw_parts(
                        (current as *const T).cast::<u8>(),
                        std::mem::size_of::<T>(),
                    );
                    let differs = (0..expected.size)
                        .filter(|&i| !expected.ignored.iter().any(|r| r.contains(&i)))
                        .any(|i| bytes[i] != expected.bytes[i]);
                    if differs {
                        Err("the edit was handed another structure".to_owned())
                    } else {
                        Ok(())
                    }
                }
            };
            (!declines).then(|| std::ptr::read(pointer))
        })
    };
    match &expected_seen {
        Some(_) => seen?,
        None if seen.is_ok() => return Err("the edit was called without a structure".into()),
        None => {}
    }
    let expected = if declines || expected_seen.is_none() {
        Ok(None)
    } else {
        expected_splice(model, T::STRUCTURE_TYPE, Some(entry))
    };
    let outcome = match (result, expected) {
        (Ok(()), Ok(None)) => {
            if spliced.head() != before {
                return Err("an edit that changes nothing moved the head".into());
            }
            "unchanged"
        }
        (Err(Unspliceable), Err(())) => {
            if spliced.head() != before {
                return Err("a refused edit moved the head".into());
            }
            "refused"
        }
        (Ok(()), Ok(Some(new_model))) => {
            *model = new_model;
            "edited"
        }
        (result, expected) => {
            return Err(format!(
                "edit of {:?}: {result:?} where the model expects {}",
                T::STRUCTURE_TYPE,
                match expected {
                    Ok(_) => "Ok",
                    Err(()) => "Err(Unspliceable)",
                }
            ))
        }
    };
    // SAFETY: as above.
    let walked = unsafe { case.compare(spliced.head(), model) }?;
    // The next edit must share these copies or copy them again.
    for (entry, at) in model.iter_mut().zip(walked) {
        entry.at = Some(at);
    }
    case.untouched()?;
    Ok(format!("edit {outcome}"))
}

/// [`find`] of `T` finds the first one in a chain.
///
/// # Safety
/// `head` is a chain made of the case's structures and copies, `model` its model.
unsafe fn find_op<T: vk::TaggedStructure>(
    case: &Case,
    head: *const c_void,
    model: &[Entry],
) -> Result<(), String> {
    // SAFETY: the caller's contract.
    let found = unsafe { find::<T>(head) }.map(|t| t as *const T as usize);
    // SAFETY: as above.
    let walked: Vec<usize> = unsafe { structures(head) }
        .take(model.len() + 1)
        .map(|base| base as *const vk::BaseInStructure<'_> as usize)
        .collect();
    let expected = model
        .iter()
        .position(|e| e.s_type == T::STRUCTURE_TYPE)
        .and_then(|index| walked.get(index).copied());
    if found != expected {
        return Err(format!("find of {:?} finds another", T::STRUCTURE_TYPE));
    }
    // SAFETY: as above.
    if unsafe { has(head, T::STRUCTURE_TYPE) } != expected.is_some() {
        return Err(format!("has({:?}) is wrong", T::STRUCTURE_TYPE));
    }
    case.untouched()
}

pub static SPLICES: Counter = Counter::new("splices");
pub static EDITS: Counter = Counter::new("edits");
pub static REFUSED: Counter = Counter::new("refused");
pub static COUNTERS: &[&Counter] = &[&SPLICES, &EDITS, &REFUSED];

fn check(bytes: &[u8]) -> Result<u64, String> {
    let mut seed = [0u8; 8];
    let n = bytes.len().min(8);
    seed[..n].copy_from_slice(&bytes[..n]);
    let mut rng = Rng::new(u64::from_le_bytes(seed));
    let spliceables = spliceables();
    let mut case = Case::build(&mut rng, &spliceables);
    let mut outcomes = Vec::new();
    // SAFETY: every chain below is made of the case's structures and copies that outlive it.
    unsafe {
        case.compare(case.head(), &case.model.clone())?;
        for _ in 0..1 + rng.below(4) {
            match rng.below(3) {
                0 => {
                    let target = rng.pick(&spliceables);
                    let outcome = (target.splice)(&mut case, &mut rng)?;
                    SPLICES.add();
                    outcomes.push(outcome);
                }
                1 => {
                    let mut spliced = Spliced::of(case.head());
                    let mut model = case.model.clone();
                    for _ in 0..1 + rng.below(4) {
                        let target = rng.pick(&spliceables);
                        let outcome = (target.edit)(&mut case, &mut spliced, &mut model, &mut rng)?;
                        EDITS.add();
                        if outcome == "edit refused" {
                            REFUSED.add();
                        }
                        // Every structure the edits made is still where it was.
                        for s in &spliceables {
                            (s.find)(&case, spliced.head(), &model)?;
                        }
                        outcomes.push(outcome);
                    }
                    drop(spliced);
                    case.untouched()?;
                }
                _ => {
                    for s in &spliceables {
                        (s.find)(&case, case.head(), &case.model)?;
                    }
                }
            }
        }
    }
    case.untouched()?;
    Ok(hash_of(&outcomes))
}

fn mutate(rng: &mut Rng, _corpus: &[Vec<u8>], input: &mut Vec<u8>) {
    *input = rng.u64().to_le_bytes().to_vec();
}

pub fn target() -> Target {
    Target {
        name: "chain_splice",
        extension: "seed",
        seeds: (0u64..8).map(|s| s.to_le_bytes().to_vec()).collect(),
        mutate,
        check,
        max_len: 8,
        counters: COUNTERS,
    }
}

pub fn run() {
    // The padding the model ignores in replacements is where the types have it.
    assert_eq!(
        std::mem::size_of::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(),
        24
    );
    assert_eq!(
        std::mem::size_of::<vk::PipelineRenderingCreateInfo<'_>>(),
        40
    );
    assert_eq!(
        std::mem::offset_of!(vk::PipelineLibraryCreateInfoKHR<'_>, p_libraries),
        24
    );
    assert_eq!(
        std::mem::offset_of!(vk::ShaderModuleCreateInfo<'_>, code_size),
        24
    );
    assert_eq!(
        std::mem::offset_of!(vk::DebugUtilsObjectNameInfoEXT<'_>, object_handle),
        24
    );
    assert_eq!(
        std::mem::size_of::<vk::PipelineViewportDepthClipControlCreateInfoEXT<'_>>(),
        24
    );
    let report = super::run(target());
    if report.replay {
        return;
    }
    assert!(SPLICES.get() > 0 && EDITS.get() > 0 && REFUSED.get() > 0);
}
