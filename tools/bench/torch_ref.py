#!/usr/bin/env python3
"""PyTorch CPU reference timings of the BNN, optionally side by side with bench_bnn.

Optional, never run in CI: it needs torch, which is not a project dependency (install it in a
venv outside the repository: `python3 -m venv /tmp/torchvenv && /tmp/torchvenv/bin/pip install
torch`; the PyPI wheel pulls its CUDA packages, ~3 GB, only to import; the CPU path alone is
timed). tests/tools/test_torch_ref.py checks its command line, the parsing of bench_bnn's
output and the lines it prints, with stand-ins for torch and bench_bnn; it times nothing.

What it times, in PyTorch on the CPU (`torch.set_num_threads(--threads)`, interop 1):

* one training step, the same as bnn_train_step() of firmware/ai/bnn_train.c: SIREN (w0 = 30) ->
  L Bayesian linear layers with ReLU (w = mu + softplus(rho) * eps, ONE eps draw per step shared
  by the batch) -> linear -> logit; BCE (from logits, mean) + kl_weight (1e-4) * sum over the
  Bayesian tensors of the mean closed-form KL to N(0, 1); backward; Adam (lr 1e-4) on the mu
  group and on the rho group (two optimisers). Batch --batch random points, 3 warm-up steps,
  then --reps timed steps: median and best.
* MC-50 inference, the same work as bnn_predict_mc(): 4096 points in [-1, 1]^2, K = 50 passes;
  each pass draws one weight sample (eps for every Bayesian weight and bias, w = mu +
  softplus(rho) * eps) shared by all points and runs the forward (SIREN included) in chunks of
  --batch points, sigmoid of the logit; then the mean and population std over the K passes per
  point. Under torch.no_grad(); one K = 1 warm-up pass, then the median of --mc-reps runs.

Presets: paper = SIREN 256 -> 4 x 256, small = SIREN 128 -> 3 x 64 (firmware/ai/bnn.h).

--bf16: the step's forward and loss run under torch.autocast("cpu", dtype=torch.bfloat16)
(every F.linear in bf16, SIREN and output layer included; parameters, Adam and the backward's
accumulation in fp32 as autocast does it), and the step figures compared are bench_bnn's bf16
step, `bnn_train_step_ms_<preset>_b<B>_bf16` (and its best); every step figure printed gets the
suffix _bf16. MC-50 stays fp32 in both (fleetsim's inference is fp32 whatever the step's
precision).

With --bench-bnn PATH the same invocation also runs that bench_bnn binary (built with the same
PRESET, e.g. `make PRESET=paper` -> build/release-host-paper/bin/bench_bnn) as `PATH --reps
--reps`, with OMP_NUM_THREADS = MKL_NUM_THREADS = 1 in its environment, alternating with the
torch measurements for --rounds rounds (each round: bench_bnn, torch step, torch MC), so both
see the same machine state. From its output it takes `bnn_train_step_ms_<preset>_b<B>` (and
its `_best_` twin) and `bnn_mc50_points_per_s_<preset>` and prints the ratios: torch step ms /
fleetsim step ms, fleetsim MC points/s / torch MC points/s (above 1: fleetsim is faster).

The script pins nothing: run it under taskset, on an otherwise idle core, e.g.

    taskset -c 1 /tmp/torchvenv/bin/python tools/bench/torch_ref.py --preset paper \\
        --bench-bnn build/release-host-paper/bin/bench_bnn --reps 30 --rounds 2

Output: `#` comment lines (CPU model from /proc/cpuinfo, allowed CPUs, torch version, MKL and
oneDNN availability, bench_bnn's GEMM kernel), then `BENCH <name> <value> <unit>` lines:
    torch_bnn_train_step_ms_<preset>_b<B>        torch step, median over rounds of the medians
    torch_bnn_train_step_ms_best_<preset>_b<B>   torch step, best repetition of all rounds
    torch_bnn_mc50_points_per_s_<preset>         torch MC-50, median over rounds
and with --bench-bnn also
    fleetsim_bnn_train_step_ms_<preset>_b<B>     bench_bnn's step median (median over rounds)
    fleetsim_bnn_train_step_ms_best_<preset>_b<B>  bench_bnn's best step (best of the rounds)
    fleetsim_bnn_mc50_points_per_s_<preset>      bench_bnn's MC-50 rate (median over rounds)
    torch_over_fleetsim_step_<preset>            torch step ms / fleetsim step ms (medians;
                                                 the median of the per-round ratios)
    torch_over_fleetsim_step_best_<preset>       the same on best repetitions
    fleetsim_over_torch_mc50_<preset>            fleetsim points/s / torch points/s (the
                                                 median of the per-round ratios)
With more than one round every figure is also printed per round, its name ending in _r<i>.

Exit status: 0; 1 when bench_bnn fails (its stderr is shown) or prints no figure the script
needs; 2 on a bad argument, when torch cannot be imported, or when bench_bnn was built for
another preset or batch.
"""
import argparse
import contextlib
import os
import platform
import re
import statistics
import subprocess
import sys
import time

PRESETS = {"paper": (256, 256, 4), "small": (128, 64, 3)}  # SIREN width, hidden width, layers
MC_POINTS = 4096
MC_K = 50
KL_WEIGHT = 1e-4
LR = 1e-4
TORCH_HINT = "python3 -m venv /tmp/torchvenv && /tmp/torchvenv/bin/pip install torch"
BENCH_RE = re.compile(r"^BENCH (\S+) (\S+)(?: (.*))?$")


class BenchFailed(Exception):
    """bench_bnn could not run, exited non-zero or lacks a figure (exit status 1)."""


class BenchMismatch(Exception):
    """bench_bnn was built for another preset or batch (exit status 2)."""


def cpu_model(path="/proc/cpuinfo"):
    """The CPU's model name from /proc/cpuinfo (x86: `model name`; Arm: `Hardware`, `Model`,
    or the implementer/part ids), else platform.processor() or the machine type."""
    fields = {}
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                k, sep, v = line.partition(":")
                k, v = k.strip(), v.strip()
                if sep and v and k not in fields:
                    fields[k] = v
    except OSError:
        pass
    for k in ("model name", "Hardware", "Model", "cpu model", "cpu"):
        if k in fields:
            return fields[k]
    if "CPU implementer" in fields:
        return f"implementer {fields['CPU implementer']} part {fields.get('CPU part', '?')}"
    return platform.processor() or platform.machine() or "unknown"


def parse_bench_output(text, preset, batch, bf16=False):
    """The figures the comparison needs from bench_bnn's stdout: {'step_ms', 'step_best_ms',
    'mc50_pps', 'gemm_kernel'} (with bf16, the step figures of the bf16 step). Raises
    BenchMismatch when the binary measured another preset or batch, BenchFailed when a figure is
    missing or not a number."""
    vals = {}
    for line in text.splitlines():
        m = BENCH_RE.match(line.strip())
        if m:
            vals[m.group(1)] = m.group(2)
    sfx = "_bf16" if bf16 else ""
    step = f"bnn_train_step_ms_{preset}_b{batch}{sfx}"
    best = f"bnn_train_step_ms_best_{preset}_b{batch}{sfx}"
    mc = f"bnn_mc50_points_per_s_{preset}"
    if f"bnn_train_step_ms_{preset}_b{batch}" not in vals:
        built = [m.groups() for n in vals for m in [re.fullmatch(r"bnn_train_step_ms_([a-z0-9]+)_b(\d+)", n)] if m]
        if built:
            p, b = built[0]
            raise BenchMismatch(f"the bench binary measures preset {p} at batch {b}, not preset {preset} "
                                f"at batch {batch}: pass --preset {p} --batch {b}, or a PRESET={preset} build")
    out = {"gemm_kernel": vals.get("gemm_kernel", "?")}
    for key, name in (("step_ms", step), ("step_best_ms", best), ("mc50_pps", mc)):
        if name not in vals:
            raise BenchFailed(f"the bench binary printed no `BENCH {name}` line")
        try:
            out[key] = float(vals[name])
        except ValueError:
            raise BenchFailed(f"`BENCH {name} {vals[name]}`: not a number") from None
        if not out[key] > 0.0:
            raise BenchFailed(f"`BENCH {name} {vals[name]}`: not a positive figure")
    return out


def run_bench_bnn(path, reps, preset, batch, bf16=False):
    """Runs `path --reps reps` single-threaded (OMP/MKL_NUM_THREADS = 1) and parses its output;
    raises BenchFailed (with its stderr) when it cannot run or exits non-zero."""
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    cmd = [path, "--reps", str(reps)]
    try:
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, errors="replace")
    except OSError as e:
        raise BenchFailed(f"cannot run {path}: {e}") from None
    if p.returncode != 0:
        how = f"signal {-p.returncode}" if p.returncode < 0 else f"exit status {p.returncode}"
        err = p.stderr.strip() or "(no stderr)"
        raise BenchFailed(f"{' '.join(cmd)} failed ({how}); its stderr:\n{err}")
    return parse_bench_output(p.stdout, preset, batch, bf16)


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="torch_ref.py", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), default="paper",
                    help="network size (default paper)")
    ap.add_argument("--batch", type=int, default=1024,
                    help="training batch and MC chunk, points (default 1024, as bench_bnn)")
    ap.add_argument("--reps", type=int, default=30,
                    help="timed torch steps per round, and bench_bnn --reps (default 30)")
    ap.add_argument("--threads", type=int, default=1, help="torch intra-op threads (default 1)")
    ap.add_argument("--mc-reps", type=int, default=3, help="timed MC-50 runs per round (default 3)")
    ap.add_argument("--bench-bnn", metavar="PATH",
                    help="also run this bench_bnn binary (same preset) and print the ratios")
    ap.add_argument("--rounds", type=int, default=None,
                    help="measurement rounds (default 2 with --bench-bnn, else 1)")
    ap.add_argument("--bf16", action="store_true",
                    help="torch's step under bf16 autocast, against bench_bnn's bf16 step")
    a = ap.parse_args(argv)
    if a.batch < 1 or a.reps < 3 or a.threads < 1 or a.mc_reps < 1:
        ap.error("need --batch >= 1, --reps >= 3, --threads >= 1, --mc-reps >= 1")
    if a.rounds is None:
        a.rounds = 2 if a.bench_bnn else 1
    if a.rounds < 1:
        ap.error("need --rounds >= 1")
    if a.bench_bnn is not None:
        if a.reps > 512:
            ap.error("bench_bnn takes --reps 3..512")
        if not os.path.isfile(a.bench_bnn) or not os.access(a.bench_bnn, os.X_OK):
            ap.error(f"--bench-bnn {a.bench_bnn}: not an executable file")
    return a


def import_torch():
    """torch, or exit 2 with how to install it."""
    try:
        import torch
        return torch
    except ModuleNotFoundError as e:
        if e.name == "torch":
            print(f"torch_ref: torch is not installed: {TORCH_HINT}", file=sys.stderr)
        else:
            print(f"torch_ref: cannot import torch: {e}\n  (install it: {TORCH_HINT})", file=sys.stderr)
    except Exception as e:  # noqa: BLE001 - e.g. the wheel's CUDA libraries are missing
        print(f"torch_ref: cannot import torch: {e}\n  (install it: {TORCH_HINT})", file=sys.stderr)
    sys.exit(2)


class TorchBnn:
    """The network, its two Adam optimisers and the timed workloads."""

    def __init__(self, torch, preset, batch, bf16=False):
        import torch.nn.functional as F
        self.torch, self.F, self.bf16 = torch, F, bf16
        torch.manual_seed(0)
        S, H, L = PRESETS[preset]
        self.L, self.B = L, batch

        def U(shape, bound):
            return ((torch.rand(*shape) * 2 - 1) * bound).requires_grad_()

        self.w0 = U((S, 2), 0.5)
        self.b0 = U((S,), 0.5)
        self.mus, self.rhos = [], []
        for l in range(L):
            fan_in = S if l == 0 else H
            bound = fan_in ** -0.5
            self.mus += [U((H, fan_in), bound), U((H,), bound)]
            self.rhos += [torch.full((H, fan_in), -3.0, requires_grad=True),
                          torch.full((H,), -3.0, requires_grad=True)]
        self.wo = U((1, H), H ** -0.5)
        self.bo = U((1,), H ** -0.5)
        self.opt_mu = torch.optim.Adam([self.w0, self.b0, *self.mus, self.wo, self.bo], lr=LR)
        self.opt_rho = torch.optim.Adam(self.rhos, lr=LR)
        self.xy = torch.rand(batch, 2) * 2 - 1
        self.y = (torch.rand(batch) > 0.8).float()
        self.mc_xy = torch.rand(MC_POINTS, 2) * 2 - 1

    def step(self):
        F, torch = self.F, self.torch
        self.opt_mu.zero_grad(set_to_none=True)
        self.opt_rho.zero_grad(set_to_none=True)
        with (torch.autocast("cpu", dtype=torch.bfloat16) if self.bf16 else contextlib.nullcontext()):
            loss = self.loss()
        loss.backward()
        self.opt_mu.step()
        self.opt_rho.step()

    def loss(self):
        F, torch = self.F, self.torch
        h = torch.sin(30.0 * F.linear(self.xy, self.w0, self.b0))
        kl = 0.0
        for l in range(self.L):
            wm, bm, wr, br = self.mus[2 * l], self.mus[2 * l + 1], self.rhos[2 * l], self.rhos[2 * l + 1]
            ws, bs = F.softplus(wr), F.softplus(br)
            w = wm + ws * torch.randn_like(ws)
            b = bm + bs * torch.randn_like(bs)
            h = F.relu(F.linear(h, w, b))
            for m, s in ((wm, ws), (bm, bs)):
                kl = kl + (-torch.log(s) + 0.5 * (s * s + m * m) - 0.5).mean()
        logit = F.linear(h, self.wo, self.bo).squeeze(1)
        return F.binary_cross_entropy_with_logits(logit.float(), self.y) + KL_WEIGHT * kl

    def predict_mc(self, K=MC_K, n=MC_POINTS):
        """bnn_predict_mc: K passes, one weight sample per pass shared by every point, chunks of
        B points; (mean, population std) of the sigmoid outputs per point."""
        F, torch = self.F, self.torch
        xy, B = self.mc_xy[:n], self.B
        with torch.no_grad():
            probs = torch.empty(K, n)
            for k in range(K):
                wb = [m + F.softplus(r) * torch.randn_like(r) for m, r in zip(self.mus, self.rhos)]
                for c0 in range(0, n, B):
                    h = torch.sin(30.0 * F.linear(xy[c0:c0 + B], self.w0, self.b0))
                    for l in range(self.L):
                        h = F.relu(F.linear(h, wb[2 * l], wb[2 * l + 1]))
                    torch.sigmoid(F.linear(h, self.wo, self.bo).squeeze(1), out=probs[k, c0:c0 + B])
            std, mean = torch.std_mean(probs, dim=0, correction=0)
        return mean, std

    def time_steps(self, reps):
        """3 warm-up steps, then reps timed ones: (median, best) in ms."""
        for _ in range(3):
            self.step()
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            self.step()
            times.append(time.perf_counter() - t0)
        return 1e3 * statistics.median(times), 1e3 * min(times)

    def time_mc(self, reps):
        """One K = 1 warm-up pass, then the median points/s of reps MC-50 runs."""
        self.predict_mc(K=1)
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            mean, std = self.predict_mc()
            times.append(time.perf_counter() - t0)
            if not (bool(self.torch.isfinite(mean).all()) and bool(self.torch.isfinite(std).all())):
                raise RuntimeError("torch MC produced non-finite values")
        return MC_POINTS / statistics.median(times)


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    torch = import_torch()
    torch.set_num_threads(a.threads)
    try:
        torch.set_num_interop_threads(1)
    except RuntimeError:
        pass  # already set (only possible before any parallel work)
    P, B, R = a.preset, a.batch, a.rounds
    S, H, L = PRESETS[P]

    print(f"# cpu: {cpu_model()}")
    if hasattr(os, "sched_getaffinity"):
        print(f"# cpus allowed: {','.join(str(c) for c in sorted(os.sched_getaffinity(0)))}")
    print(f"# torch {torch.__version__}: MKL {'yes' if torch.backends.mkl.is_available() else 'no'}, "
          f"oneDNN {'yes' if torch.backends.mkldnn.is_available() else 'no'}, "
          f"CPU capability {getattr(torch.backends.cpu, 'get_cpu_capability', lambda: '?')()}; "
          f"threads {torch.get_num_threads()}, interop {torch.get_num_interop_threads()}")
    print(f"# preset {P}: SIREN {S} -> {L} x {H}; step batch {B}{' under bf16 autocast' if a.bf16 else ''}, {a.reps} reps; "
          f"MC-{MC_K} on {MC_POINTS} points in chunks of {B}, {a.mc_reps} reps; {R} round(s)")
    if a.bench_bnn:
        print(f"# fleetsim: {a.bench_bnn} --reps {a.reps} (OMP_NUM_THREADS=MKL_NUM_THREADS=1)")
        if a.threads != 1:
            print(f"# note: torch runs {a.threads} threads, bench_bnn one: the ratios compare unequal set-ups")
    sys.stdout.flush()

    net = TorchBnn(torch, P, B, a.bf16)
    X = "_bf16" if a.bf16 else ""  # suffix of the step figures
    t_step, t_best, t_mc, c_step, c_best, c_mc = [], [], [], [], [], []
    r_step, r_best, r_mc = [], [], []

    def emit(name, value, unit, rnd=None, fmt=".3f"):
        print(f"BENCH {name}{'' if rnd is None else f'_r{rnd}'} {value:{fmt}} {unit}")

    for r in range(1, R + 1):
        rnd = r if R > 1 else None
        if R > 1:
            print(f"# round {r}/{R}")
        if a.bench_bnn:
            try:
                c = run_bench_bnn(a.bench_bnn, a.reps, P, B, a.bf16)
            except BenchMismatch as e:
                print(f"torch_ref: {e}", file=sys.stderr)
                return 2
            except BenchFailed as e:
                print(f"torch_ref: {e}", file=sys.stderr)
                return 1
            if r == 1:
                print(f"# fleetsim gemm_kernel: {c['gemm_kernel']}")
            c_step.append(c["step_ms"])
            c_best.append(c["step_best_ms"])
            c_mc.append(c["mc50_pps"])
        med, best = net.time_steps(a.reps)
        t_step.append(med)
        t_best.append(best)
        t_mc.append(net.time_mc(a.mc_reps))
        if a.bench_bnn:
            r_step.append(t_step[-1] / c_step[-1])
            r_best.append(t_best[-1] / c_best[-1])
            r_mc.append(c_mc[-1] / t_mc[-1])
        if rnd is not None:
            emit(f"torch_bnn_train_step_ms_{P}_b{B}{X}", t_step[-1], "ms", rnd)
            emit(f"torch_bnn_train_step_ms_best_{P}_b{B}{X}", t_best[-1], "ms", rnd)
            emit(f"torch_bnn_mc50_points_per_s_{P}", t_mc[-1], "points/s", rnd, ".0f")
            if a.bench_bnn:
                emit(f"fleetsim_bnn_train_step_ms_{P}_b{B}{X}", c_step[-1], "ms", rnd)
                emit(f"fleetsim_bnn_train_step_ms_best_{P}_b{B}{X}", c_best[-1], "ms", rnd)
                emit(f"fleetsim_bnn_mc50_points_per_s_{P}", c_mc[-1], "points/s", rnd, ".0f")
                emit(f"torch_over_fleetsim_step_{P}{X}", r_step[-1], "x", rnd, ".2f")
                emit(f"torch_over_fleetsim_step_best_{P}{X}", r_best[-1], "x", rnd, ".2f")
                emit(f"fleetsim_over_torch_mc50_{P}", r_mc[-1], "x", rnd, ".2f")
        sys.stdout.flush()

    if R > 1:
        print(f"# over the {R} rounds: medians (best: the best repetition)")
    med = statistics.median
    emit(f"torch_bnn_train_step_ms_{P}_b{B}{X}", med(t_step), "ms")
    emit(f"torch_bnn_train_step_ms_best_{P}_b{B}{X}", min(t_best), "ms")
    emit(f"torch_bnn_mc50_points_per_s_{P}", med(t_mc), "points/s", fmt=".0f")
    if a.bench_bnn:
        emit(f"fleetsim_bnn_train_step_ms_{P}_b{B}{X}", med(c_step), "ms")
        emit(f"fleetsim_bnn_train_step_ms_best_{P}_b{B}{X}", min(c_best), "ms")
        emit(f"fleetsim_bnn_mc50_points_per_s_{P}", med(c_mc), "points/s", fmt=".0f")
        emit(f"torch_over_fleetsim_step_{P}{X}", med(r_step), "x", fmt=".2f")
        emit(f"torch_over_fleetsim_step_best_{P}{X}", min(t_best) / min(c_best), "x", fmt=".2f")
        emit(f"fleetsim_over_torch_mc50_{P}", med(r_mc), "x", fmt=".2f")
    return 0


if __name__ == "__main__":
    sys.exit(main())
