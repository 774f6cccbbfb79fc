"""PyTorch eager's PPO update on the shapes of `ppo_update_speed` (orbit-mlp-wgpu's example),
written the way rsl_rl's `PPO.update` runs it: per minibatch the forward passes, the KL read on
the host for the adaptive learning rate, the clipped surrogate and value losses with the entropy
bonus, backward, a gradient-norm clip per network and Adam. Random data: the time does not
depend on the values. Each update is timed from its first minibatch to the device's end (one
update after one of warm-up; the median of five).

    python3 tools/ppo_update_torch.py            # needs torch with CUDA
"""

import statistics
import time

import torch
from torch import nn

CONFIGS = [
    ("box pushing", 53, [256, 128, 64], 7, 4096 * 24, 10, 16),
    ("Ant", 60, [400, 200, 100], 8, 4096 * 32, 5, 4),
    ("Humanoid", 87, [400, 200, 100], 21, 4096 * 32, 5, 4),
]


def mlp(inputs, hidden, outputs):
    layers, width = [], inputs
    for h in hidden:
        layers += [nn.Linear(width, h), nn.ELU()]
        width = h
    layers.append(nn.Linear(width, outputs))
    return nn.Sequential(*layers)


def update(actor, critic, std, optimizer, data, epochs, minibatches, lr):
    obs, actions, old_mu, old_log_prob, advantages, returns, values, old_sigma = data
    batch = obs.shape[0]
    m = batch // minibatches
    perm = torch.randperm(batch, device=obs.device)
    clip, desired_kl = 0.2, 0.01
    for _ in range(epochs):
        for j in range(minibatches):
            idx = perm[j * m:(j + 1) * m]
            mu = actor(obs[idx])
            sigma = std.clamp_min(1e-6).expand_as(mu)
            dist = torch.distributions.Normal(mu, sigma)
            log_prob = dist.log_prob(actions[idx]).sum(-1)
            entropy = dist.entropy().sum(-1)
            value = critic(obs[idx]).squeeze(-1)
            with torch.inference_mode():
                kl = torch.sum(
                    torch.log(sigma / old_sigma + 1.0e-5)
                    + (old_sigma.square() + (old_mu[idx] - mu).square()) / (2.0 * sigma.square())
                    - 0.5,
                    dim=-1,
                ).mean()
                kl = kl.item()  # rsl_rl reads it on the host every minibatch
                if kl > desired_kl * 2.0:
                    lr = max(1e-5, lr / 1.5)
                elif 0.0 < kl < desired_kl / 2.0:
                    lr = min(1e-2, lr * 1.5)
                for group in optimizer.param_groups:
                    group["lr"] = lr
            ratio = torch.exp(log_prob - old_log_prob[idx])
            adv = advantages[idx]
            surrogate = torch.max(-adv * ratio, -adv * ratio.clamp(1 - clip, 1 + clip)).mean()
            clipped = values[idx] + (value - values[idx]).clamp(-clip, clip)
            value_loss = torch.max(
                (value - returns[idx]).square(), (clipped - returns[idx]).square()
            ).mean()
            loss = surrogate + value_loss - 0.005 * entropy.mean()
            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(list(actor.parameters()) + [std], 1.0)
            nn.utils.clip_grad_norm_(critic.parameters(), 1.0)
            optimizer.step()
    return lr


def main():
    device = torch.device("cuda")
    print(f"torch {torch.__version__} on {torch.cuda.get_device_name(device)}")
    for name, obs_width, hidden, num_actions, batch, epochs, minibatches in CONFIGS:
        torch.manual_seed(0)
        actor = mlp(obs_width, hidden, num_actions).to(device)
        critic = mlp(obs_width, hidden, 1).to(device)
        std = nn.Parameter(torch.ones(num_actions, device=device))
        params = list(actor.parameters()) + list(critic.parameters()) + [std]
        optimizer = torch.optim.Adam(params, lr=1e-4)
        data = (
            torch.randn(batch, obs_width, device=device),
            torch.randn(batch, num_actions, device=device),
            torch.randn(batch, num_actions, device=device),
            torch.randn(batch, device=device),
            torch.randn(batch, device=device),
            torch.randn(batch, device=device),
            torch.randn(batch, device=device),
            torch.ones(num_actions, device=device),
        )
        lr = update(actor, critic, std, optimizer, data, epochs, minibatches, 1e-4)
        times = []
        for _ in range(5):
            torch.cuda.synchronize()
            start = time.perf_counter()
            lr = update(actor, critic, std, optimizer, data, epochs, minibatches, lr)
            torch.cuda.synchronize()
            times.append(time.perf_counter() - start)
        median = statistics.median(times)
        steps = epochs * minibatches
        print(
            f"{name}: {median * 1e3:.1f} ms per update ({steps} steps of {batch // minibatches}"
            f" rows; {median * 1e3 / steps:.3f} ms per step)"
        )


if __name__ == "__main__":
    main()
