#!/usr/bin/python3
"""The fleet's messages, one description: the .lcm files of firmware/msg, read here.

    tools/lcmgen.py -o OUT.h firmware/msg/*.lcm     the C header of the field layouts
    tools/lcmgen.py --print firmware/msg/*.lcm      the same, on standard output

Each message of the fleet protocol is written once, as an LCM type (firmware/msg/NAME.lcm).
lcm-gen makes the host's generated LCM code from those files; this script makes what the
firmware and the host's bounds check need from the same files: a header of macros only (no
storage, no code, only <stdint.h>), so firmware/ may include it (tools/check-layering.sh). For
each message `fleetsim.NAME_t` it defines, with NAME in upper case:

    MSG_NAME_FINGERPRINT   the 8-byte type fingerprint that leads every datagram, computed as
                           lcm-gen computes it (lcm_struct_hash: a hash over each field's name,
                           type and dimensions, then rotated left by one bit)
    MSG_NAME_N_FIELDS      fields in declaration order
    MSG_NAME_FIXED_BYTES   bytes on the wire before the first variable-length array (the
                           fingerprint included): the whole message when it has none
    MSG_NAME_FIELDS(X)     an X-macro, one X(name, member, type, size, count, len_field, offset)
                           per field in declaration order: its LCM name; the C struct member it
                           maps to (MSG_NAME_MEMBER_<field>, the field's own name unless the
                           including file defined that macro first); MSG_LCM_<TYPE>; bytes of
                           one element; elements (1 for a scalar, N for [N], 0 for a variable
                           array); the index of the field holding a variable array's count
                           (-1 otherwise); its offset on the wire, or -1 once a variable array
                           came before it.

gp_wire.c encodes and decodes from those tables, hal/host/hal_host_msg.c checks received
datagrams against them, tools/lcm_traffic.py reads the same .lcm files through parse() here.
The Makefile runs this script into the build folder whenever a .lcm file or this script
changes (the cross boards' boards/cross.mk too): nothing generated is committed.

Adding a field is one edit: declare it in the .lcm file. Then the fingerprint, the encoder,
the decoder's length checks and the bounds check follow; the C struct that carries the message
(gp_pse.h) needs the member of the same name (or gp_wire.c maps the name, as it does for
chunk_request_t's n_chunks), or gp_wire.c does not compile. What the protocol requires of the
new field's values (ranges, relations to other fields) is gp_wire.c's per-message check.
tests/gp/test_wire_golden.c freezes today's bytes: a new field changes them, on purpose.

The grammar is the subset of LCM the fleet uses: `package`, one `struct` per file, fields of
the primitive types (no strings or nested types) with at most one dimension, constant or named
by an earlier integer field. Anything else is refused with its file and line, exit status 1.
"""
import argparse
import os
import re
import sys

# LCM primitive type -> (element bytes, the header's MSG_LCM_ name, struct format for python)
PRIMITIVES = {
    "int8_t": (1, "INT8", "b"),
    "int16_t": (2, "INT16", "h"),
    "int32_t": (4, "INT32", "i"),
    "int64_t": (8, "INT64", "q"),
    "float": (4, "FLOAT", "f"),
    "double": (8, "DOUBLE", "d"),
    "byte": (1, "BYTE", "B"),
    "boolean": (1, "BOOLEAN", "b"),
}
LENGTH_TYPES = ("int8_t", "int16_t", "int32_t", "int64_t")
# lcm_dimension_t's modes, as lcm-gen hashes them.
DIM_CONST, DIM_VAR = 0, 1


class LcmError(Exception):
    pass


class Field:
    def __init__(self, name, type_, dim, line):
        self.name = name
        self.type = type_        # an LCM primitive type name
        self.dim = dim           # None, an int (constant) or the name of the count field
        self.line = line
        self.size = PRIMITIVES[type_][0]
        self.count = 1 if dim is None else (dim if isinstance(dim, int) else 0)
        self.len_field = -1      # index of the count field of a variable array
        self.offset = -1         # on the wire, fingerprint included; -1 after a variable array


class Message:
    def __init__(self, package, name, fields, path):
        self.package = package
        self.name = name         # e.g. state_chunk_t
        self.fields = fields
        self.path = path
        self.fingerprint = fingerprint(fields)
        at = 8
        for i, f in enumerate(fields):
            if isinstance(f.dim, str):
                f.len_field = next(j for j, g in enumerate(fields) if g.name == f.dim)
            f.offset = at
            if at >= 0:
                at = at + f.size * f.count if f.count else -1
        self.fixed_bytes = next((f.offset for f in fields if f.count == 0), at)

    @property
    def macro(self):
        """MSG_<NAME> without the _t: MSG_STATE_CHUNK."""
        return "MSG_" + re.sub(r"_t$", "", self.name).upper()


def _hash_update(v, c):
    """lcm-gen's hash_update on an int64_t: ((v << 8) ^ (v >> 55)) + c, wrapping."""
    v = ((v << 8) & 0xFFFFFFFFFFFFFFFF) ^ ((v >> 55) & 0xFFFFFFFFFFFFFFFF)
    v = (v + c) & 0xFFFFFFFFFFFFFFFF
    return v - (1 << 64) if v >> 63 else v


def _hash_string(v, s):
    v = _hash_update(v, len(s))
    for ch in s.encode():
        v = _hash_update(v, ch)
    return v


def fingerprint(fields):
    """The type fingerprint lcm-gen writes (lcm_struct_hash, then one left rotation as the
    generated _get_hash does for a type without nested types). The struct's name is not in it."""
    v = 0x12345678
    for f in fields:
        v = _hash_string(v, f.name)
        v = _hash_string(v, f.type)       # primitive: its type name is part of the hash
        if f.dim is None:
            v = _hash_update(v, 0)
        else:
            v = _hash_update(v, 1)
            v = _hash_update(v, DIM_VAR if isinstance(f.dim, str) else DIM_CONST)
            v = _hash_string(v, str(f.dim))
    u = v & 0xFFFFFFFFFFFFFFFF
    return ((u << 1) | (u >> 63)) & 0xFFFFFFFFFFFFFFFF


_TOKEN = re.compile(r"\s*(?:(//[^\n]*)|(/\*.*?\*/)|([A-Za-z_][A-Za-z0-9_.]*|\d+|[{}\[\];=]))", re.S)


def _tokens(text, path):
    """(token, line) pairs without comments."""
    pos, out = 0, []
    while True:
        m = _TOKEN.match(text, pos)
        if not m:
            rest = text[pos:].strip()
            if rest:
                line = text.count("\n", 0, pos) + 1 + text[pos:].count("\n", 0, text[pos:].index(rest[0]))
                raise LcmError(f"{path}:{line}: unexpected '{rest[0]}'")
            return out
        if m.group(3):
            out.append((m.group(3), text.count("\n", 0, m.start(3)) + 1))
        pos = m.end()


def parse_file(path):
    """The one struct of an .lcm file as a Message."""
    with open(path, encoding="utf-8") as f:
        toks = _tokens(f.read(), path)
    i, package = 0, ""

    def take(expect=None):
        nonlocal i
        if i >= len(toks):
            raise LcmError(f"{path}: ends early" + (f" (expected '{expect}')" if expect else ""))
        tok, line = toks[i]
        if expect is not None and tok != expect:
            raise LcmError(f"{path}:{line}: expected '{expect}', got '{tok}'")
        i += 1
        return tok, line

    if toks and toks[0][0] == "package":
        take()
        package = take()[0]
        take(";")
    tok, line = take()
    if tok != "struct":
        raise LcmError(f"{path}:{line}: expected 'struct', got '{tok}' (only structs are supported)")
    name = take()[0]
    take("{")
    fields = []
    while True:
        tok, line = take()
        if tok == "}":
            break
        if tok not in PRIMITIVES:
            raise LcmError(f"{path}:{line}: field type '{tok}' is not supported (primitive types only)")
        fname, _ = take()
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", fname):
            raise LcmError(f"{path}:{line}: bad field name '{fname}'")
        if any(g.name == fname for g in fields):
            raise LcmError(f"{path}:{line}: field '{fname}' declared twice")
        dim = None
        if i < len(toks) and toks[i][0] == "[":
            take()
            d, dline = take()
            if d.isdigit():
                dim = int(d)
                if dim < 1:
                    raise LcmError(f"{path}:{dline}: array size must be positive")
            else:
                count = next((g for g in fields if g.name == d), None)
                if count is None or count.type not in LENGTH_TYPES or count.dim is not None:
                    raise LcmError(f"{path}:{dline}: '{d}' must be an integer field declared before '{fname}'")
                dim = d
            take("]")
            if i < len(toks) and toks[i][0] == "[":
                raise LcmError(f"{path}:{line}: '{fname}': more than one dimension is not supported")
        take(";")
        fields.append(Field(fname, tok, dim, line))
    if i != len(toks):
        raise LcmError(f"{path}:{toks[i][1]}: one struct per file")
    if not fields:
        raise LcmError(f"{path}: struct {name} has no fields")
    return Message(package, name, fields, path)


def parse(paths):
    """Messages of the .lcm files, by struct name (state_chunk_t -> Message)."""
    msgs = {}
    for p in sorted(paths):
        m = parse_file(p)
        if m.name in msgs:
            raise LcmError(f"{p}: struct {m.name} also in {msgs[m.name].path}")
        msgs[m.name] = m
    return msgs


def default_paths():
    """The project's .lcm files (firmware/msg/*.lcm beside this script's tools/)."""
    d = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "firmware", "msg")
    return sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith(".lcm"))


def header(msgs):
    out = [
        "/* Generated by tools/lcmgen.py from " + ", ".join(sorted(os.path.basename(m.path) for m in msgs.values())) + ": do not edit",
        " * (edit the .lcm file; tools/lcmgen.py says what each macro is). Macros only, no storage. */",
        "#ifndef MSG_MSG_LAYOUT_H",
        "#define MSG_MSG_LAYOUT_H",
        "",
        "#include <stdint.h>",
        "",
        "/* LCM's primitive types (the `type` of an X-macro entry). */",
    ]
    for n, (_, tag, _) in enumerate(PRIMITIVES.values(), 1):
        out.append(f"#define MSG_LCM_{tag} {n}")
    for m in msgs.values():
        mm = m.macro
        out += [
            "",
            f"/* {m.package + '.' if m.package else ''}{m.name} ({os.path.basename(m.path)}) */",
            f"#define {mm}_FINGERPRINT UINT64_C(0x{m.fingerprint:016x})",
            f"#define {mm}_N_FIELDS {len(m.fields)}",
            f"#define {mm}_FIXED_BYTES {m.fixed_bytes}u",
        ]
        for f in m.fields:
            out += [f"#ifndef {mm}_MEMBER_{f.name}", f"#define {mm}_MEMBER_{f.name} {f.name}", "#endif"]
        out.append(f"/* X(name, member, type, size, count, len_field, offset) */")
        out.append(f"#define {mm}_FIELDS(X) \\")
        for f in m.fields:
            out.append(f"    X({f.name}, {mm}_MEMBER_{f.name}, MSG_LCM_{PRIMITIVES[f.type][1]}, {f.size}, "
                       f"{f.count}, {f.len_field}, {f.offset}) \\")
        out.append("    /* end */")
    out += ["", "#endif /* MSG_MSG_LAYOUT_H */", ""]
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("lcm", nargs="*", help="the .lcm files (default: firmware/msg/*.lcm)")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("-o", "--out", help="the header to write")
    g.add_argument("--print", action="store_true", help="print the header")
    a = ap.parse_args(argv)
    try:
        text = header(parse(a.lcm or default_paths()))
    except (LcmError, OSError) as e:
        print(f"lcmgen: {e}", file=sys.stderr)
        return 1
    if a.print:
        sys.stdout.write(text)
        return 0
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    tmp = a.out + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
