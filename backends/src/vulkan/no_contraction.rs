//! Marks every floating-point product, sum, difference and quotient of a
//! SPIR-V module `NoContraction`, so that a device computes each one as its
//! own correctly rounded operation, as the CPU backend does.
//!
//! Vulkan lets a driver fuse `a * b + c` into one fused multiply-add unless
//! the result is decorated `NoContraction` (SPIR-V 1.6 §3.20, decoration
//! 42). Lavapipe did not fuse, so the kernels matched the CPU bit for bit
//! there; the NVIDIA driver does, and an H200 gave other hits, other
//! crossings and other volume samples than the CPU (docs/VULKAN.md, *On a
//! real GPU*). naga writes no such decoration, so `build.rs` runs this pass
//! over each kernel it compiles. Included by `build.rs` and, for its tests,
//! by the library.

/// `OpDecorate`.
const OP_DECORATE: u32 = 71;
/// Decoration `NoContraction`.
const NO_CONTRACTION: u32 = 42;

/// Float arithmetic whose result a driver may contract: `OpFAdd`, `OpFSub`,
/// `OpFMul`, `OpFDiv`, `OpFRem`, `OpFMod`, `OpVectorTimesScalar`,
/// `OpMatrixTimesScalar`, `OpVectorTimesMatrix`, `OpMatrixTimesVector`,
/// `OpMatrixTimesMatrix`, `OpOuterProduct`, `OpDot`.
const CONTRACTIBLE: [u32; 13] = [129, 131, 133, 136, 140, 141, 142, 143, 144, 145, 146, 147, 148];

/// Opcodes that may precede the first type declaration (the module's
/// preamble: capabilities, imports, entry points, debug names, annotations).
const PREAMBLE: [u32; 25] =
    [2, 3, 4, 5, 6, 7, 8, 10, 11, 14, 15, 16, 17, 71, 72, 73, 74, 75, 317, 330, 331, 332, 5632, 5633, 12];

/// The `(offset, opcode, word count)` of each instruction after the header.
fn instructions(words: &[u32]) -> Vec<(usize, u32, usize)> {
    let mut out = Vec::new();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        out.push((at, words[at] & 0xffff, count));
        at += count.max(1);
    }
    out
}

/// Result ids of the contractible float instructions.
fn contractible_results(words: &[u32]) -> Vec<u32> {
    instructions(words)
        .into_iter()
        .filter(|&(_, op, count)| CONTRACTIBLE.contains(&op) && count >= 3)
        .map(|(at, _, _)| words[at + 2])
        .collect()
}

/// Ids already decorated `NoContraction`.
fn decorated(words: &[u32]) -> Vec<u32> {
    instructions(words)
        .into_iter()
        .filter(|&(at, op, count)| op == OP_DECORATE && count == 3 && words[at + 2] == NO_CONTRACTION)
        .map(|(at, _, _)| words[at + 1])
        .collect()
}

/// The module with an `OpDecorate %id NoContraction` for every contractible
/// float result, placed at the end of the annotations (before the first
/// type declaration).
///
/// # Panics
/// If the module has no type declarations (not a kernel naga wrote).
#[must_use]
pub fn mark_no_contraction(words: &[u32]) -> Vec<u32> {
    let have = decorated(words);
    let ids: Vec<u32> = contractible_results(words).into_iter().filter(|id| !have.contains(id)).collect();
    let insert = instructions(words)
        .into_iter()
        .find(|&(_, op, _)| !PREAMBLE.contains(&op))
        .map(|(at, _, _)| at)
        .expect("a SPIR-V module with type declarations");
    let mut out = Vec::with_capacity(words.len() + 3 * ids.len());
    out.extend_from_slice(&words[..insert]);
    for id in ids {
        out.extend([(3 << 16) | OP_DECORATE, id, NO_CONTRACTION]);
    }
    out.extend_from_slice(&words[insert..]);
    out
}

/// Contractible float results left without `NoContraction`.
#[cfg(test)]
#[must_use]
pub fn uncontracted(words: &[u32]) -> usize {
    let have = decorated(words);
    contractible_results(words).into_iter().filter(|id| !have.contains(id)).count()
}

#[cfg(test)]
mod tests {
    use super::{mark_no_contraction, uncontracted};

    fn words(bytes: &[u8]) -> Vec<u32> {
        bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    }

    /// Every kernel the library embeds has each float operation marked.
    #[test]
    fn every_embedded_kernel_is_marked() {
        for (name, spv) in [
            ("trace", &include_bytes!(concat!(env!("OUT_DIR"), "/trace.spv"))[..]),
            ("volume", &include_bytes!(concat!(env!("OUT_DIR"), "/volume.spv"))[..]),
            ("xlogy", &include_bytes!(concat!(env!("OUT_DIR"), "/xlogy.spv"))[..]),
            ("axis_sum", &include_bytes!(concat!(env!("OUT_DIR"), "/axis_sum.spv"))[..]),
        ] {
            let w = words(spv);
            assert_eq!(uncontracted(&w), 0, "{name}");
            assert!(!super::decorated(&w).is_empty(), "{name} has float arithmetic");
        }
    }

    /// The pass finds unmarked operations, marks each once, and is idempotent.
    #[test]
    fn the_pass_marks_a_module_once() {
        // A minimal module: header, OpCapability Shader, OpMemoryModel,
        // OpTypeFloat 32 (%1), OpConstant %1 %2 = 1.0, OpFAdd %1 %3 %2 %2 and
        // OpFMul %1 %4 %3 %3 (outside a function, enough for the pass).
        let m = vec![
            0x0723_0203,
            0x0001_0300,
            0,
            5,
            0,
            (2 << 16) | 17,
            1,
            (3 << 16) | 14,
            0,
            1,
            (3 << 16) | 22,
            1,
            32,
            (4 << 16) | 43,
            1,
            2,
            0x3f80_0000,
            (5 << 16) | 129,
            1,
            3,
            2,
            2,
            (5 << 16) | 133,
            1,
            4,
            3,
            3,
        ];
        assert_eq!(uncontracted(&m), 2);
        let once = mark_no_contraction(&m);
        assert_eq!(uncontracted(&once), 0);
        assert_eq!(once.len(), m.len() + 6);
        // The decorations sit before the first type declaration.
        assert_eq!(once[10], (3 << 16) | 71);
        assert_eq!(&once[10..16], &[(3 << 16) | 71, 3, 42, (3 << 16) | 71, 4, 42]);
        assert_eq!(mark_no_contraction(&once), once);
    }
}
