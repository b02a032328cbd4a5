// Front-to-back volume ray casting for the channel over voxels (Part VI
// §2.2): one invocation per pixel ray marches it exactly as `Caster::
// march_from` in src/volume/raycast.rs does, operation for operation in f64
// (the grid point, the trilinear value, the opacity lookup, the
// transmittance), and writes each sample of positive opacity as (grid point,
// contribution T·α). The host shares the contributions among the eight
// voxels in ray order, so the sums are the CPU backend's bit for bit. The
// host computes each ray's direction and its span in the box (so no
// trigonometry or square roots run here).
//
// A ray with more than k samples stops at its (k+1)-th and hands the host
// where it stopped (t and the transmittance in front of that sample); the
// host marches the rest with the CPU's code.

struct Params {
    rays: u32,
    k: u32,
    nx: u32,
    ny: u32,
    nz: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

var<immediate> pc: Params;

// 3: the grid scale per axis (s · spacing), 6: dims · 0.5 per
// axis, 9: lo, 10: 1/range, 11: skip_below, 12: step, 13: the early
// termination transmittance; from 16 on: the step-corrected opacity table
// (TABLE entries over the normalised scalar).
@group(0) @binding(0) var<storage, read> consts: array<f64>;
// The voxels (f32, x fastest).
@group(0) @binding(1) var<storage, read> data: array<f32>;
// Bit c of word c / 32: whether cell c (by lowest corner) can be seen.
@group(0) @binding(2) var<storage, read> cells: array<u32>;
// 0: the eye (the viewpoint's) xyz; ray i from 4 + 5i on: direction.xyz,
// the first sample's t, the box exit t1.
@group(0) @binding(3) var<storage, read> rays: array<f64>;
// Sample j of ray i at i * k + j: grid point xyz, contribution.
@group(0) @binding(4) var<storage, read_write> samples: array<f64>;
// Ray i: transmittance left (or in front of the sample where it stopped),
// and the t where it stopped.
@group(0) @binding(5) var<storage, read_write> state: array<f64>;
// Ray i: samples written, + 0x80000000 when it stopped early.
@group(0) @binding(6) var<storage, read_write> counts: array<u32>;

const TABLE: u32 = 4096u;
const TABLE_AT: u32 = 16u;
const RAYS_AT: u32 = 4u;

// Rust's `f64::clamp` (no NaN reaches it here).
fn clampf(x: f64, lo: f64, hi: f64) -> f64 {
    var y = x;
    if y < lo {
        y = lo;
    }
    if y > hi {
        y = hi;
    }
    return y;
}

struct Axis {
    base: u32,
    frac: f64,
}

// `Volume::corners` along one axis: the cell's lowest corner (clamped to the
// grid, at most n - 2) and the fraction past it.
fn axis(g: f64, n: u32) -> Axis {
    let x = clampf(g, 0.0lf, f64(n - 1u));
    let top = max(n, 2u) - 2u;
    let i = min(u32(floor(x)), top);
    var f = 0.0lf;
    if n > 1u {
        f = x - f64(i);
    }
    return Axis(i, f);
}

// `(x).round() as usize` for x >= 0: halves away from zero (WGSL's round
// goes to even). x - floor(x) is exact here.
fn round_half_up(x: f64) -> u32 {
    let f = floor(x);
    var k = u32(f);
    if x - f >= 0.5lf {
        k = k + 1u;
    }
    return k;
}

@compute @workgroup_size(64)
fn march(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = gid.x;
    if r >= pc.rays {
        return;
    }
    let ex = rays[0];
    let ey = rays[1];
    let ez = rays[2];
    let kx = consts[3];
    let ky = consts[4];
    let kz = consts[5];
    let hx = consts[6];
    let hy = consts[7];
    let hz = consts[8];
    let lo = consts[9];
    let inv_range = consts[10];
    let skip_below = consts[11];
    let step = consts[12];
    let early = consts[13];
    let dx = rays[RAYS_AT + 5u * r];
    let dy = rays[RAYS_AT + 5u * r + 1u];
    let dz = rays[RAYS_AT + 5u * r + 2u];
    var t = rays[RAYS_AT + 5u * r + 3u];
    let t1 = rays[RAYS_AT + 5u * r + 4u];
    let nx = pc.nx;
    let ny = pc.ny;
    let nz = pc.nz;
    var transmittance = 1.0lf;
    var n = 0u;
    var stopped = 0u;
    while t < t1 {
        // Volume::grid_coords(o + d t).
        let gx = (ex + dx * t) / kx + hx - 0.5lf;
        let gy = (ey + dy * t) / ky + hy - 0.5lf;
        let gz = (ez + dz * t) / kz + hz - 0.5lf;
        let ax = axis(gx, nx);
        let ay = axis(gy, ny);
        let az = axis(gz, nz);
        let cell = ax.base + nx * (ay.base + ny * az.base);
        if (cells[cell >> 5u] & (1u << (cell & 31u))) == 0u {
            t = t + step;
            continue;
        }
        // The eight corners in Volume::corners order (x fastest), weights
        // (wx · wy) · wz, the value summed in that order.
        let x1 = min(ax.base + 1u, nx - 1u);
        let y1 = min(ay.base + 1u, ny - 1u);
        let z1 = min(az.base + 1u, nz - 1u);
        let wx0 = 1.0lf - ax.frac;
        let wy0 = 1.0lf - ay.frac;
        let wz0 = 1.0lf - az.frac;
        let wx1 = ax.frac;
        let wy1 = ay.frac;
        let wz1 = az.frac;
        let r00 = nx * (ay.base + ny * az.base);
        let r10 = nx * (y1 + ny * az.base);
        let r01 = nx * (ay.base + ny * z1);
        let r11 = nx * (y1 + ny * z1);
        var value = wx0 * wy0 * wz0 * f64(data[ax.base + r00]);
        value = value + wx1 * wy0 * wz0 * f64(data[x1 + r00]);
        value = value + wx0 * wy1 * wz0 * f64(data[ax.base + r10]);
        value = value + wx1 * wy1 * wz0 * f64(data[x1 + r10]);
        value = value + wx0 * wy0 * wz1 * f64(data[ax.base + r01]);
        value = value + wx1 * wy0 * wz1 * f64(data[x1 + r01]);
        value = value + wx0 * wy1 * wz1 * f64(data[ax.base + r11]);
        value = value + wx1 * wy1 * wz1 * f64(data[x1 + r11]);
        let s = clampf((value - lo) * inv_range, 0.0lf, 1.0lf);
        if s > skip_below {
            let alpha = consts[TABLE_AT + round_half_up(s * f64(TABLE - 1u))];
            if alpha > 0.0lf {
                if n == pc.k {
                    stopped = 0x80000000u;
                    break;
                }
                let at = 4u * (r * pc.k + n);
                samples[at] = gx;
                samples[at + 1u] = gy;
                samples[at + 2u] = gz;
                samples[at + 3u] = transmittance * alpha;
                n = n + 1u;
                transmittance = transmittance * (1.0lf - alpha);
                if transmittance < early {
                    break;
                }
            }
        }
        t = t + step;
    }
    state[2u * r] = transmittance;
    state[2u * r + 1u] = t;
    counts[r] = n | stopped;
}
