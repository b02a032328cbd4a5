//! Compiles the WGSL compute shaders in `shaders/` to SPIR-V with naga
//! (pure Rust: no Vulkan SDK or shader compiler needed to build).

use std::path::Path;

#[path = "src/vulkan/no_contraction.rs"]
mod no_contraction;

fn main() {
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    for name in ["trace", "xlogy", "axis_sum", "volume"] {
        let src_path = format!("shaders/{name}.wgsl");
        println!("cargo::rerun-if-changed={src_path}");
        println!("cargo::rerun-if-changed=src/vulkan/no_contraction.rs");
        let src = std::fs::read_to_string(&src_path).expect("read shader");
        let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        let caps = naga::valid::Capabilities::FLOAT64 | naga::valid::Capabilities::IMMEDIATES;
        let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{src_path}: {}", e.emit_to_string(&src)));
        let options = naga::back::spv::Options {
            lang_version: (1, 3),
            // The default polyfill doubled kernel cost on lavapipe (docs/VULKAN.md).
            zero_initialize_workgroup_memory: naga::back::spv::ZeroInitializeWorkgroupMemoryMode::None,
            force_loop_bounding: false,
            ..Default::default()
        };
        let words = naga::back::spv::write_vec(&module, &info, &options, None).expect("SPIR-V");
        // Each float operation rounded on its own, as on the CPU (no fused multiply-adds).
        let words = no_contraction::mark_no_contraction(&words);
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        std::fs::write(Path::new(&out).join(format!("{name}.spv")), bytes).expect("write SPIR-V");
    }
}
