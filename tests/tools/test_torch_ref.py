#!/usr/bin/python3
"""Tests of tools/bench/torch_ref.py without torch and without timing anything: its command line
(--help, bad arguments, torch missing), the parsing of bench_bnn's output, how it runs a bench
binary (fake ones, shell scripts), and the BENCH lines main() prints, with torch and the timed
network replaced by stand-ins that return fixed figures.

    python3 tests/tools/test_torch_ref.py      prints "N passed, M failed", exit 1 on failure
"""
import contextlib
import io
import os
import shutil
import subprocess
import sys
import tempfile
import types

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
SCRIPT = os.path.join(ROOT, "tools", "bench", "torch_ref.py")
sys.path.insert(0, os.path.dirname(SCRIPT))
import torch_ref  # noqa: E402  (imports torch only inside main)

C_OUT = """BENCH gemm_kernel avx512_12x32 -
BENCH fma_peak_gflops_avx512 120.0 GFLOP/s
BENCH bnn_train_step_ms_paper_b1024 20.000 ms
BENCH bnn_train_step_ms_best_paper_b1024 17.500 ms
BENCH bnn_train_gflops_paper_b1024 70.00 GFLOP/s
BENCH bnn_train_step_ms_ref_paper_b1024 300.000 ms
BENCH bnn_mc50_points_per_s_paper 3000 points/s
BENCH bnn_mc50_of_limit_paper 40.0 %
"""


def run_script(args, block_torch=True):
    """The script in a child python; with block_torch, `import torch` fails there."""
    pre = "import sys; sys.modules['torch'] = None; " if block_torch else "import sys; "
    code = pre + f"import runpy; sys.argv = [{SCRIPT!r}] + {args!r}; runpy.run_path({SCRIPT!r}, run_name='__main__')"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


def fake_bench(d, body):
    path = os.path.join(d, "bench_bnn")
    with open(path, "w") as f:
        f.write("#!/bin/sh\n" + body)
    os.chmod(path, 0o755)
    return path


@test
def test_help():
    rc, out, err = run_script(["--help"])
    check(rc == 0, f"--help exit {rc}: {err}")
    for word in ("--bench-bnn", "--rounds", "--mc-reps", "never run in CI", "bnn_predict_mc"):
        check(word in out, f"--help lacks {word}")


@test
def test_bad_arguments_exit_2():
    d = tempfile.mkdtemp()
    try:
        exe = fake_bench(d, "exit 0\n")
        plain = os.path.join(d, "plain")
        open(plain, "w").close()
        for args in (["--reps", "2"], ["--preset", "big"], ["--batch", "0"], ["--rounds", "0"],
                     ["--mc-reps", "0"], ["--bogus"], ["--bench-bnn", os.path.join(d, "none")],
                     ["--bench-bnn", plain], ["--bench-bnn", exe, "--reps", "513"]):
            rc, out, err = run_script(args)
            check(rc == 2, f"{args}: exit {rc}, not 2")
            check("error" in err, f"{args}: no message on stderr: {err!r}")
    finally:
        shutil.rmtree(d)


@test
def test_missing_torch_exits_2():
    rc, out, err = run_script(["--preset", "small"])
    check(rc == 2, f"exit {rc}")
    check("torch is not installed: python3 -m venv /tmp/torchvenv && /tmp/torchvenv/bin/pip install torch"
          in err, f"message: {err!r}")


@test
def test_parse_bench_output():
    v = torch_ref.parse_bench_output(C_OUT, "paper", 1024)
    check(v["step_ms"] == 20.0 and v["step_best_ms"] == 17.5, f"step {v}")
    check(v["mc50_pps"] == 3000.0 and v["gemm_kernel"] == "avx512_12x32", f"mc {v}")
    for preset, batch in (("small", 1024), ("paper", 512)):
        try:
            torch_ref.parse_bench_output(C_OUT, preset, batch)
            check(False, f"{preset} b{batch}: no mismatch raised")
        except torch_ref.BenchMismatch as e:
            check("preset paper at batch 1024" in str(e), f"message: {e}")
    # --bf16 compares bench_bnn's bf16 step; a binary without one is a failure, not a mismatch
    bf = C_OUT + "\nBENCH bnn_train_step_ms_paper_b1024_bf16 12.5 ms\nBENCH bnn_train_step_ms_best_paper_b1024_bf16 11.0 ms\n"
    v = torch_ref.parse_bench_output(bf, "paper", 1024, bf16=True)
    check(v["step_ms"] == 12.5 and v["step_best_ms"] == 11.0, f"bf16 step {v}")
    try:
        torch_ref.parse_bench_output(C_OUT, "paper", 1024, bf16=True)
        check(False, "missing bf16 step accepted")
    except torch_ref.BenchFailed as e:
        check("bnn_train_step_ms_paper_b1024_bf16" in str(e), f"message: {e}")
    no_mc = "\n".join(l for l in C_OUT.splitlines() if "mc50_points" not in l)
    try:
        torch_ref.parse_bench_output(no_mc, "paper", 1024)
        check(False, "missing MC line accepted")
    except torch_ref.BenchFailed as e:
        check("bnn_mc50_points_per_s_paper" in str(e), f"message: {e}")


@test
def test_cpu_model():
    d = tempfile.mkdtemp()
    try:
        p = os.path.join(d, "cpuinfo")
        with open(p, "w") as f:
            f.write("processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD EPYC 9R14\n\n"
                    "processor\t: 1\nmodel name\t: AMD EPYC 9R14\n")
        check(torch_ref.cpu_model(p) == "AMD EPYC 9R14", torch_ref.cpu_model(p))
        with open(p, "w") as f:
            f.write("processor\t: 0\nCPU implementer\t: 0x41\nCPU part\t: 0xd0c\n")
        check(torch_ref.cpu_model(p) == "implementer 0x41 part 0xd0c", torch_ref.cpu_model(p))
        check(torch_ref.cpu_model(os.path.join(d, "none")) != "", "no fallback")
    finally:
        shutil.rmtree(d)


@test
def test_run_bench_bnn():
    d = tempfile.mkdtemp()
    try:
        # the child gets --reps N and one OpenMP/MKL thread
        ok = fake_bench(d, '[ "$1 $2" = "--reps 7" ] || { echo "bad args: $*" >&2; exit 2; }\n'
                           '[ "$OMP_NUM_THREADS$MKL_NUM_THREADS" = 11 ] || { echo "threads" >&2; exit 2; }\n'
                           f"cat <<'EOF'\n{C_OUT}EOF\n")
        v = torch_ref.run_bench_bnn(ok, 7, "paper", 1024)
        check(v["step_ms"] == 20.0 and v["mc50_pps"] == 3000.0, f"{v}")
        bad = fake_bench(d, 'echo "BENCH gemm_kernel x -"; echo "bench_bnn: bnn_init failed (-22)" >&2; exit 1\n')
        try:
            torch_ref.run_bench_bnn(bad, 7, "paper", 1024)
            check(False, "failure not raised")
        except torch_ref.BenchFailed as e:
            check("bnn_init failed (-22)" in str(e) and "exit status 1" in str(e), f"message: {e}")
    finally:
        shutil.rmtree(d)


class FakeNet:
    """Stands in for TorchBnn: fixed torch figures, nothing timed."""

    def __init__(self, torch, preset, batch, bf16=False):
        pass

    def time_steps(self, reps):
        return 40.0, 35.0

    def time_mc(self, reps):
        return 2000.0


def fake_torch():
    yes = types.SimpleNamespace(is_available=lambda: True)
    return types.SimpleNamespace(
        __version__="0.0-fake", set_num_threads=lambda n: None, set_num_interop_threads=lambda n: None,
        get_num_threads=lambda: 1, get_num_interop_threads=lambda: 1,
        backends=types.SimpleNamespace(mkl=yes, mkldnn=yes, cpu=types.SimpleNamespace(get_cpu_capability=lambda: "X")))


def run_main(args):
    saved = torch_ref.import_torch, torch_ref.TorchBnn
    torch_ref.import_torch, torch_ref.TorchBnn = fake_torch, FakeNet
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = torch_ref.main(args)
    finally:
        torch_ref.import_torch, torch_ref.TorchBnn = saved
    return rc, out.getvalue(), err.getvalue()


@test
def test_main_ratio_lines():
    d = tempfile.mkdtemp()
    try:
        ok = fake_bench(d, f"cat <<'EOF'\n{C_OUT}EOF\n")
        rc, out, err = run_main(["--preset", "paper", "--reps", "5", "--bench-bnn", ok, "--rounds", "2"])
        check(rc == 0, f"exit {rc}: {err}")
        lines = set(out.splitlines())
        for want in ("BENCH torch_bnn_train_step_ms_paper_b1024 40.000 ms",
                     "BENCH torch_bnn_train_step_ms_best_paper_b1024 35.000 ms",
                     "BENCH torch_bnn_mc50_points_per_s_paper 2000 points/s",
                     "BENCH fleetsim_bnn_train_step_ms_paper_b1024 20.000 ms",
                     "BENCH fleetsim_bnn_mc50_points_per_s_paper 3000 points/s",
                     "BENCH torch_over_fleetsim_step_paper_r1 2.00 x",
                     "BENCH torch_over_fleetsim_step_paper_r2 2.00 x",
                     "BENCH torch_over_fleetsim_step_paper 2.00 x",
                     "BENCH torch_over_fleetsim_step_best_paper 2.00 x",
                     "BENCH fleetsim_over_torch_mc50_paper_r2 1.50 x",
                     "BENCH fleetsim_over_torch_mc50_paper 1.50 x",
                     "# fleetsim gemm_kernel: avx512_12x32"):
            check(want in lines, f"missing {want!r} in:\n{out}")
        check(any(l.startswith("# cpu: ") for l in lines), "no CPU line")
        check(any(l.startswith("# torch 0.0-fake: MKL yes, oneDNN yes") for l in lines), "no torch line")
        # one round without a bench: the plain torch names only
        rc, out, err = run_main(["--preset", "small", "--reps", "5"])
        bench = [l for l in out.splitlines() if l.startswith("BENCH")]
        check(rc == 0 and len(bench) == 3 and "BENCH torch_bnn_mc50_points_per_s_small 2000 points/s" in bench,
              f"exit {rc}: {out}")
    finally:
        shutil.rmtree(d)


@test
def test_main_bench_failures():
    d = tempfile.mkdtemp()
    try:
        bad = fake_bench(d, 'echo "bench_bnn: bnn_train_step failed (-5)" >&2; exit 1\n')
        rc, out, err = run_main(["--bench-bnn", bad, "--reps", "5"])
        check(rc == 1, f"failing bench: exit {rc}")
        check("bnn_train_step failed (-5)" in err, f"stderr not shown: {err!r}")
        other = fake_bench(d, f"cat <<'EOF'\n{C_OUT}EOF\n")
        rc, out, err = run_main(["--bench-bnn", other, "--preset", "small", "--reps", "5"])
        check(rc == 2 and "--preset paper" in err, f"preset mismatch: exit {rc}: {err!r}")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
