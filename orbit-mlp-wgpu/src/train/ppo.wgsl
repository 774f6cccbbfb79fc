// PPO's per-minibatch work besides the layers' products (matmul.wgsl), in the order a gradient
// step runs it: `gather` the minibatch's rows, `loss` (per row: the clipped surrogate, the
// value loss, the KL divergence and their gradients), `column_sums` of the per-row terms by
// chunk, `finish` (the gradient of every parameter from its chunks' shares), `scalars` (the
// gradient norms, the KL-adaptive learning rate, the clip factors, the step count, the running
// loss totals) and `adam`. Every sum runs in a fixed order: the same bits on every run.
//
// Parameters are flat, in the order the learner's modules visit them: the actor's layers
// (W [k, n] row-major, then b), the critic's, then the noise parameter; after them three
// slots of gradient-only values: the minibatch's mean surrogate, value loss and KL.

struct Hyper {
    // Minibatch rows, rollout rows, minibatches per epoch, action width.
    rows: u32,
    batch: u32,
    minibatches: u32,
    actions: u32,
    // Parameters (without the three loss slots); where the critic's and the noise's begin.
    params: u32,
    critic_at: u32,
    noise_at: u32,
    // Chunks of rows summed apart, and rows per chunk.
    chunks: u32,
    chunk_rows: u32,
    clipped_value_loss: u32,
    log_std: u32,
    per_network_clip: u32,
    adaptive: u32,
    clip: f32,
    value_coef: f32,
    entropy_coef: f32,
    desired_kl: f32,
    max_grad_norm: f32,
    beta_1: f32,
    beta_2: f32,
    epsilon: f32,
    // Floats per row of each section (observations, critic observations, actions, means,
    // then log-probability, advantage, return, value), and where each section begins in the
    // rollout and in the minibatch. The critic's section is the actor's where they share.
    obs_width: u32,
    critic_width: u32,
    rollout_obs: u32,
    rollout_critic: u32,
    rollout_actions: u32,
    rollout_mu: u32,
    rollout_scalars: u32,
    mb_obs: u32,
    mb_critic: u32,
    mb_actions: u32,
    mb_mu: u32,
    mb_scalars: u32,
    separate_critic: u32,
}

// The values that steps carry from one to the next, on the device.
struct Scalars {
    learning_rate: f32,
    // Adam steps taken, and minibatches done in this update.
    steps: u32,
    minibatch: u32,
    clip_actor: f32,
    clip_critic: f32,
    // Sums over this update's minibatches.
    total_value: f32,
    total_surrogate: f32,
    total_entropy: f32,
}

@group(0) @binding(0) var<uniform> h: Hyper;
@group(0) @binding(1) var<storage, read> perm: array<u32>;
@group(0) @binding(2) var<storage, read> rollout: array<f32>;
@group(0) @binding(3) var<storage, read_write> mb: array<f32>;
@group(0) @binding(4) var<storage, read> mb_in: array<f32>;
@group(0) @binding(5) var<storage, read> actor_out: array<f32>;
@group(0) @binding(6) var<storage, read> critic_out: array<f32>;
@group(0) @binding(7) var<storage, read> params_in: array<f32>;
@group(0) @binding(8) var<storage, read> old_sigma: array<f32>;
@group(0) @binding(9) var<storage, read_write> actor_grad: array<f32>;
@group(0) @binding(10) var<storage, read_write> critic_grad: array<f32>;
@group(0) @binding(11) var<storage, read_write> row_terms: array<f32>;
@group(0) @binding(12) var<storage, read> row_terms_in: array<f32>;
@group(0) @binding(13) var<storage, read_write> partials: array<f32>;
@group(0) @binding(14) var<storage, read> partials_in: array<f32>;
@group(0) @binding(15) var<storage, read_write> grads: array<f32>;
@group(0) @binding(16) var<storage, read_write> squares: array<f32>;
@group(0) @binding(17) var<storage, read> grads_in: array<f32>;
@group(0) @binding(18) var<storage, read> squares_in: array<f32>;
@group(0) @binding(19) var<storage, read_write> scal: Scalars;
@group(0) @binding(20) var<storage, read> scal_in: Scalars;
@group(0) @binding(21) var<storage, read_write> params: array<f32>;
@group(0) @binding(22) var<storage, read_write> first_moment: array<f32>;
@group(0) @binding(23) var<storage, read_write> second_moment: array<f32>;

const HALF_LOG_2PI: f32 = 0.9189385332046727;

// The action noise's standard deviation j (a scalar parameter is clamped at 1e-6).
fn sigma(j: u32) -> f32 {
    let v = params_in[h.noise_at + j];
    if h.log_std == 1u {
        return exp(v);
    }
    return max(v, 1e-6);
}

// The current minibatch's rows of every section, in the permutation's order: one invocation
// per float, so that neighbours read neighbouring floats of a row (a grid of at most the
// device's workgroups per dimension steps through larger minibatches).
@compute @workgroup_size(256)
fn gather(@builtin(global_invocation_id) id: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>) {
    let critic = select(0u, h.critic_width, h.separate_critic == 1u);
    let width = h.obs_width + critic + 2u * h.actions + 4u;
    let first = (scal_in.minibatch % h.minibatches) * h.rows;
    for (var i = id.x; i < h.rows * width; i += groups.x * 256u) {
        gather_float(first, i / width, i % width, critic);
    }
}

// Float `column` of minibatch row `r` (rollout row `perm[first + r]`).
fn gather_float(first: u32, r: u32, column: u32, critic: u32) {
    let a = h.actions;
    let src = perm[first + r];
    var c = column;
    if c < h.obs_width {
        mb[h.mb_obs + r * h.obs_width + c] = rollout[h.rollout_obs + src * h.obs_width + c];
        return;
    }
    c -= h.obs_width;
    if c < critic {
        mb[h.mb_critic + r * critic + c] = rollout[h.rollout_critic + src * critic + c];
        return;
    }
    c -= critic;
    if c < a {
        mb[h.mb_actions + r * a + c] = rollout[h.rollout_actions + src * a + c];
        return;
    }
    c -= a;
    if c < a {
        mb[h.mb_mu + r * a + c] = rollout[h.rollout_mu + src * a + c];
        return;
    }
    c -= a;
    // Log-probability, advantage, return, value: four sections of `batch` (`rows`) floats.
    mb[h.mb_scalars + c * h.rows + r] = rollout[h.rollout_scalars + c * h.batch + src];
}

// Per row: the gradients of the loss at the actor's outputs (the means) and the critic's (the
// value), and in `row_terms` [rows, actions + 3] the row's share of ∂L/∂σ and of the mean
// surrogate, value loss and KL divergence.
@compute @workgroup_size(64)
fn loss(@builtin(global_invocation_id) id: vec3<u32>) {
    let r = id.x;
    if r >= h.rows {
        return;
    }
    let a = h.actions;
    let m = f32(h.rows);
    var log_prob = -f32(a) * HALF_LOG_2PI;
    var kl = 0.0;
    for (var j = 0u; j < a; j++) {
        let s = sigma(j);
        let d = mb_in[h.mb_actions + r * a + j] - actor_out[r * a + j];
        log_prob -= d * d / (2.0 * s * s) + log(s);
        let so = old_sigma[j];
        let dm = mb_in[h.mb_mu + r * a + j] - actor_out[r * a + j];
        kl += log(s / so + 1e-5) + (so * so + dm * dm) / (2.0 * s * s) - 0.5;
    }
    let old_log_prob = mb_in[h.mb_scalars + r];
    let advantage = mb_in[h.mb_scalars + h.rows + r];
    let ret = mb_in[h.mb_scalars + 2u * h.rows + r];
    let old_value = mb_in[h.mb_scalars + 3u * h.rows + r];
    let ratio = exp(log_prob - old_log_prob);
    let eps = h.clip;
    let unclipped = -advantage * ratio;
    let clipped = -advantage * clamp(ratio, 1.0 - eps, 1.0 + eps);
    // Where the clipped term is the larger one the ratio is outside the clip range, and the
    // surrogate does not depend on it.
    let d_log_prob = select(0.0, unclipped, unclipped >= clipped) / m;
    let terms = r * (a + 3u);
    for (var j = 0u; j < a; j++) {
        let s = sigma(j);
        let d = mb_in[h.mb_actions + r * a + j] - actor_out[r * a + j];
        actor_grad[r * a + j] = d_log_prob * d / (s * s);
        row_terms[terms + j] = d_log_prob * (d * d / (s * s * s) - 1.0 / s);
    }
    let v = critic_out[r];
    var value_loss = (ret - v) * (ret - v);
    var d_value = 2.0 * (v - ret);
    if h.clipped_value_loss == 1u {
        let vc = old_value + clamp(v - old_value, -eps, eps);
        let lc = (vc - ret) * (vc - ret);
        if lc > value_loss {
            value_loss = lc;
            d_value = select(0.0, 2.0 * (vc - ret), abs(v - old_value) <= eps);
        }
    }
    critic_grad[r] = h.value_coef * d_value / m;
    row_terms[terms + a] = max(unclipped, clipped) / m;
    row_terms[terms + a + 1u] = value_loss / m;
    row_terms[terms + a + 2u] = kl / m;
}

// Chunk c's sums of the row terms' columns, into the noise parameter's and the loss slots'
// partials (they follow each other).
@compute @workgroup_size(64)
fn column_sums(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = h.actions + 3u;
    let c = id.x / width;
    let j = id.x % width;
    if c >= h.chunks {
        return;
    }
    let end = min((c + 1u) * h.chunk_rows, h.rows);
    var sum = 0.0;
    for (var r = c * h.chunk_rows; r < end; r++) {
        sum += row_terms_in[r * width + j];
    }
    partials[c * (h.params + 3u) + h.noise_at + j] = sum;
}

var<workgroup> actor_sums: array<f32, 256>;
var<workgroup> critic_sums: array<f32, 256>;

// Sums `actor_sums` and `critic_sums` in a fixed tree; the totals end in element 0.
fn reduce_sums(t: u32) {
    workgroupBarrier();
    for (var half = 128u; half > 0u; half /= 2u) {
        if t < half {
            actor_sums[t] += actor_sums[t + half];
            critic_sums[t] += critic_sums[t + half];
        }
        workgroupBarrier();
    }
}

// Each parameter's gradient: its chunks' partials summed in order; the noise parameter's with
// the entropy bonus and the chain rule through σ. Each workgroup also writes its share of the
// squared gradient norms of the actor (with the noise parameter) and of the critic.
@compute @workgroup_size(256)
fn finish(@builtin(global_invocation_id) id: vec3<u32>,
          @builtin(workgroup_id) wg: vec3<u32>,
          @builtin(local_invocation_index) t: u32) {
    let i = id.x;
    let stride = h.params + 3u;
    var g = 0.0;
    if i < stride {
        for (var c = 0u; c < h.chunks; c++) {
            g += partials_in[c * stride + i];
        }
        if i >= h.noise_at && i < h.params {
            let j = i - h.noise_at;
            let s = sigma(j);
            g -= h.entropy_coef / s;
            if h.log_std == 1u {
                g *= s;
            } else if params_in[i] < 1e-6 {
                g = 0.0;
            }
        }
        grads[i] = g;
    }
    let in_critic = i >= h.critic_at && i < h.noise_at;
    let square = select(0.0, g * g, i < h.params);
    actor_sums[t] = select(square, 0.0, in_critic);
    critic_sums[t] = select(0.0, square, in_critic);
    reduce_sums(t);
    if t == 0u {
        squares[2u * wg.x] = actor_sums[0];
        squares[2u * wg.x + 1u] = critic_sums[0];
    }
}

// One workgroup: the squared gradient norms (from `finish`'s shares), the learning rate adapted
// to the minibatch's KL (RSL-RL's rule), the clip factors, the step count and the loss totals.
@compute @workgroup_size(256)
fn scalars(@builtin(local_invocation_index) t: u32) {
    var actor = 0.0;
    var critic = 0.0;
    let groups = (h.params + 3u + 255u) / 256u;
    for (var i = t; i < groups; i += 256u) {
        actor += squares_in[2u * i];
        critic += squares_in[2u * i + 1u];
    }
    actor_sums[t] = actor;
    critic_sums[t] = critic;
    reduce_sums(t);
    if t != 0u {
        return;
    }
    let surrogate = grads_in[h.params];
    let value = grads_in[h.params + 1u];
    let kl = grads_in[h.params + 2u];
    var lr = scal.learning_rate;
    if h.adaptive == 1u {
        if kl > 2.0 * h.desired_kl {
            lr = max(lr / 1.5, 1e-5);
        } else if kl > 0.0 && kl < h.desired_kl / 2.0 {
            lr = min(lr * 1.5, 1e-2);
        }
    }
    scal.learning_rate = lr;
    if h.per_network_clip == 1u {
        scal.clip_actor = min(h.max_grad_norm / (sqrt(actor_sums[0]) + 1e-6), 1.0);
        scal.clip_critic = min(h.max_grad_norm / (sqrt(critic_sums[0]) + 1e-6), 1.0);
    } else {
        let both = min(h.max_grad_norm / (sqrt(actor_sums[0] + critic_sums[0]) + 1e-6), 1.0);
        scal.clip_actor = both;
        scal.clip_critic = both;
    }
    var entropy = f32(h.actions) * (0.5 + HALF_LOG_2PI);
    for (var j = 0u; j < h.actions; j++) {
        entropy += log(sigma(j));
    }
    scal.steps += 1u;
    scal.minibatch += 1u;
    scal.total_value += value;
    scal.total_surrogate += surrogate;
    scal.total_entropy += entropy;
}

// One Adam step of every parameter (PyTorch's arithmetic, ε inside the bias-corrected
// denominator) along its clipped gradient.
@compute @workgroup_size(256)
fn adam(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= h.params {
        return;
    }
    let in_critic = i >= h.critic_at && i < h.noise_at;
    let g = grads_in[i] * select(scal_in.clip_actor, scal_in.clip_critic, in_critic);
    let t = f32(scal_in.steps);
    let correction_2 = sqrt(1.0 - pow(h.beta_2, t));
    let step_factor = correction_2 / (1.0 - pow(h.beta_1, t));
    let eps = h.epsilon * correction_2;
    let m = first_moment[i] * h.beta_1 + g * (1.0 - h.beta_1);
    let v = second_moment[i] * h.beta_2 + g * g * (1.0 - h.beta_2);
    first_moment[i] = m;
    second_moment[i] = v;
    params[i] -= m * step_factor / (sqrt(v) + eps) * scal_in.learning_rate;
}
