// Every crossing of each line with every triangle: the watertight test of
// Woop, Benthin and Wald (2013), as `Shear::hit` in src/tracer.rs. The host
// computes the per-line shear constants and, from the numerator and
// determinant returned here, t = num / det, the facing and the patch, so the
// same arithmetic as the CPU backend decides the result.

struct Params {
    lines: u32,
    tris: u32,
    k: u32,
    pad: u32,
}

var<immediate> pc: Params;

// Triangle i: vertices in tris[3i], tris[3i + 1], tris[3i + 2] (w unused).
@group(0) @binding(0) var<storage, read> tris: array<vec4<f32>>;
// Line i: (org.xyz, tmin), (sx, sy, sz, tmax), (bitcast kx | ky << 2 | kz << 4, 0, 0, 0).
@group(0) @binding(1) var<storage, read> lines: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> counts: array<u32>;
// Hit j of line i at i * k + j: (num bits, det bits, triangle, 0).
@group(0) @binding(3) var<storage, read_write> hits: array<vec4<u32>>;

fn pick(v: vec3<f32>, k: u32) -> f32 {
    if k == 0u {
        return v.x;
    }
    if k == 1u {
        return v.y;
    }
    return v.z;
}

fn cross2(p: f32, q: f32, r: f32, s: f32) -> f32 {
    // Exact in f64 (products of two f32 fit), rounded once.
    return f32(f64(p) * f64(q) - f64(r) * f64(s));
}

@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= pc.lines {
        return;
    }
    let l0 = lines[3u * i];
    let l1 = lines[3u * i + 1u];
    let ks = bitcast<u32>(lines[3u * i + 2u].x);
    let kx = ks & 3u;
    let ky = (ks >> 2u) & 3u;
    let kz = (ks >> 4u) & 3u;
    let org = l0.xyz;
    let sx = l1.x;
    let sy = l1.y;
    let sz = l1.z;
    var n = 0u;
    for (var t = 0u; t < pc.tris; t = t + 1u) {
        let a = tris[3u * t].xyz - org;
        let b = tris[3u * t + 1u].xyz - org;
        let c = tris[3u * t + 2u].xyz - org;
        let az = pick(a, kz);
        let bz = pick(b, kz);
        let cz = pick(c, kz);
        let ax = pick(a, kx) - sx * az;
        let ay = pick(a, ky) - sy * az;
        let bx = pick(b, kx) - sx * bz;
        let by = pick(b, ky) - sy * bz;
        let cx = pick(c, kx) - sx * cz;
        let cy = pick(c, ky) - sy * cz;
        var u = cx * by - cy * bx;
        var w = bx * ay - by * ax;
        var v = ax * cy - ay * cx;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            u = cross2(cx, by, cy, bx);
            v = cross2(ax, cy, ay, cx);
            w = cross2(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            continue;
        }
        let det = u + v + w;
        if det == 0.0 {
            continue;
        }
        let num = u * sz * az + v * sz * bz + w * sz * cz;
        // A loose range test; the host applies the exact one.
        let tt = num / det;
        if tt < l0.w - 1e-3 || tt > l1.w + 1e-3 {
            continue;
        }
        if n < pc.k {
            hits[i * pc.k + n] = vec4<u32>(bitcast<u32>(num), bitcast<u32>(det), t, 0u);
        }
        n = n + 1u;
    }
    counts[i] = n;
}
