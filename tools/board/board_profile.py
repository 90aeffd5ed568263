#!/usr/bin/python3
"""The profile of a board's image in an embedded engineer's units (make profile-board):
results/board-<name>/profile.md and profile.json, and BENCH lines on stdout.

    tools/board/board_profile.py --board NAME --preset P --board-h boards/NAME/board.h \\
        --elf IMAGE --map IMAGE.map --obj OBJDIR --cross PREFIX --run run.txt --out DIR

From the link map: text, data and bss per module (what the linker kept) and per core; the
memory regions against the part's sizes. From -fstack-usage (OBJDIR/**/*.su): the largest
frames; from the run: the main stack's measured high-water mark. From the run (board_train
under QEMU -icount): instructions per training step, per 50-pass inference, per fp32 and
int8 mean-weight pass, per one-pass uncertainty (bnn_post: its prediction, its factor once
per map, its sum over the samples), and the cycle and time estimates at the part's clock (an assumption
on cycles per instruction, stated). Then what the robot can afford, and published figures
of small networks on the same cores for comparison."""
import argparse
import json
import os
import re
import subprocess
import sys

# Cycles per instruction assumed for the estimates: a single-issue Cortex-M retires most
# instructions in one cycle from zero-wait memory; flash wait states, SDRAM latency and
# multi-cycle FP divide and square root raise that. The range is the estimate's honesty.
CPI_LOW, CPI_MID, CPI_HIGH = 1.0, 1.25, 1.5
SCAN_HZ, SAMPLES_PER_SCAN = 10, 500        # the RT core: 20 beams x 25 points per scan at 10 Hz
PRIMAL_STEPS = 5                           # DiNNO's B (optimiser steps per round), default
PUBLISHED = [
    ("MLPerf Tiny v0.5, anomaly detection (FC autoencoder, ~266k parameters, int8, TFLM)",
     "Cortex-M4F 120 MHz (NUCLEO-L4R5ZI, 640 KB SRAM)",
     "10.05 ms per inference, about 4.5 cycles per int8 multiply-accumulate",
     "Banbury et al., MLPerf Tiny Benchmark, NeurIPS Datasets and Benchmarks 2021; MLCommons Tiny v0.5 results"),
    ("CMSIS-NN int8 kernels", "Cortex-M4/M7",
     "4.6x the throughput and 4.9x the energy efficiency of a float baseline",
     "Lai, Suda, Chandra, CMSIS-NN: Efficient Neural Network Kernels for Arm Cortex-M CPUs, arXiv:1801.06601, 2018"),
    ("Tiny Training Engine (MCUNetV3): on-device training", "Cortex-M7 (STM32F746)",
     "trains within 256 KB of SRAM and 1 MB of flash",
     "Lin et al., On-Device Training Under 256KB Memory, NeurIPS 2022"),
    ("TinyTL: training memory", "MCU-class",
     "up to 6.5x less training memory than fine-tuning the whole network (frozen weights, biases and lite residuals learnt)",
     "Cai et al., TinyTL: Reduce Memory, Not Parameters for Efficient On-Device Learning, NeurIPS 2020"),
]


def board_defines(path):
    """Integer #defines of board.h (suffixes u/U dropped, simple arithmetic evaluated)."""
    out = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = re.match(r"\s*#define\s+(\w+)\s+(.+?)\s*(/\*.*)?$", line)
            if not m:
                continue
            expr = re.sub(r"(?<=[0-9a-fA-Fx])[uU]\b", "", m.group(2))
            if re.fullmatch(r"[0-9a-fA-Fx()*+ /-]+", expr):
                try:
                    out[m.group(1)] = int(eval(expr, {"__builtins__": {}}))  # digits and operators only
                except (SyntaxError, ZeroDivisionError, TypeError):
                    pass
    return out


def run_results(path):
    res, rounds = {}, 0
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            m = re.match(r"^result (\w+) (\S+)(?: of (\d+))?", line)
            if m:
                res[m.group(1)] = float(m.group(2))
                if m.group(3):
                    res[m.group(1) + "_size"] = float(m.group(3))
            if line.startswith("round "):
                rounds += 1
    if "loss_final" not in res:
        raise ValueError(f"{path}: not a complete board_train run")
    res["rounds"] = rounds
    return res


def cores_section(r, prof):
    """The RT and GP cores started beside the AI work (board_train --rt-hz/--gp-hz) on a target
    with a scheduler: their wake-up lateness in the target's time, deadlines missed, stacks."""
    md = ["## Cores while the AI core trains", ""]
    if "rt_ticks" not in r and "gp_ticks" not in r:
        return md + ["Not measured: this target has no scheduler of its own (a Linux board runs the host HAL's "
                     "threads), so the AI core's work ran alone.", ""]
    md += ["The RT and GP cores ran beside the AI core's work, preempting it (priorities RT > GP > AI), released "
           "at whole periods of the board's time; each wake-up's lateness is the target's time from its release "
           "to the core running (the tick interrupt, the switch), in virtual time under `-icount` (1 ns per "
           "instruction). A deadline is missed when a core wakes after its next release.", "",
           "| core | period | ticks | lateness mean / max | deadlines missed | stack used |",
           "|---|---:|---:|---:|---:|---:|"]
    prof["cores"] = {}
    for core in ("rt", "gp"):
        if f"{core}_ticks" not in r:
            continue
        e = {k: r.get(f"{core}_{k}") for k in ("period_us", "ticks", "late_mean_ns", "late_max_ns",
                                               "deadline_misses")}
        e["stack_used"], e["stack_size"] = r.get(f"stack_{core}_used"), r.get(f"stack_{core}_used_size")
        prof["cores"][core] = e
        stack = f"{int(e['stack_used']):,} of {int(e['stack_size']):,} B" if e["stack_used"] is not None else "-"
        md.append(f"| {core.upper()} | {int(e['period_us']):,} us | {int(e['ticks']):,} | "
                  f"{e['late_mean_ns']:.0f} / {int(e['late_max_ns']):,} ns | {int(e['deadline_misses'])} | {stack} |")
    return md + [""]


MARKS = {10: "insn_train_round", 20: "insn_mc_inference", 30: "insn_fp32_inference", 40: "insn_int8_inference",
         50: "insn_post_inference", 60: "insn_post_factor", 70: "insn_post_observe"}
POST_GOAL = 1 / 20  # the one-pass uncertainty's instructions against MC-50's, at most


def insn_from_marks(path, res):
    """Adds the instruction counts of a Linux board's run from the QEMU plugin's log
    (tools/board/qemu_insn.c): pairs of marks begin (id) and end (id + 1) around the work
    board_train measures, summed per kind, as the Cortex-M images print them."""
    sums, begin = {}, {}
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            m = re.match(r"^insn_mark (\d+) (\d+)$", line.strip())
            if not m:
                continue
            mid, n = int(m.group(1)), int(m.group(2))
            if mid in MARKS:
                begin[mid] = n
            elif mid - 1 in begin:
                key = MARKS[mid - 1]
                sums[key] = sums.get(key, 0) + n - begin.pop(mid - 1)
    if "insn_train_round" not in sums:
        raise ValueError(f"{path}: no instruction marks (was the run made with the QEMU plugin?)")
    res["insn_train_step"] = sums.pop("insn_train_round") / max(res["steps"], 1)
    res.update(sums)


def module_of(path, objdir):
    """The source a map file's input belongs to, and its owner (core, HAL, library)."""
    m = re.search(r"lib(\w+)\.a\(([^)]+)\)$", path)
    if m and m.group(1) == "firmware":
        member = m.group(2)[:-2]  # x.c.o -> x.c
        for root, _, files in os.walk(os.path.join(objdir, "firmware")):
            if m.group(2) in files:
                src = os.path.relpath(os.path.join(root, member), objdir)
                break
        else:
            src = "firmware/" + member
    elif m:
        return f"lib{m.group(1)} (toolchain)", "C library"
    elif "/obj/" in path:
        src = path.split("/obj/", 1)[1][:-2]
    else:
        return os.path.basename(path), "C library"
    parts = src.split("/")
    if parts[0] == "firmware":
        owner = {"rt": "RT core", "gp": "GP core", "ai": "AI core"}.get(parts[1], "links, image")
    elif parts[0] == "hal":
        owner = "HAL"
    else:
        owner = "image program"
    return src, owner


def kind_of(section):
    if section in (".bss", ".ram_ext", ".tbss", ".sbss") or section.startswith(".bss"):
        return "bss"
    if section in (".data", ".tdata", ".got", ".got.plt", ".init_array", ".fini_array",
                   ".preinit_array", ".data.rel.ro"):
        return "data"
    return "text"


def parse_map(path, objdir, alloc):
    """{module: {text, data, bss, owner}} from the input sections the linker kept in the
    allocated output sections `alloc` (debug information is not part of the image)."""
    mods = {}
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.read().split("\n")
    try:
        start = lines.index("Linker script and memory map")
    except ValueError:
        start = 0
    out_sec, pending = None, None
    for line in lines[start:]:
        m = re.match(r"^(\.\S+)\s+0x[0-9a-f]+\s+0x[0-9a-f]+", line) or re.match(r"^(\.\S+)\s*$", line)
        if m and not line.startswith(" "):
            out_sec, pending = m.group(1), None
            continue
        if out_sec is None:
            continue
        m = re.match(r"^ (\S+)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$", line)
        name = None
        if m:
            name, size, src = m.group(1), int(m.group(3), 16), m.group(4)
        else:
            m2 = re.match(r"^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*\.o\)?|\S+\.a\([^)]*\))$", line)
            if m2 and pending:
                name, size, src = pending, int(m2.group(2), 16), m2.group(3)
            m3 = re.match(r"^ (\.\S+)\s*$", line)
            pending = m3.group(1) if m3 else None
        if name is None or size == 0 or name.startswith("*") or out_sec not in alloc:
            continue
        mod, owner = module_of(src.strip(), objdir)
        e = mods.setdefault(mod, {"text": 0, "data": 0, "bss": 0, "owner": owner})
        e[kind_of(out_sec)] += size
    return mods


def sections(elf, cross):
    out = subprocess.run([cross + "size", "-A", elf], check=True, capture_output=True, text=True).stdout
    secs = {}
    for line in out.splitlines():
        m = re.match(r"^(\.\S+)\s+(\d+)\s+(\d+)", line)
        if m and not m.group(1).startswith((".debug", ".comment", ".ARM.attributes")):
            secs[m.group(1)] = (int(m.group(2)), int(m.group(3)))
    return secs


def stack_frames(objdir):
    frames = []
    for root, _, files in os.walk(objdir):
        for fn in files:
            if fn.endswith(".su"):
                with open(os.path.join(root, fn), encoding="utf-8") as f:
                    for line in f:
                        parts = line.rstrip("\n").split("\t")
                        if len(parts) == 3 and parts[1].isdigit():
                            where = parts[0].split(":")
                            src = os.path.relpath(os.path.join(root, fn[:-5]), objdir)
                            frames.append((int(parts[1]), f"{where[-1]} ({src})", parts[2]))
    return sorted(frames, reverse=True)


# The loops of the three cores (common/fw_core.h: the runner calls tick() through a pointer).
CORE_ROOTS = (("RT", "rt_core_tick"), ("GP", "gp_core_tick"), ("AI", "ai_core_tick"))


def call_graph(objdir):
    """Frames and direct calls from GCC's -fcallgraph-info=su files (OBJDIR/**/*.ci):
    ({function: bytes}, {function: {callees}}). Static functions are named file:function."""
    frames, calls = {}, {}
    node = re.compile(r'node: \{ title: "([^"]+)" label: "[^"]*?\\n[^"]*?\\n(\d+) bytes')
    edge = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
    for root, _, files in os.walk(objdir):
        for fn in files:
            if fn.endswith(".ci"):
                with open(os.path.join(root, fn), encoding="utf-8", errors="replace") as f:
                    for line in f:
                        m = node.match(line)
                        if m:
                            frames[m.group(1)] = int(m.group(2))
                        m = edge.match(line)
                        if m:
                            calls.setdefault(m.group(1), set()).add(m.group(2))
    return frames, calls


def worst_stack(root, frames, calls):
    """Deepest chain of direct calls from root: (bytes, chain, indirect calls met, calls into
    code without a frame figure (the C library), recursion met)."""
    memo, flags = {}, {"indirect": False, "unknown": set(), "recursion": False}

    def walk(f, stack):
        if f in memo:
            return memo[f]
        if f in stack:
            flags["recursion"] = True
            return 0, []
        if f == "__indirect_call":
            flags["indirect"] = True
            return 0, []
        if f not in frames:
            flags["unknown"].add(f.split(":")[-1])
            return 0, []
        best = (0, [])
        for c in sorted(calls.get(f, ())):
            best = max(best, walk(c, stack | {f}), key=lambda t: t[0])
        memo[f] = (frames[f] + best[0], [f.split(":")[-1]] + best[1])
        return memo[f]

    total, chain = walk(root, frozenset())
    return total, chain, flags


def kb(n):
    return f"{n / 1024:,.1f} KB" if n < 1024 * 1024 else f"{n / 1048576:,.2f} MB"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for a in ("--board", "--preset", "--board-h", "--elf", "--map", "--obj", "--run", "--out"):
        ap.add_argument(a, required=True)
    ap.add_argument("--cross", default="", help="toolchain prefix of size (e.g. arm-none-eabi-)")
    ap.add_argument("--insn-log", help="QEMU plugin log with the instruction marks (Linux boards)")
    a = ap.parse_args(argv)
    try:
        d = board_defines(a.board_h)
        r = run_results(a.run)
        if a.insn_log:
            insn_from_marks(a.insn_log, r)
        secs = sections(a.elf, a.cross)
        mods = parse_map(a.map, a.obj, secs)
    except (OSError, ValueError, subprocess.CalledProcessError) as e:
        print(f"board_profile: {e}", file=sys.stderr)
        return 1
    frames = stack_frames(a.obj)
    bare = "BOARD_FLASH_BYTES" in d
    clock = d.get("BOARD_PART_CLOCK_HZ", 0)
    prof = {"board": a.board, "preset": a.preset, "part_clock_hz": clock, "run": r}
    md = [f"# Board profile: {a.board} (preset `{a.preset}`)", ""]
    md.append(f"Written by `make profile-board BOARD={a.board}` (tools/board/board_profile.py) from the image "
              f"`{os.path.basename(a.elf)}`, its link map, the compiler's `-fstack-usage` files and one run of "
              f"`board_train` ({int(r['rounds'])} DiNNO rounds x {int(r['steps'] / max(r['rounds'], 1))} steps, "
              f"batch {int(r['batch'])}, {int(r['parameters']):,} parameters).")
    md.append("")

    # ---- memory ------------------------------------------------------------------------------
    flash = sum(s for n, (s, _) in secs.items() if kind_of(n) == "text") + secs.get(".data", (0, 0))[0]
    ram = sum(s for n, (s, _) in secs.items() if kind_of(n) in ("data", "bss") or n in (".heap", ".stack"))
    prof["image_flash_bytes"], prof["image_ram_bytes"] = flash, ram
    md += ["## Memory", ""]
    if bare:
        regions = [("FLASH", d["BOARD_FLASH_BYTES"], flash, ".text, .ARM.exidx and the initial values of .data"),
                   ("SRAM", d["BOARD_SRAM_BYTES"],
                    sum(secs.get(n, (0, 0))[0] for n in (".data", ".bss", ".heap", ".stack")),
                    ".data, .bss of the C library and HAL, heap, main stack"),
                   ("XRAM", d["BOARD_XRAM_BYTES"], secs.get(".ram_ext", (0, 0))[0],
                    "the firmware's static state (.ram_ext)")]
        md += ["| region | size | used | free | holds |", "|---|---:|---:|---:|---|"]
        for name, size, used, what in regions:
            md.append(f"| {name} | {kb(size)} | {kb(used)} ({used / size:.0%}) | {kb(size - used)} | {what} |")
        prof["regions"] = {n: {"size": s, "used": u} for n, s, u, _ in regions}
    else:
        md.append(f"A Linux board: the image is one static executable of {kb(flash)} (text and data) "
                  f"and {kb(ram)} of static RAM; the kernel places it, no linker regions.")
    md.append("")
    budgets = [("RT", d.get("BOARD_RAM_RT_BYTES", 0), r["mem_rt_state"] + r["mem_rt_links"],
                "rt_core_t, sample ring, RT mailboxes"),
               ("AI", d.get("BOARD_RAM_AI_BYTES", 0), r["mem_ai_state"] + r["mem_ai_links"],
                f"DiNNO node {kb(r['mem_ai_node'])} (model arena {kb(r['arena_bytes'])}), "
                f"pool {kb(r['mem_ai_pool'])}, state and checkpoint mailboxes {kb(r['mem_ai_links'])}"),
               ("GP", d.get("BOARD_RAM_GP_BYTES", 0), r["mem_gp_state"] + r["mem_gp_links"] + r["mem_gp_fleet"],
                f"gp_core_t, neighbour view {kb(r['mem_gp_links'])}, fleet exchange {kb(r['mem_gp_fleet'])}")]
    md += ["Static RAM per core against the board's budget (board.h, checked at compile time):", "",
           "| core | budget | used | what |", "|---|---:|---:|---|"]
    for core, budget, used, what in budgets:
        md.append(f"| {core} | {kb(budget)} | {kb(used)} ({used / budget:.0%}) | {what} |")
    prof["cores"] = {c: {"budget": b, "used": u} for c, b, u, _ in budgets}
    md += ["", "The model arena as TensorFlow Lite Micro reports its own: "
           f"**persistent** (tail: parameters, gradients, Adam moments) {kb(r['arena_persistent_bytes'])}, "
           f"**scratch** (head: sampled weights, noise, sigma, the activations of the preset's largest batch) "
           f"{kb(r['arena_scratch_bytes'])}, **peak** {kb(r['arena_bytes'])} "
           "(all of it is static: the peak is the arena).", ""]
    heap_growth = r.get("heap_growth_after_init", 0)
    md.append(f"Heap: {int(r['heap_in_use_after_init'])} bytes in use after init, held by the C library (stdio buffers, its start-up); "
              f"**{int(heap_growth)} bytes allocated after init** (firmware/ allocates nothing).")
    md.append("")

    owners = {}
    for mod, e in mods.items():
        o = owners.setdefault(e["owner"], {"text": 0, "data": 0, "bss": 0})
        for k in ("text", "data", "bss"):
            o[k] += e[k]
    md += ["Sections per part of the image (from the link map: what the linker kept):", "",
           "| part | text | data | bss |", "|---|---:|---:|---:|"]
    for o in ("RT core", "GP core", "AI core", "links, image", "HAL", "image program", "C library"):
        if o in owners:
            e = owners[o]
            md.append(f"| {o} | {e['text']:,} | {e['data']:,} | {e['bss']:,} |")
    md += ["", "<details><summary>Per module</summary>", "", "| module | part | text | data | bss |",
           "|---|---|---:|---:|---:|"]
    for mod, e in sorted(mods.items(), key=lambda kv: -(kv[1]["text"] + kv[1]["data"] + kv[1]["bss"])):
        md.append(f"| {mod} | {e['owner']} | {e['text']:,} | {e['data']:,} | {e['bss']:,} |")
    md += ["", "</details>", ""]
    prof["modules"] = mods

    # ---- stack -------------------------------------------------------------------------------
    md += ["## Stack", ""]
    if "stack_main_used" in r:
        md.append(f"Measured: the AI core's work (training, inference) used **{int(r['stack_main_used']):,} of "
                  f"{int(r['stack_main_used_size']):,} bytes** of the main stack (painted at reset, high-water "
                  "mark at the end of the run).")
    else:
        md.append("Measured high-water mark: not available on this target (a Linux process; its main stack "
                  "grows on demand).")
    md += ["", "Largest frames (`-fstack-usage`, bytes per call, not whole call chains):", "",
           "| bytes | function | kind |", "|---:|---|---|"]
    for size, fn, k in frames[:10]:
        md.append(f"| {size:,} | {fn} | {k} |")
    prof["stack_frames"] = [{"bytes": s, "function": f, "kind": k} for s, f, k in frames[:25]]
    md.append("")
    cg_frames, cg_calls = call_graph(a.obj)
    if cg_frames:
        md += ["Deepest chain of direct calls from each core's loop (`-fcallgraph-info=su`), against the core's "
               "stack; calls through pointers (the HAL's operations) and into the C library add what their "
               "callees use, which static analysis cannot see:", "",
               "| core | stack | deepest direct chain | through |", "|---|---:|---:|---|"]
        prof["stack_worst_case"] = {}
        for core, root in CORE_ROOTS:
            total, chain, fl = worst_stack(root, cg_frames, cg_calls)
            size = d.get(f"BOARD_STACK_{core}_BYTES", 0)
            via = " > ".join(chain[:6]) + (" > ..." if len(chain) > 6 else "")
            extra = [x for x, on in (("indirect calls", fl["indirect"]), ("recursion", fl["recursion"])) if on]
            md.append(f"| {core} | {size:,} | {total:,} B{' + ' + ', '.join(extra) if extra else ''} | {via} |")
            prof["stack_worst_case"][core] = {"stack": size, "direct_chain_bytes": total, "chain": chain,
                                              "indirect": fl["indirect"], "recursion": fl["recursion"]}
        md.append("")

    # ---- the cores' timing --------------------------------------------------------------------
    md += cores_section(r, prof)

    # ---- instructions and time ---------------------------------------------------------------
    md += ["## Instructions and time", ""]
    S, H, L = r["net_siren"], r["net_hidden"], r["net_layers"]
    macs = 2 * S + S * H + (L - 1) * H * H + H  # one point, mean weights
    pts = r["points"]
    if "insn_train_step" in r and clock:
        how = ("Counted by QEMU's user mode with the plugin tools/board/qemu_insn.c (every executed "
               "translated block adds its instruction count; the program marks the measured work with a "
               "system call the plugin sees)." if a.insn_log else
               "Counted by QEMU with `-icount shift=0` (each instruction advances virtual time by 1 ns; "
               "SysTick counts them, the ratio calibrated at reset on a loop of known length).")
        md.append(how + " QEMU is not cycle-accurate: cycles and times are **estimates**, instructions x CPI "
                  f"at the part's clock ({clock / 1e6:.0f} MHz), CPI {CPI_LOW}-{CPI_HIGH} (an in-order core; "
                  "memory wait states, external RAM latency and multi-cycle FP division are not modelled).")
        md += ["", "| work | instructions | per unit | time at CPI 1.0 | at CPI 1.5 |", "|---|---:|---:|---:|---:|"]
        rows = [("training step", r["insn_train_step"], f"batch {int(r['batch'])}", 1),
                (f"Monte-Carlo inference, {int(r['mc_passes'])} passes", r["insn_mc_inference"],
                 f"{int(pts)} points", 1),
                ("mean-weight pass, fp32", r["insn_fp32_inference"],
                 f"{r['insn_fp32_inference'] / (pts * macs):.1f} per MAC", 1),
                ("mean-weight pass, int8", r["insn_int8_inference"],
                 f"{r['insn_int8_inference'] / (pts * macs):.1f} per MAC", 1)]
        has_post = "insn_post_inference" in r
        if has_post:
            post_ratio = r["insn_post_inference"] / r["insn_mc_inference"]
            rows += [(f"one-pass uncertainty of {int(pts)} points (logits + share of prior variance left)",
                      r["insn_post_inference"],
                      f"{post_ratio:.4f} of MC-{int(r['mc_passes'])} (1/{1 / post_ratio:.0f})", 1),
                     ("its posterior's factor, once per map (Cholesky and L^-1, "
                      f"D = {int(r['post_dim'])})", r["insn_post_factor"], "once", 1),
                     (f"summing the samples into the posterior ({int(r['post_observed']):,})",
                      r["insn_post_observe"], f"{r['insn_post_observe'] / max(r['post_observed'], 1):,.0f} per sample",
                      1)]
        for name, n, unit, _ in rows:
            md.append(f"| {name} | {int(n):,} | {unit} | {n * CPI_LOW / clock * 1e3:,.1f} ms | "
                      f"{n * CPI_HIGH / clock * 1e3:,.1f} ms |")
        md.append("")
        md.append(f"int8 against fp32: {r['insn_int8_inference'] / r['insn_fp32_inference']:.2f}x the instructions, "
                  f"{int(r['int8_packed_bytes']):,} bytes of int8 mean weights (with their row scales) instead of "
                  f"{int(r['parameters_mean'] * 4):,} in fp32, largest change of an output probability "
                  f"{r['int8_max_abs_prob_diff']:.4f}.")
        md.append("")
        if has_post:
            verdict = "within" if post_ratio <= POST_GOAL else "**over**"
            md.append(f"One-pass uncertainty (bnn_post.h, {int(r['post_bytes']):,} bytes of `bnn_post_t` at this "
                      f"preset): {int(r['insn_post_inference']):,} instructions for {int(pts)} points against "
                      f"{int(r['insn_mc_inference']):,} for the {int(r['mc_passes'])}-pass Monte-Carlo inference, "
                      f"{post_ratio:.4f} ({verdict} the goal of 1/{1 / POST_GOAL:.0f}); the factor adds "
                      f"{int(r['insn_post_factor']):,} once per map. Mean share of prior variance left over the "
                      f"points {r['unknown_mean_post']:.4g} (min {r['unknown_min_post']:.3g}, "
                      f"max {r['unknown_max_post']:.3g}).")
            md.append("")
        step_s = r["insn_train_step"] * CPI_MID / clock
        steps_ps = 1.0 / step_s
        samples_ps = steps_ps * r["batch"]
        need = SCAN_HZ * SAMPLES_PER_SCAN
        mc_s = r["insn_mc_inference"] * CPI_MID / clock
        afford = {"train_steps_per_s": steps_ps, "samples_per_s": samples_ps,
                  "dinno_rounds_per_min": steps_ps * 60 / PRIMAL_STEPS, "mc_inference_s": mc_s}
        if has_post:
            afford["post_inference_s"] = r["insn_post_inference"] * CPI_MID / clock
        prof["afford"] = afford
        md += ["## What the robot can afford", "",
               f"At CPI {CPI_MID} on the AI core alone ({clock / 1e6:.0f} MHz), batch {int(r['batch'])}:", "",
               "| figure | value |", "|---|---:|",
               f"| training steps per second | {steps_ps:,.2f} |",
               f"| samples per second the training absorbs (steps x batch) | {samples_ps:,.0f} |",
               f"| DiNNO rounds per minute (B = {PRIMAL_STEPS} steps per round, exchange not counted) | "
               f"{afford['dinno_rounds_per_min']:,.1f} |",
               f"| 50-pass map inference of {int(pts)} points | {mc_s:,.2f} s |",
               *([f"| one-pass uncertainty of {int(pts)} points (logits and what is known) | "
                  f"{afford['post_inference_s'] * 1e3:,.1f} ms |"] if has_post else []),
               f"| the 10 Hz scan gives (20 beams x 25 points) | {need:,} samples/s |", ""]
        if samples_ps >= need:
            md.append(f"The 10 Hz scan fits: the AI core can train on every sample once as it arrives "
                      f"({samples_ps / need:.1f}x the rate).")
        else:
            md.append(f"The 10 Hz scan does not fit one pass per sample: the AI core trains on "
                      f"{samples_ps / need:.0%} of the samples as they arrive; the pool keeps the rest, "
                      "and a robot that stops to think (or scans at a lower rate) catches up.")
        md.append("")
        md.append(f"Comparison: {(r['insn_int8_inference'] * CPI_MID) / (pts * macs):.1f} estimated cycles per "
                  "int8 multiply-accumulate here (scalar C, points one at a time) against about 4.5 with TFLM + "
                  "CMSIS-NN on a Cortex-M4F; training memory "
                  f"{kb(r['arena_bytes'])} of model arena against the 256 KB the Tiny Training Engine trains in.")
        print(f"BENCH mcu_train_step_instructions_{a.board} {int(r['insn_train_step'])} instructions")
        print(f"BENCH mcu_mc50_instructions_{a.board} {int(r['insn_mc_inference'])} instructions")
        if has_post:
            print(f"BENCH mcu_post_instructions_{a.board} {int(r['insn_post_inference'])} instructions")
            print(f"BENCH mcu_post_over_mc50_{a.board} {post_ratio:.5f} ratio")
            print(f"BENCH mcu_post_factor_instructions_{a.board} {int(r['insn_post_factor'])} instructions")
    else:
        md.append("Not counted on this board (no instruction counter in this run).")
    md += ["", "## Published figures of small networks on these cores", "",
           "| work | core | figure | source |", "|---|---|---|---|"]
    for w, c, f, s in PUBLISHED:
        md.append(f"| {w} | {c} | {f} | {s} |")
    md.append("")
    print(f"BENCH image_flash_bytes_{a.board} {flash} bytes")
    print(f"BENCH image_ram_bytes_{a.board} {ram} bytes")

    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "profile.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(md))
    with open(os.path.join(a.out, "profile.json"), "w", encoding="utf-8") as f:
        json.dump(prof, f, indent=1, sort_keys=True)
    print(f"board_profile: {os.path.join(a.out, 'profile.md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
