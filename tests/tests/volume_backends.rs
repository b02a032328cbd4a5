//! Volume-casting conformance: the channel over voxels (Part VI §2.2) cast
//! by the Vulkan kernel equals the CPU caster's, bit for bit, on the
//! built-in volumes. Skipped with a printed reason where no Vulkan device
//! opens, unless `ITGFX_REQUIRE_VULKAN=1` (CI, on lavapipe) requires it.

use itgfx_backends::BackendChoice;
use itgfx_backends::backend::open_volume;
use itgfx_backends::viewpoint::{ViewpointChannel, icosphere};
use itgfx_backends::volume::builtin::built_in;
use itgfx_backends::volume::cast::VolumeCaster;
use itgfx_backends::volume::raycast::Caster;
use itgfx_backends::volume::{TransferFunction, VolumeChannelOptions, volume_channel};
use itgfx_backends::vulkan::volume::VulkanVolumeCaster;

fn vulkan_required() -> bool {
    std::env::var_os("ITGFX_REQUIRE_VULKAN").is_some_and(|v| v == "1")
}

/// The Vulkan caster over `caster` (at most `k` samples per ray on the
/// device), or `None` (skip) when there is no device and none is required.
fn vulkan<'a>(caster: &'a Caster<'a>, k: Option<usize>) -> Option<VulkanVolumeCaster<'a>> {
    match VulkanVolumeCaster::with_samples(caster, k) {
        Ok(v) => Some(v),
        Err(e) if vulkan_required() => panic!("ITGFX_REQUIRE_VULKAN=1 but Vulkan is unavailable: {e}"),
        Err(e) => {
            eprintln!("skipping the Vulkan volume caster: {e}");
            None
        }
    }
}

fn channel(backend: &dyn VolumeCaster, o: &VolumeChannelOptions) -> ViewpointChannel {
    volume_channel(backend, o, &mut |_, _| {}).unwrap()
}

/// Every row, entry and background share, compared by their bits.
fn assert_same(a: &ViewpointChannel, b: &ViewpointChannel, what: &str) {
    assert_eq!(a.starts, b.starts, "{what}: row lengths");
    assert_eq!(a.patch, b.patch, "{what}: voxels");
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.solid_angle), bits(&b.solid_angle), "{what}: visibilities");
    assert_eq!(bits(&a.background), bits(&b.background), "{what}: background");
}

#[test]
fn vulkan_rows_are_the_cpu_rows_bit_for_bit() {
    let cases = [
        ("hydrogen:3,2,0,24", "ramp", 0.5),
        ("hydrogen:2,1,1,17", "ramp", 0.35),
        ("phantom:20", "ramp", 0.5),
        ("cube:16", "step", 0.5),
        ("sphere:15", "ramp", 1.3),
        ("marschner-lobb:19", "ramp", 0.6),
    ];
    for (spec, tf, step) in cases {
        let v = built_in(spec).unwrap();
        let tf = TransferFunction::preset(tf).unwrap();
        let caster = Caster::new(&v, &tf, step);
        let o = VolumeChannelOptions { directions: icosphere(1), distance: 3.0, size: 40 };
        let cpu = channel(&caster, &o);
        assert!(cpu.patch.len() > 1000, "{spec}: the views see something");
        let Some(gpu) = vulkan(&caster, None) else { return };
        assert_eq!(gpu.name(), "vulkan");
        assert_same(&cpu, &channel(&gpu, &o), spec);
        // Few samples kept per ray: the host marches the rest of most rays.
        let short = vulkan(&caster, Some(1)).unwrap();
        assert_same(&cpu, &channel(&short, &o), &format!("{spec}, 1 sample a ray"));
        assert!(short.host_resumed() > 0, "{spec}: no ray was handed back");
    }
}

/// Several chunks per viewpoint, and a viewpoint close to the box (rays that
/// miss it, rays that graze it).
#[test]
fn chunked_and_close_views_agree() {
    let v = built_in("hydrogen:3,2,0,32").unwrap();
    let tf = TransferFunction::preset("ramp").unwrap();
    let caster = Caster::new(&v, &tf, 0.5);
    let o = VolumeChannelOptions { directions: icosphere(0), distance: 1.2, size: 300 };
    let cpu = channel(&caster, &o);
    let Some(gpu) = vulkan(&caster, Some(200)) else { return };
    assert_same(&cpu, &channel(&gpu, &o), "hydrogen 32, 300² rays at distance 1.2");
}

#[test]
fn open_names_the_backends() {
    let v = built_in("cube:8").unwrap();
    let caster = Caster::new(&v, &TransferFunction::preset("step").unwrap(), 0.5);
    assert_eq!(open_volume(BackendChoice::Cpu, &caster).unwrap().name(), "cpu");
    let e = open_volume(BackendChoice::Reference, &caster).err().unwrap();
    assert!(e.to_string().contains("cpu or vulkan backend"), "{e}");
}
