//! Cheap facts read straight from SPIR-V words, without parsing the module.
//!
//! A fragment shader that writes `FragDepth` computes its own depth: the viewport flip cannot
//! reach it, so its draws into a reversed attachment would mix conventions. Finding the
//! decoration is a linear scan for one instruction, done once per shader module.

/// `OpDecorate`.
const OP_DECORATE: u32 = 71;
/// `Decoration BuiltIn`.
const DECORATION_BUILT_IN: u32 = 11;
/// `BuiltIn FragDepth`.
const BUILT_IN_FRAG_DEPTH: u32 = 22;
/// The SPIR-V magic number (first word of every module).
const MAGIC: u32 = 0x0723_0203;
/// Words in a module header.
const HEADER_WORDS: usize = 5;

/// Whether a module decorates a variable as `BuiltIn FragDepth`. A module that is not SPIR-V
/// (bad magic, truncated instruction) answers `false`: the scan never reads past the end.
pub fn writes_frag_depth(words: &[u32]) -> bool {
    if words.len() < HEADER_WORDS || words[0] != MAGIC {
        return false;
    }
    let mut at = HEADER_WORDS;
    while at < words.len() {
        let instruction = words[at];
        let count = (instruction >> 16) as usize;
        let opcode = instruction & 0xffff;
        if count == 0 || at + count > words.len() {
            return false;
        }
        if opcode == OP_DECORATE
            && count == 4
            && words[at + 2] == DECORATION_BUILT_IN
            && words[at + 3] == BUILT_IN_FRAG_DEPTH
        {
            return true;
        }
        at += count;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn module(body: &[u32]) -> Vec<u32> {
        let mut words = vec![MAGIC, 0x0001_0000, 0, 100, 0];
        words.extend_from_slice(body);
        words
    }

    #[test]
    fn finds_the_frag_depth_decoration() {
        let frag_depth = [
            (4 << 16) | OP_DECORATE,
            7,
            DECORATION_BUILT_IN,
            BUILT_IN_FRAG_DEPTH,
        ];
        let position = [(4 << 16) | OP_DECORATE, 8, DECORATION_BUILT_IN, 0];
        assert!(writes_frag_depth(&module(&frag_depth)));
        assert!(!writes_frag_depth(&module(&position)));
        // An OpName whose operand happens to hold the same numbers is not a decoration.
        let name = [(5 << 16) | 5, 7, 11, 22, 0];
        assert!(!writes_frag_depth(&module(&name)));
    }

    #[test]
    fn malformed_modules_are_not_read_past_their_end() {
        assert!(!writes_frag_depth(&[]));
        assert!(!writes_frag_depth(&[1, 2, 3, 4, 5, 6]));
        assert!(!writes_frag_depth(&module(&[(9 << 16) | OP_DECORATE, 7])));
        assert!(!writes_frag_depth(&module(&[0])));
    }
}
