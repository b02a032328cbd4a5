// Sums along one axis of a row-major matrix, in f64: output j is
// Σ_k w_k · a[j * s1 + k * s2] for k < len, with w_k = ws[k] when
// `weighted` is 1 and 1 otherwise. Row sums: s1 = cols, s2 = 1, len = cols.
// Column sums weighted by p(x): s1 = 1, s2 = cols, len = rows. flags[j] is
// 1 when a summed value is negative, NaN or infinite.

struct Params {
    count: u32,
    len: u32,
    s1: u32,
    s2: u32,
    weighted: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

var<immediate> pc: Params;

@group(0) @binding(0) var<storage, read> as_: array<f32>;
@group(0) @binding(1) var<storage, read> ws: array<f32>;
@group(0) @binding(2) var<storage, read_write> sums: array<f64>;
@group(0) @binding(3) var<storage, read_write> flags: array<u32>;

@compute @workgroup_size(64)
fn axis_sum(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j = gid.x;
    if j >= pc.count {
        return;
    }
    var s = 0.0lf;
    var f = 0u;
    for (var k = 0u; k < pc.len; k = k + 1u) {
        let a = as_[j * pc.s1 + k * pc.s2];
        if !(a >= 0.0) || a > 3.4028234e38 {
            f = 1u;
            continue;
        }
        var w = 1.0;
        if pc.weighted == 1u {
            w = ws[k];
        }
        s = s + f64(w) * f64(a);
    }
    sums[j] = s;
    flags[j] = f;
}
