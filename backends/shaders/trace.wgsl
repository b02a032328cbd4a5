// Every crossing of each line with the scene's triangles. Candidates come
// from a BVH2 (obvhs's, built on the host over the CPU backend's padded
// triangle boxes; the slab test is loosened so it can only add candidates),
// and each candidate gets the watertight test of Woop, Benthin and Wald
// (2013), as `Shear::hit` in src/tracer.rs. The host computes the per-line
// shear constants and, from the numerator and determinant returned here,
// t = num / det, the facing and the patch, so the same arithmetic as the CPU
// backend decides the result.

struct Params {
    lines: u32,
    k: u32,
    // 0: every crossing (up to k per line); 1: the closest crossing only.
    mode: u32,
    pad1: u32,
}

var<immediate> pc: Params;

// Node i: (min.xyz, bitcast prim_count), (max.xyz, bitcast first_index);
// prim_count 0 marks an inner node whose children are first and first + 1.
// Integers are never stored in f32 words: small ones are denormals, which a
// device may flush to zero.
@group(0) @binding(0) var<storage, read> nodes: array<vec4<u32>>;
// Triangle p (in leaf order): vertices in tris[3p], tris[3p + 1], tris[3p + 2].
@group(0) @binding(1) var<storage, read> tris: array<vec4<f32>>;
// Scene index of triangle p.
@group(0) @binding(2) var<storage, read> prims: array<u32>;
// Line i: (org.xyz, tmin), (sx, sy, sz, tmax), (bitcast kx | ky << 2 | kz << 4, 1/d.xyz).
@group(0) @binding(3) var<storage, read> lines: array<vec4<u32>>;
// Crossings found per line; 0xffffffff when the traversal stack overflowed.
@group(0) @binding(4) var<storage, read_write> counts: array<u32>;
// Hit j of line i at i * k + j: (num bits, det bits, triangle, 0). In mode 1
// only j = 0 is written: the crossing with the smallest t = num / det inside
// [tmin, tmax], ties to the smaller triangle (as the host sorts crossings).
@group(0) @binding(5) var<storage, read_write> hits: array<vec4<u32>>;

const STACK: u32 = 64u;

// Traversal stacks, one slice of STACK entries per invocation, in workgroup
// memory: with a function-local `array<u32, 64>` stack, lavapipe (Mesa
// 22.3.6) ran the dispatch without writing anything (seen, not explained).
var<workgroup> stacks: array<u32, 4096>;

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

// |num - q det| as the CPU would have it: exact in f64 (q det of two f32 has
// 48 bits; the difference of two nearby values with that few bits is exact).
fn residual(num: f32, det: f32, q: f32) -> f64 {
    return abs(f64(num) - f64(q) * f64(det));
}

// num / det rounded to nearest, ties to even: the CPU's f32 division. A
// device's f32 division may be off by 2.5 ulp (Vulkan's precision table) and
// the NVIDIA driver's is; the f64 quotient rounded to f32 lies within one
// ulp of the right one, which of it and its two neighbours leaves the
// smallest exact residual decides.
fn div_rn(num: f32, det: f32) -> f32 {
    let q = f32(f64(num) / f64(det));
    let b = bitcast<u32>(q);
    if q == 0.0 || (b & 0x7f800000u) == 0x7f800000u {
        return q;
    }
    var best = q;
    var r = residual(num, det, q);
    for (var s = 0u; s < 2u; s = s + 1u) {
        // The neighbours by bit pattern (same sign, one ulp each way).
        var nb = b - 1u;
        if s == 1u {
            nb = b + 1u;
        }
        let c = bitcast<f32>(nb);
        if (nb & 0x7f800000u) == 0x7f800000u {
            continue;
        }
        let rc = residual(num, det, c);
        if rc < r || (rc == r && (nb & 1u) == 0u) {
            best = c;
            r = rc;
        }
    }
    return best;
}

// (num bits, det bits, scene triangle, 1) for a crossing, w = 0 for none.
fn test_triangle(p: u32, org: vec3<f32>, s: vec3<f32>, ks: vec3<u32>, tmin: f32, tmax: f32) -> vec4<u32> {
    let a = tris[3u * p].xyz - org;
    let b = tris[3u * p + 1u].xyz - org;
    let c = tris[3u * p + 2u].xyz - org;
    let az = pick(a, ks.z);
    let bz = pick(b, ks.z);
    let cz = pick(c, ks.z);
    let ax = pick(a, ks.x) - s.x * az;
    let ay = pick(a, ks.y) - s.y * az;
    let bx = pick(b, ks.x) - s.x * bz;
    let by = pick(b, ks.y) - s.y * bz;
    let cx = pick(c, ks.x) - s.x * cz;
    let cy = pick(c, ks.y) - s.y * cz;
    var u = cx * by - cy * bx;
    var w = bx * ay - by * ax;
    var v = ax * cy - ay * cx;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = cross2(cx, by, cy, bx);
        v = cross2(ax, cy, ay, cx);
        w = cross2(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec4<u32>(0u);
    }
    let det = u + v + w;
    if det == 0.0 {
        return vec4<u32>(0u);
    }
    let num = u * s.z * az + v * s.z * bz + w * s.z * cz;
    // A loose range test; the host applies the exact one.
    let t = num / det;
    if t < tmin - 1e-3 || t > tmax + 1e-3 {
        return vec4<u32>(0u);
    }
    return vec4<u32>(bitcast<u32>(num), bitcast<u32>(det), prims[p], 1u);
}

@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = gid.x;
    if i >= pc.lines {
        return;
    }
    var found = 0u;
    let l0 = bitcast<vec4<f32>>(lines[3u * i]);
    let l1 = bitcast<vec4<f32>>(lines[3u * i + 1u]);
    let l2u = lines[3u * i + 2u];
    let l2 = bitcast<vec4<f32>>(l2u);
    let kp = l2u.x;
    let ks = vec3<u32>(kp & 3u, (kp >> 2u) & 3u, (kp >> 4u) & 3u);
    let org = l0.xyz;
    let inv = l2.yzw;
    let tmin = l0.w;
    let tmax = l1.w;
    let closest = pc.mode == 1u;
    // Mode 1: the best crossing so far, and the interval it leaves to search.
    var best = vec4<u32>(0u);
    var best_t = tmax;
    var reach = tmax;
    let base = li * STACK;
    var sp = 1u;
    stacks[base] = 0u;
    var overflow = false;
    loop {
        if sp == 0u {
            break;
        }
        sp = sp - 1u;
        let ni = stacks[base + sp];
        let lo_u = nodes[2u * ni];
        let hi_u = nodes[2u * ni + 1u];
        let lo = bitcast<vec4<f32>>(lo_u);
        let hi = bitcast<vec4<f32>>(hi_u);
        let t1 = (lo.xyz - org) * inv;
        let t2 = (hi.xyz - org) * inv;
        let near = min(t1, t2);
        let far = max(t1, t2);
        let t_near = max(max(near.x, near.y), max(near.z, tmin));
        let t_far = min(min(far.x, far.y), min(far.z, reach));
        // Loosened: a box the line grazes is kept (never culls a real hit).
        if t_near <= t_far + 1e-4 * (abs(t_far) + 1.0) {
            let count = lo_u.w;
            let first = hi_u.w;
            if count == 0u {
                if sp + 2u <= STACK {
                    stacks[base + sp] = first;
                    stacks[base + sp + 1u] = first + 1u;
                    sp = sp + 2u;
                } else {
                    overflow = true;
                    sp = 0u;
                }
            } else {
                for (var p = first; p < first + count; p = p + 1u) {
                    let h = test_triangle(p, org, l1.xyz, ks, tmin, tmax);
                    if closest {
                        if h.w == 1u {
                            // The exact test the host applies, in the same f32 division.
                            let t = div_rn(bitcast<f32>(h.x), bitcast<f32>(h.y));
                            if t >= tmin && t <= tmax {
                                if found == 0u || t < best_t || (t == best_t && h.z < best.z) {
                                    best = vec4<u32>(h.xyz, 0u);
                                    best_t = t;
                                    reach = t;
                                }
                                found = 1u;
                            }
                        }
                    } else if h.w == 1u {
                        if found < pc.k {
                            hits[i * pc.k + found] = vec4<u32>(h.xyz, 0u);
                        }
                        found = found + 1u;
                    }
                }
            }
        }
    }
    if closest && found == 1u {
        hits[i * pc.k] = best;
    }
    if overflow {
        counts[i] = 0xffffffffu;
    } else {
        counts[i] = found;
    }
}
