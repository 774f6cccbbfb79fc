// The three products of training a dense layer y = act(x · W + b) on a minibatch of rows, as
// one tiled kernel: a workgroup computes a 64 × 64 tile of its output, each invocation 4 × 4
// adjacent outputs of it, stepping through the summed dimension in slices of 16 held in
// workgroup memory as vectors of 4 (one read of each operand per 16 products).
// Every output sums its products in increasing order of the summed index: the same bits on
// every run.
//
// mode 0, forward:   out[r, c] = act(Σ_d x[r, d] W[d, c] + b[c])       rows m, cols n, depth k
// mode 1, backward:  out[r, c] = (Σ_d g[r, d] W[c, d]) · act'(y[r, c]) rows m, cols k, depth n
//                    (the gradient at the previous layer's pre-activation, from its output y)
// mode 2, weights:   out[z][i, c] = Σ_{d in chunk z} x[d, i] g[d, c]    rows k, cols n
//                    (chunk z's share of ∂L/∂W; its column sums of g, ∂L/∂b, follow W's rows)

struct Params {
    mode: u32,
    rows: u32,
    cols: u32,
    depth: u32,
    // lhs[a_off + r * a_stride + d] is x (modes 0, 2) or g (mode 1).
    a_off: u32,
    a_stride: u32,
    // W's offset in rhs (modes 0, 1) and b's in aux (mode 0).
    w_off: u32,
    b_off: u32,
    activation: u32,
    // Mode 2: rows of a chunk, rows in all, and the floats between two chunks' outputs.
    chunk_rows: u32,
    batch: u32,
    out_stride: u32,
}

@group(0) @binding(0) var<storage, read> lhs: array<f32>;
@group(0) @binding(1) var<storage, read> rhs: array<f32>;
@group(0) @binding(2) var<storage, read> aux: array<f32>;
@group(0) @binding(3) var<storage, read_write> out: array<f32>;
@group(0) @binding(4) var<uniform> p: Params;

const TILE: u32 = 64u;
const SLICE: u32 = 16u;

// [SLICE][TILE / 4]: the slice of the left operand (transposed) and of the right one.
var<workgroup> xs: array<vec4<f32>, 256>;
var<workgroup> ws: array<vec4<f32>, 256>;

// The left operand at tile row r, summed index d (depth `depth`, starting at row r0 in mode 2).
fn left(r: u32, d: u32, depth: u32, r0: u32) -> f32 {
    if r >= p.rows || d >= depth {
        return 0.0;
    }
    if p.mode == 2u {
        return lhs[p.a_off + (r0 + d) * p.a_stride + r];
    }
    return lhs[p.a_off + r * p.a_stride + d];
}

// The right operand at summed index d, column c.
fn right(d: u32, c: u32, depth: u32, r0: u32) -> f32 {
    if d >= depth || c >= p.cols {
        return 0.0;
    }
    switch p.mode {
        case 0u: { return rhs[p.w_off + d * p.cols + c]; }
        case 1u: { return rhs[p.w_off + c * p.depth + d]; }
        default: { return rhs[(r0 + d) * p.cols + c]; }
    }
}

// Writes row r's four columns c0 .. c0 + 3.
fn store(r: u32, c0: u32, a: vec4<f32>, chunk: u32) {
    if r >= p.rows {
        return;
    }
    for (var j = 0u; j < 4u; j++) {
        let c = c0 + j;
        if c >= p.cols {
            return;
        }
        let at = r * p.cols + c;
        switch p.mode {
            case 0u: { out[at] = activate(a[j] + aux[p.b_off + c], p.activation); }
            case 1u: { out[at] = a[j] * slope(aux[at], p.activation); }
            default: { out[chunk * p.out_stride + p.w_off + at] = a[j]; }
        }
    }
}

@compute @workgroup_size(16, 16)
fn main(@builtin(workgroup_id) wg: vec3<u32>,
        @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let row0 = wg.y * TILE;
    let col0 = wg.x * TILE;
    // Mode 2 sums over the rows of chunk wg.z.
    let chunk = wg.z;
    var r0 = 0u;
    var depth = p.depth;
    if p.mode == 2u {
        r0 = chunk * p.chunk_rows;
        depth = min(p.chunk_rows, p.batch - r0);
    }
    // The column sums of the right operand (mode 2, first row of tiles): ∂L/∂b.
    let sums_bias = p.mode == 2u && wg.y == 0u && lid.y == 0u;
    var bias = vec4<f32>(0.0);
    // Rows 4 lid.y + i (acc_i), columns 4 lid.x + j (component j).
    var acc0 = vec4<f32>(0.0);
    var acc1 = vec4<f32>(0.0);
    var acc2 = vec4<f32>(0.0);
    var acc3 = vec4<f32>(0.0);
    for (var k0 = 0u; k0 < depth; k0 += SLICE) {
        for (var i = 0u; i < 4u; i++) {
            let at = li + i * 256u;
            // Consecutive invocations read consecutive floats of each operand.
            var r = at / SLICE;
            var kx = at % SLICE;
            if p.mode == 2u {
                r = at % TILE;
                kx = at / TILE;
            }
            xs[kx * 16u + r / 4u][r % 4u] = left(row0 + r, k0 + kx, depth, r0);
            var kw = at / TILE;
            var c = at % TILE;
            if p.mode == 1u {
                kw = at % SLICE;
                c = at / SLICE;
            }
            ws[kw * 16u + c / 4u][c % 4u] = right(k0 + kw, col0 + c, depth, r0);
        }
        workgroupBarrier();
        for (var kk = 0u; kk < SLICE; kk++) {
            let xr = xs[kk * 16u + lid.y];
            let wr = ws[kk * 16u + lid.x];
            acc0 = fma(vec4<f32>(xr.x), wr, acc0);
            acc1 = fma(vec4<f32>(xr.y), wr, acc1);
            acc2 = fma(vec4<f32>(xr.z), wr, acc2);
            acc3 = fma(vec4<f32>(xr.w), wr, acc3);
            if sums_bias {
                bias += wr;
            }
        }
        workgroupBarrier();
    }
    let r = row0 + 4u * lid.y;
    let c = col0 + 4u * lid.x;
    store(r, c, acc0, chunk);
    store(r + 1u, c, acc1, chunk);
    store(r + 2u, c, acc2, chunk);
    store(r + 3u, c, acc3, chunk);
    if sums_bias {
        // b follows W's `rows` rows in the parameters.
        for (var j = 0u; j < 4u; j++) {
            if c + j < p.cols {
                out[chunk * p.out_stride + p.w_off + p.rows * p.cols + c + j] = bias[j];
            }
        }
    }
}
