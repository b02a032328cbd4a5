//! `itgfx devices`: the Vulkan devices found and the one `--backend vulkan` uses.

use itgfx_backends::vulkan::devices;

use crate::CliError;
use crate::report::Report;

/// Lists the devices.
///
/// # Errors
/// One line naming the fix when there is no Vulkan loader, driver or device.
pub fn run() -> Result<Report, CliError> {
    let (list, chosen) = devices().map_err(|e| CliError::usage(e.to_string()))?;
    let mut r = Report::new();
    let mut recs = Vec::new();
    for (i, d) in list.iter().enumerate() {
        let mut x = Report::new();
        x.text("name", d.name.clone()).text("type", d.kind).text("api_version", d.api_version.clone());
        x.count("max_storage_buffer_range", u64::from(d.max_storage_buffer_range))
            .count("max_workgroup_invocations", u64::from(d.max_workgroup_invocations))
            .count("max_shared_memory", u64::from(d.max_shared_memory))
            .count("heap_bytes", d.heap_bytes)
            .text("float64", if d.float64 { "yes" } else { "no (not usable: itgfx needs 64-bit float shaders)" })
            .text("used", if chosen == Some(i) { "yes" } else { "no" });
        recs.push(x);
    }
    match chosen {
        Some(i) => {
            let d = &list[i];
            r.text("vulkan_device", d.name.clone()).text("type", d.kind).text("api_version", d.api_version.clone());
            r.count("max_storage_buffer_range", u64::from(d.max_storage_buffer_range)).count("heap_bytes", d.heap_bytes)
        }
        None => r.text("vulkan_device", "none usable (no device has 64-bit float shaders and compute)"),
    };
    r.records("devices", recs);
    Ok(r)
}
