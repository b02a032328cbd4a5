// Partial sums for divergences and channel information: invocation i reduces
// k in [i * per, (i + 1) * per) to, in f64,
//   Σ w a,   Σ w a ln(a / b),   Σ w a ln a,   Σ b (only when b is indexed by k),
// with a = as[k], b = bs[k % bcols], w = ws[k / wcols] (ln in f32: naga's
// f64 log is not valid SPIR-V). Flags: 1 = some a or b negative, NaN or
// infinite; 2 = some a > 0 where b = 0 (an infinite divergence).
// H(w): a = w, b = [1], bcols = 1, w = [1], wcols = n (Σ a and Σ a ln a).
// KL(p‖q): a = p, b = q, bcols = n, w = [1], wcols = n.
// I(X;Y): a = p(y|x) row-major, b = p(y), bcols = |Y|, w = p(x), wcols = |Y|.

struct Params {
    n: u32,
    per: u32,
    bcols: u32,
    wcols: u32,
}

var<immediate> pc: Params;

@group(0) @binding(0) var<storage, read> as_: array<f32>;
@group(0) @binding(1) var<storage, read> bs: array<f32>;
@group(0) @binding(2) var<storage, read> ws: array<f32>;
@group(0) @binding(3) var<storage, read_write> partial: array<f64>;
@group(0) @binding(4) var<storage, read_write> flags: array<u32>;

fn bad(x: f32) -> bool {
    return !(x >= 0.0) || x > 3.4028234e38;
}

@compute @workgroup_size(64)
fn xlogy(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    let start = i * pc.per;
    if start >= pc.n {
        return;
    }
    let end = min(start + pc.per, pc.n);
    var sa = 0.0lf;
    var sd = 0.0lf;
    var se = 0.0lf;
    var sb = 0.0lf;
    var f = 0u;
    for (var k = start; k < end; k = k + 1u) {
        let a = as_[k];
        let b = bs[k % pc.bcols];
        let w = ws[k / pc.wcols];
        if bad(a) || bad(b) {
            f = f | 1u;
            continue;
        }
        if pc.bcols == pc.n {
            sb = sb + f64(b);
        }
        if a > 0.0 {
            let wa = f64(w) * f64(a);
            sa = sa + wa;
            se = se + wa * f64(log(a));
            if b > 0.0 {
                sd = sd + wa * f64(log(a) - log(b));
            } else if w > 0.0 {
                f = f | 2u;
            }
        }
    }
    partial[4u * i] = sa;
    partial[4u * i + 1u] = sd;
    partial[4u * i + 2u] = se;
    partial[4u * i + 3u] = sb;
    flags[i] = f;
}
