#!/usr/bin/python3
"""Tests of tools/lcmgen.py: its fingerprints are lcm-gen's (the fleet's .lcm files and a type
with every primitive, fixed and variable arrays, counts of every integer width), the header it
writes is what firmware/ may include (macros, <stdint.h> only) and compiles clean, its layouts
are the wire's, and what it does not support is refused with the file and line.

    python3 tests/tools/test_lcmgen.py      prints "N passed, M failed", exit 1 on failure

Needs lcm-gen (Debian liblcm-bin, a build dependency) and gcc.
"""
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import lcmgen  # noqa: E402

GEN = os.path.join(ROOT, "tools", "lcmgen.py")
FLEET_LCM = sorted(glob.glob(os.path.join(ROOT, "firmware", "msg", "*.lcm")))

# Every construct the generator accepts, in one type.
EVERY = """package fleetsim;
/* a block comment */
struct every_t
{
    int8_t a;           // a comment
    int16_t n16;
    int64_t n64;
    int32_t n32;
    int8_t n8;
    float f;
    double d;
    boolean ok;
    byte raw[n16];
    int32_t fixed[3];
    double xs[n64];
    int16_t ys[n8];
    int64_t zs[n32];
    float tail;
}
"""


def lcm_gen_fingerprints(paths, d):
    """{struct name: fingerprint} as lcm-gen's C code computes it (base hash, rotated left)."""
    subprocess.run(["lcm-gen", "-c", "--c-cpath", d, "--c-hpath", d] + paths, check=True,
                   stdout=subprocess.DEVNULL)
    out = {}
    for c in glob.glob(os.path.join(d, "*.c")):
        with open(c) as f:
            text = f.read()
        m = re.search(r"uint64_t hash = \(uint64_t\)(0x[0-9a-f]+)LL", text)
        name = re.sub(r"^[a-z]+_", "", os.path.basename(c)[:-2], count=1)
        base = int(m.group(1), 16)
        out[name] = ((base << 1) | (base >> 63)) & 0xFFFFFFFFFFFFFFFF
    return out


@test
def fingerprints_are_lcm_gens():
    d = tempfile.mkdtemp(prefix="lcmgen.")
    try:
        every = os.path.join(d, "every.lcm")
        with open(every, "w") as f:
            f.write(EVERY)
        paths = FLEET_LCM + [every]
        theirs = lcm_gen_fingerprints(paths, d)
        ours = {m.name: m.fingerprint for m in lcmgen.parse(paths).values()}
        check(set(theirs) == {"state_chunk_t", "round_complete_t", "chunk_request_t", "goal_claim_t", "every_t"}, theirs)
        check(ours == theirs, f"ours {ours}\nlcm-gen {theirs}")
        # the constants the fleet has always used (firmware, logs, peers of older builds)
        check(ours["state_chunk_t"] == 0xDF65602B2D04BF15, hex(ours["state_chunk_t"]))
        # the RoundComplete carries the next round's position since round openings without a beacon (was 0x9EC25DAEB3A35535)
        check(ours["round_complete_t"] == 0x4BAED42FB1823BC9, hex(ours["round_complete_t"]))
        # the request carries its sender's position since neighbour-scoped delivery (was 0x2765123CB5B82F65)
        check(ours["chunk_request_t"] == 0x1A0EE5130E4FFF0D, hex(ours["chunk_request_t"]))
    finally:
        shutil.rmtree(d)


@test
def layouts():
    m = lcmgen.parse(FLEET_LCM)
    sc = m["state_chunk_t"]
    check(sc.fixed_bytes == 57, sc.fixed_bytes)
    check([(f.name, f.offset) for f in sc.fields][5:8] == [("encoding", 28), ("crc32", 29), ("x_m", 33)],
          [(f.name, f.offset) for f in sc.fields])
    data = sc.fields[-1]
    check(data.count == 0 and sc.fields[data.len_field].name == "n_bytes", vars(data))
    check(m["round_complete_t"].fixed_bytes == 37, "done")
    rq = m["chunk_request_t"]
    check(rq.fixed_bytes == 45 and rq.fields[-1].len_field == 7, "request")


@test
def header_is_firmware_clean():
    d = tempfile.mkdtemp(prefix="lcmgen.")
    try:
        h = os.path.join(d, "msg", "msg_layout.h")
        r = subprocess.run([GEN, "-o", h] + FLEET_LCM, capture_output=True, text=True)
        check(r.returncode == 0 and os.path.exists(h), r.stderr)
        with open(h) as f:
            text = f.read()
        check(re.findall(r"#\s*include\s*(\S+)", text) == ["<stdint.h>"], "includes: only <stdint.h>")
        check(not re.search(r"^\s*(static|extern|const|int|uint)", text, re.M), "macros only, no storage")
        r2 = subprocess.run([GEN, "--print"] + FLEET_LCM, capture_output=True, text=True)
        check(r2.returncode == 0 and r2.stdout == text, "--print writes the same header")
        # every X-macro expands to the generated values; compiled as firmware is
        c = os.path.join(d, "t.c")
        with open(c, "w") as f:
            f.write('#include "msg/msg_layout.h"\n'
                    "#define OFF(name, member, type, size, count, len_field, offset) +(offset)\n"
                    "_Static_assert(0 MSG_STATE_CHUNK_FIELDS(OFF) == 8+12+16+20+24+28+29+33+41+49+53+57, \"offsets\");\n"
                    "_Static_assert(MSG_STATE_CHUNK_FINGERPRINT == 0xdf65602b2d04bf15ull, \"fp\");\n"
                    "_Static_assert(MSG_CHUNK_REQUEST_FIXED_BYTES == 45u, \"request\");\n"
                    "int main(void) { return 0; }\n")
        r = subprocess.run(["gcc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-I", d, "-c", c,
                            "-o", os.path.join(d, "t.o")], capture_output=True, text=True)
        check(r.returncode == 0, r.stderr)
    finally:
        shutil.rmtree(d)


@test
def refuses_what_it_does_not_support():
    d = tempfile.mkdtemp(prefix="lcmgen.")
    try:
        cases = {
            "string": ("struct a_t { int32_t n;\n string s; }", ":2: field type 'string'"),
            "nested": ("struct a_t { other_t o; }", "field type 'other_t'"),
            "two_dims": ("struct a_t { int32_t n;\n int32_t m;\n byte b[n][m]; }", ":3:"),
            "later_count": ("struct a_t { byte b[n];\n int32_t n; }", "must be an integer field declared before"),
            "float_count": ("struct a_t { double n;\n byte b[n]; }", "must be an integer field"),
            "twice": ("struct a_t { int32_t n;\n int32_t n; }", "declared twice"),
            "const": ("struct a_t { const int32_t K = 3; }", "field type 'const'"),
            "junk": ("struct a_t { int32_t n; } %", "unexpected '%'"),
        }
        for name, (text, want) in cases.items():
            p = os.path.join(d, name + ".lcm")
            with open(p, "w") as f:
                f.write(text)
            r = subprocess.run([GEN, "--print", p], capture_output=True, text=True)
            check(r.returncode == 1 and want in r.stderr and p in r.stderr and r.stdout == "",
                  f"{name}: {r.returncode} {r.stderr!r}")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
