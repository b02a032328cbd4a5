// Partial sums of a weight array for its entropy (Part II eq. (1)):
// invocation i reduces xs[i * per .. (i + 1) * per] to (Σ x, Σ x ln x) in f64
// (ln in f32, as naga's f64 log is not valid SPIR-V; VULKAN.md) and counts the
// values that are negative, NaN or infinite. The host adds the partials.

struct Params {
    n: u32,
    per: u32,
    pad0: u32,
    pad1: u32,
}

var<immediate> pc: Params;

@group(0) @binding(0) var<storage, read> xs: array<f32>;
@group(0) @binding(1) var<storage, read_write> partial: array<f64>;
@group(0) @binding(2) var<storage, read_write> bad: array<u32>;

@compute @workgroup_size(64)
fn entropy(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    let start = i * pc.per;
    if start >= pc.n {
        return;
    }
    let end = min(start + pc.per, pc.n);
    var s = 0.0lf;
    var e = 0.0lf;
    var b = 0u;
    for (var k = start; k < end; k = k + 1u) {
        let x = xs[k];
        if !(x >= 0.0) || x > 3.4028234e38 {
            b = b + 1u;
            continue;
        }
        if x > 0.0 {
            s = s + f64(x);
            e = e + f64(x) * f64(log(x));
        }
    }
    partial[2u * i] = s;
    partial[2u * i + 1u] = e;
    bad[i] = b;
}
