// One dense layer of a stack of MLPs: y[z] = act(x[z] · w[z] + b[z]) for every stack z (the
// workgroups' z), x [rows, k] (its stacks `x_stride` floats apart; 0 shares one input),
// w [k, n], b [n], y [rows, n], all row-major. A workgroup computes a 64 × 64 tile of y, each
// invocation 4 × 4 of it, stepping through k in slices of 16 held in workgroup memory. Every
// output sums its k products in increasing order of k: the same bits on every run.

struct Params {
    rows: u32,
    n: u32,
    k: u32,
    x_stride: u32,
    activation: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> x: array<f32>;
@group(0) @binding(1) var<storage, read> w: array<f32>;
@group(0) @binding(2) var<storage, read> b: array<f32>;
@group(0) @binding(3) var<storage, read_write> y: array<f32>;
@group(0) @binding(4) var<uniform> p: Params;

const TILE: u32 = 64u;
const SLICE: u32 = 16u;

// [SLICE][TILE]: the slice of x (transposed) and of w.
var<workgroup> xs: array<f32, 1024>;
var<workgroup> ws: array<f32, 1024>;

// Writes row `r`'s four columns `col0 + lid.x + 16 j` of stack `z`.
fn store(z: u32, r: u32, c0: u32, a: vec4<f32>) {
    if r >= p.rows {
        return;
    }
    for (var j = 0u; j < 4u; j++) {
        let c = c0 + 16u * j;
        if c < p.n {
            y[z * p.rows * p.n + r * p.n + c] = activate(a[j] + b[z * p.n + c], p.activation);
        }
    }
}

@compute @workgroup_size(16, 16)
fn main(@builtin(workgroup_id) wg: vec3<u32>,
        @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let z = wg.z;
    let row0 = wg.y * TILE;
    let col0 = wg.x * TILE;
    let x0 = z * p.x_stride;
    let w0 = z * p.k * p.n;
    // Rows lid.y + 16 i (acc_i), columns lid.x + 16 j (component j): vectors, not an indexed
    // array, so that the driver keeps them in registers.
    var acc0 = vec4<f32>(0.0);
    var acc1 = vec4<f32>(0.0);
    var acc2 = vec4<f32>(0.0);
    var acc3 = vec4<f32>(0.0);
    for (var k0 = 0u; k0 < p.k; k0 += SLICE) {
        for (var i = 0u; i < 4u; i++) {
            let at = li + i * 256u;
            // x: 64 rows × 16 k, read along k.
            let r = at / SLICE;
            let kx = at % SLICE;
            var xv = 0.0;
            if row0 + r < p.rows && k0 + kx < p.k {
                xv = x[x0 + (row0 + r) * p.k + k0 + kx];
            }
            xs[kx * TILE + r] = xv;
            // w: 16 k × 64 columns, read along the columns.
            let kw = at / TILE;
            let c = at % TILE;
            var wv = 0.0;
            if k0 + kw < p.k && col0 + c < p.n {
                wv = w[w0 + (k0 + kw) * p.n + col0 + c];
            }
            ws[kw * TILE + c] = wv;
        }
        workgroupBarrier();
        for (var kk = 0u; kk < SLICE; kk++) {
            let xb = kk * TILE + lid.y;
            let wb = kk * TILE + lid.x;
            let xr = vec4<f32>(xs[xb], xs[xb + 16u], xs[xb + 32u], xs[xb + 48u]);
            let wr = vec4<f32>(ws[wb], ws[wb + 16u], ws[wb + 32u], ws[wb + 48u]);
            acc0 = fma(vec4<f32>(xr.x), wr, acc0);
            acc1 = fma(vec4<f32>(xr.y), wr, acc1);
            acc2 = fma(vec4<f32>(xr.z), wr, acc2);
            acc3 = fma(vec4<f32>(xr.w), wr, acc3);
        }
        workgroupBarrier();
    }
    let r = row0 + lid.y;
    let c = col0 + lid.x;
    store(z, r, c, acc0);
    store(z, r + 16u, c, acc1);
    store(z, r + 32u, c, acc2);
    store(z, r + 48u, c, acc3);
}
