#!/usr/bin/env python3
"""Time the PyTorch CPU version of one BNN training step, for comparison with bench_bnn.

The same step as bnn_train_step() of firmware/ai/bnn.c: SIREN (w0 = 30) -> L Bayesian
linear layers with ReLU (w = mu + softplus(rho) * eps, one draw per step) -> linear -> logit;
BCE (from logits, mean) + kl_weight * sum over Bayesian tensors of the mean closed-form KL to
N(0, 1); backward; Adam on the mu group and on the rho group (two optimisers).

Usage: torch_bnn_step.py [--preset paper|small] [--batch 1024] [--reps 30] [--threads 1]
Prints `BENCH torch_bnn_train_step_ms_<preset>_b<batch> <ms> ms` (median) and the best
repetition. Needs torch (not a project dependency): the PyPI wheel imports once its CUDA
dependency packages are installed; only the CPU path is timed. See firmware/ai/README.md
("Same-machine PyTorch comparison") for the commands.
"""
import argparse
import statistics
import sys
import time

PRESETS = {"paper": (256, 256, 4), "small": (128, 64, 3)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), default="paper")
    ap.add_argument("--batch", type=int, default=1024)
    ap.add_argument("--reps", type=int, default=30)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    if a.batch < 1 or a.reps < 3 or a.threads < 1:
        ap.error("--batch >= 1, --reps >= 3, --threads >= 1")
    try:
        import torch
        import torch.nn.functional as F
    except Exception as e:  # noqa: BLE001 - report any import failure plainly
        print(f"torch_bnn_step: cannot import torch: {e}", file=sys.stderr)
        return 2
    torch.set_num_threads(a.threads)
    try:
        torch.set_num_interop_threads(1)
    except RuntimeError:
        pass  # already set (only possible before any parallel work)
    torch.manual_seed(0)
    S, H, L = PRESETS[a.preset]
    B = a.batch

    def U(shape, bound):
        return ((torch.rand(*shape) * 2 - 1) * bound).requires_grad_()

    w0 = U((S, 2), 0.5)
    b0 = U((S,), 0.5)
    mus, rhos = [], []
    for l in range(L):
        fan_in = S if l == 0 else H
        bound = fan_in ** -0.5
        mus += [U((H, fan_in), bound), U((H,), bound)]
        rhos += [torch.full((H, fan_in), -3.0, requires_grad=True), torch.full((H,), -3.0, requires_grad=True)]
    wo = U((1, H), H ** -0.5)
    bo = U((1,), H ** -0.5)
    opt_mu = torch.optim.Adam([w0, b0, *mus, wo, bo], lr=1e-4)
    opt_rho = torch.optim.Adam(rhos, lr=1e-4)
    xy = torch.rand(B, 2) * 2 - 1
    y = (torch.rand(B) > 0.8).float()

    def step():
        opt_mu.zero_grad(set_to_none=True)
        opt_rho.zero_grad(set_to_none=True)
        h = torch.sin(30.0 * F.linear(xy, w0, b0))
        kl = 0.0
        for l in range(L):
            wm, bm, wr, br = mus[2 * l], mus[2 * l + 1], rhos[2 * l], rhos[2 * l + 1]
            ws, bs = F.softplus(wr), F.softplus(br)
            w = wm + ws * torch.randn_like(ws)
            b = bm + bs * torch.randn_like(bs)
            h = F.relu(F.linear(h, w, b))
            for m, s in ((wm, ws), (bm, bs)):
                kl = kl + (-torch.log(s) + 0.5 * (s * s + m * m) - 0.5).mean()
        logit = F.linear(h, wo, bo).squeeze(1)
        loss = F.binary_cross_entropy_with_logits(logit, y) + 1e-4 * kl
        loss.backward()
        opt_mu.step()
        opt_rho.step()

    for _ in range(3):
        step()
    times = []
    for _ in range(a.reps):
        t0 = time.perf_counter()
        step()
        times.append(time.perf_counter() - t0)
    print(f"BENCH torch_bnn_train_step_ms_{a.preset}_b{B} {1e3 * statistics.median(times):.3f} ms")
    print(f"BENCH torch_bnn_train_step_ms_best_{a.preset}_b{B} {1e3 * min(times):.3f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
