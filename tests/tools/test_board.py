#!/usr/bin/python3
"""The board tools: board_train (the image's program, built for the host exactly as the
reference of `make run-board` builds it, so no cross toolchain is needed) on good and bad
input, board_check's verdicts, board_profile's reading of board.h and of a link map, and a rule
in boards/cross.mk for every goal the top Makefile hands it."""
import os
import re
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tools", "board"))
from minitest import check, main, test  # noqa: E402

import board_check  # noqa: E402
import board_profile  # noqa: E402

BUILD = os.environ.get("BUILD_ROOT", os.path.join(ROOT, "build"))
BIN = os.path.join(BUILD, "cross-mps2-an386-mcu", "host", "board_train")
SAMPLES = os.path.join(ROOT, "tools", "board", "train_samples.bin")


def host_program():
    """Builds the host reference of the Cortex-M4 board (host gcc only) once."""
    if not getattr(host_program, "built", False):
        r = subprocess.run(["make", "--no-print-directory", "-s", "-f", "boards/cross.mk", "XBOARD=mps2-an386",
                            f"BUILD_ROOT={BUILD}", BIN], cwd=ROOT, capture_output=True, text=True)
        check(r.returncode == 0, f"building {BIN} failed:\n{r.stdout}{r.stderr}")
        host_program.built = True
    return BIN


def run(*args):
    return subprocess.run([host_program(), *args], capture_output=True, text=True, timeout=120)


def with_samples(data, *args):
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "s.bin"), "wb") as f:
            f.write(data)
        return run("--dir", d, "--samples", "s.bin", *args)


@test
def train_runs_and_reports():
    r = run("--dir", os.path.dirname(SAMPLES), "--rounds", "3", "--steps", "2", "--mc", "4")
    check(r.returncode == 0, f"exit {r.returncode}: {r.stderr}")
    rounds, res = board_check.parse_text(r.stdout)
    check(sorted(rounds) == [0, 1, 2], f"rounds {sorted(rounds)}")
    check(rounds[2][0] < rounds[0][0], "the loss falls over three rounds")
    check(res["steps"] == "6" and res["heap_growth_after_init"] == "0", f"results {res}")
    check(int(res["arena_persistent_bytes"]) + int(res["arena_scratch_bytes"]) == int(res["arena_bytes"]),
          "the arena splits into persistent and scratch")
    _, _, post = board_check.parse_text_post(r.stdout)
    check(sorted(post) == list(range(64)), f"one-pass uncertainty of the 64 points: {sorted(post)}")
    check(all(0.0 < u <= 1.0 and 0.0 < p < 1.0 for p, u in post.values()), f"shares in (0, 1]: {post}")
    check(res["post_observed"] == "2048" and float(res["post_logit_max_abs_diff"]) == 0.0,
          f"every sample summed in, the logits those of the mean pass: {res}")


@test
def train_rejects_bad_input():
    r = run("--dir", "/nonexistent-dir", "--rounds", "1")
    check(r.returncode == 1 and "cannot read train_samples.bin" in r.stderr, f"missing file: {r.stderr}")
    r = with_samples(b"\0" * 13)
    check(r.returncode == 1 and "not a whole number" in r.stderr, f"13 bytes: {r.stderr}")
    r = with_samples(struct.pack("<3f", 0.1, 0.2, 0.5))
    check(r.returncode == 1 and "sample 0 is out of range" in r.stderr, f"occ 0.5: {r.stderr}")
    r = with_samples(struct.pack("<3f", float("nan"), 0.0, 1.0))
    check(r.returncode == 1 and "out of range" in r.stderr, f"NaN: {r.stderr}")
    r = with_samples(b"\0" * 12 * (4096 + 1))
    check(r.returncode == 1 and "more than the pool" in r.stderr, f"too many: {r.stderr}")
    for args, what in ((["--rounds", "0"], "bad value for --rounds"), (["--batch", "65"], "bad value for --batch"),
                       (["--kl-weight", "x"], "bad value for --kl-weight"), (["--bogus"], "unknown option")):
        r = run(*args)
        check(r.returncode == 2 and what in r.stderr, f"{args}: exit {r.returncode}, {r.stderr}")
    r = run("--help")
    check(r.returncode == 0 and "usage: board_train" in r.stdout, "--help")


RUN = """round 0 loss 0.700000 bce 0.600000 kl 15.0 insn 10
round 1 loss 0.650000 bce 0.550000 kl 15.0 insn 10
result loss_final 0.650000
result bce_final 0.550000
"""


@test
def check_agrees_and_disagrees():
    with tempfile.TemporaryDirectory() as d:
        a, b = os.path.join(d, "a.txt"), os.path.join(d, "b.txt")
        with open(a, "w") as f:
            f.write(RUN)
        with open(b, "w") as f:
            f.write(RUN.replace("insn 10", "insn 0"))
        check(board_check.main([a, b]) == 0, "identical losses agree")
        with open(b, "w") as f:
            f.write(RUN.replace("0.650000 bce", "0.651000 bce"))
        check(board_check.main([a, b]) == 1, "a loss 1.5e-3 away disagrees")
        check(board_check.main([a, b, "--rtol", "1e-2"]) == 0, "within a wider tolerance it agrees")
        with open(b, "w") as f:
            f.write(RUN.split("result")[0])
        check(board_check.main([a, b]) == 1, "a run without its results is incomplete")
        post = "post 0 p 0.300000 unknown 5.000000e-04\npost 1 p 0.400000 unknown 2.000000e-03\n"
        with open(a, "w") as f:
            f.write(RUN + post)
        with open(b, "w") as f:
            f.write(RUN + post.replace("5.000000e-04", "5.004000e-04"))
        check(board_check.main([a, b]) == 0, "a share 8e-4 away agrees (--rtol-post 1e-3)")
        with open(b, "w") as f:
            f.write(RUN + post.replace("5.000000e-04", "5.010000e-04"))
        check(board_check.main([a, b]) == 1, "a share 2e-3 away disagrees")
        check(board_check.main([a, b, "--rtol-post", "1e-2"]) == 0, "within a wider tolerance it agrees")
        with open(b, "w") as f:
            f.write(RUN + post.split("post 1")[0])
        check(board_check.main([a, b]) == 1, "a point missing disagrees")


MAP = """Linker script and memory map

.text           0x00000000      0x130
 *(.text .text.*)
 .text.bnn_train_step
                0x00000000      0x100 /b/obj/../lib/libfirmware.a(bnn.c.o)
 .text          0x00000100       0x30 /b/obj/hal/stdc/hal_stdc.c.o
.ram_ext        0x21000000     0x1000
 .bss.fw_ai     0x21000000     0x1000 /b/lib/libfirmware.a(fw_robot.c.o)
.debug_info     0x00000000     0x9999
 .debug_info    0x00000000     0x9999 /b/obj/hal/stdc/hal_stdc.c.o
"""


@test
def every_cross_goal_has_a_rule():
    """`make cross|run-board|profile-board|hil|hil-rt` hand boards/cross.mk the goals image, run,
    profile, hil and hil-rt. A goal without a rule there is not an error to make (it is .PHONY):
    `profile` lost its rule once, and for a week `make profile-board` printed "Nothing to be
    done" and ran no board."""
    with open(os.path.join(ROOT, "boards", "cross.mk")) as f:
        text = f.read()
    for goal in ("image", "run", "profile", "hil", "hil-rt"):
        check(re.search(rf"^{re.escape(goal)}:(?!=)", text, re.M), f"boards/cross.mk has no rule for {goal}")


@test
def profile_reads_board_and_map():
    d = board_profile.board_defines(os.path.join(ROOT, "boards", "mps2-an386", "board.h"))
    check(d["BOARD_FLASH_BYTES"] == 2 * 1024 * 1024 and d["BOARD_XRAM_BASE"] == 0x21000000,
          f"board.h values {d.get('BOARD_FLASH_BYTES')}")
    with tempfile.TemporaryDirectory() as t:
        path = os.path.join(t, "x.map")
        with open(path, "w") as f:
            f.write(MAP)
        mods = board_profile.parse_map(path, "/b/obj", {".text": 0, ".ram_ext": 0})
    check(mods["firmware/bnn.c"]["text"] == 0x100, f"archive member {mods.get('firmware/bnn.c')}")
    check(mods["hal/stdc/hal_stdc.c"] == {"text": 0x30, "data": 0, "bss": 0, "owner": "HAL"},
          f"hal module {mods.get('hal/stdc/hal_stdc.c')} (debug sections are not the image)")
    check(mods["firmware/fw_robot.c"]["bss"] == 0x1000, "state in .ram_ext is bss")


@test
def profile_pairs_plugin_marks():
    log = "insn_mark 10 100\ninsn_mark 11 1100\ninsn_mark 10 1200\ninsn_mark 11 2200\n" \
          "insn_mark 20 3000\ninsn_mark 21 9000\ninsn_mark 60 9100\ninsn_mark 61 9200\n" \
          "insn_mark 50 9300\ninsn_mark 51 9400\ninsn_total 9500\n"
    with tempfile.TemporaryDirectory() as t:
        path = os.path.join(t, "insn.log")
        with open(path, "w") as f:
            f.write(log)
        res = {"steps": 4.0}
        board_profile.insn_from_marks(path, res)
        check(res["insn_train_step"] == 500 and res["insn_mc_inference"] == 6000, f"pairs {res}")
        check(res["insn_post_factor"] == 100 and res["insn_post_inference"] == 100, f"post marks {res}")
        with open(path, "w") as f:
            f.write("insn_total 5\n")
        try:
            board_profile.insn_from_marks(path, {"steps": 1.0})
            check(False, "a log without marks is an error")
        except ValueError:
            pass


CI = """graph: { title: "x.c"
node: { title: "x.c:leaf" label: "leaf\\nx.c:1:1\\n100 bytes (static)" }
node: { title: "mid" label: "mid\\nx.c:2:1\\n20 bytes (static)" }
node: { title: "top" label: "top\\nx.c:3:1\\n8 bytes (static)" }
node: { title: "small" label: "small\\nx.c:4:1\\n50 bytes (static)" }
node: { title: "__indirect_call" label: "Indirect Call Placeholder" shape : ellipse }
edge: { sourcename: "top" targetname: "mid" }
edge: { sourcename: "top" targetname: "small" }
edge: { sourcename: "mid" targetname: "x.c:leaf" }
edge: { sourcename: "mid" targetname: "memcpy" }
edge: { sourcename: "small" targetname: "__indirect_call" }
}
"""


@test
def profile_finds_the_deepest_chain():
    with tempfile.TemporaryDirectory() as t:
        with open(os.path.join(t, "x.c.ci"), "w") as f:
            f.write(CI)
        frames, calls = board_profile.call_graph(t)
    check(frames == {"x.c:leaf": 100, "mid": 20, "top": 8, "small": 50}, f"frames {frames}")
    total, chain, flags = board_profile.worst_stack("top", frames, calls)
    check(total == 128 and chain == ["top", "mid", "leaf"], f"deepest {total} {chain}")
    check(flags["indirect"] and "memcpy" in flags["unknown"] and not flags["recursion"], f"flags {flags}")


if __name__ == "__main__":
    sys.exit(main())
