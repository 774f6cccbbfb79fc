// The activations of the MLP kernels and their derivatives (prepended to `layer.wgsl` and
// `train/matmul.wgsl`).

// 0 none, 1 ELU, 2 SELU, 3 ReLU, 4 leaky ReLU (0.01), 5 tanh, 6 sigmoid. The exponentials
// take min(v, 0) so that a large positive pre-activation never overflows.
fn activate(v: f32, kind: u32) -> f32 {
    switch kind {
        case 1u: { return select(exp(min(v, 0.0)) - 1.0, v, v > 0.0); }
        case 2u: {
            return SELU_SCALE * select(SELU_ALPHA * (exp(min(v, 0.0)) - 1.0), v, v > 0.0);
        }
        case 3u: { return max(v, 0.0); }
        case 4u: { return select(0.01 * v, v, v > 0.0); }
        case 5u: { return tanh(v); }
        case 6u: { return 1.0 / (1.0 + exp(-v)); }
        default: { return v; }
    }
}

const SELU_SCALE: f32 = 1.0507009873554805;
const SELU_ALPHA: f32 = 1.6732632423543772;

// The activation's derivative, from its output y (each activation is monotonic, so y says on
// which side of 0 the input was).
fn slope(y: f32, kind: u32) -> f32 {
    switch kind {
        case 1u: { return select(y + 1.0, 1.0, y > 0.0); }
        case 2u: { return select(y + SELU_SCALE * SELU_ALPHA, SELU_SCALE, y > 0.0); }
        case 3u: { return select(0.0, 1.0, y > 0.0); }
        case 4u: { return select(0.01, 1.0, y > 0.0); }
        case 5u: { return 1.0 - y * y; }
        case 6u: { return y * (1.0 - y); }
        default: { return 1.0; }
    }
}
