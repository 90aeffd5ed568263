#!/usr/bin/python3
"""Fleet traffic in an lcm-logger event log, per round and agent (pure Python, no lcm module).

    tools/lcm_traffic.py LOGFILE [--prefix fleetsim/] [--csv FILE] [--totals-only] [--key-file F]

Reads the event log that `lcm-logger` writes (each event: u32 sync word 0xEDA1DA01, i64 event
number, i64 utime in microseconds, i32 channel length, i32 data length, the channel name
without NUL, the data; all big-endian) and decodes the fleet's three LCM messages by their
8-byte fingerprint, with the field layouts and fingerprints read from the .lcm files of
firmware/msg (through tools/lcmgen.py, as the firmware's are; today's values):

    state_chunk_t     0xdf65602b2d04bf15   on <prefix><fleet>/state
    round_complete_t  0x9ec25daeb3a35535   on <prefix><fleet>/done
    chunk_request_t   0x1a0ee5130e4fff0d   on <prefix><fleet>/request

Telemetry (<prefix>telemetry/<robot>) is counted per robot; any other channel as "other".

A keyed fleet (tools/fleet's default; host_sim run --key-file) ends every datagram with a
48-byte trailer (hal/host/hal_host_auth.h): run id (8 bytes, big-endian) | nonce (24) | tag
(16), tag = XChaCha20-Poly1305 under BLAKE2b-256(key; channel | 0x00) over no plaintext with
the message and the run id as associated data. A fleet message whose lengths match only
without those 48 bytes is a keyed one: the trailer is stripped before the message is decoded,
and the messages that carried one are counted (column keyed_messages, the run ids in the
summary). With --key-file F (the fleet's key) every tag is checked too, through the system's
libsodium (ctypes): a message whose tag is not the key's is counted as malformed ("bad tag").

Everything is validated: a bad sync word makes the reader scan forward to the next event and
count the bytes skipped; event lengths must be non-negative and within the file; a truncated
last event is reported and ignored; a message whose fingerprint does not match its channel,
whose lengths disagree with its data, or whose fields are out of range (negative sender or
round, chunk outside 0..n_chunks-1, ...) is counted as malformed with its reason.

Prints one row per (fleet, round, agent): state chunks sent, state bytes (chunk payload),
chunks sent again (a (sender, round, chunk) seen more than once), chunk requests sent (as
requester), chunks requested in them, RoundComplete sent; then totals per agent and overall,
the log's time span and the event counts. --csv FILE writes the same table (rows, then the
totals with round "total") as CSV. Exit status 1 on a missing or unreadable file, or one
without a single valid event.
"""
import argparse
import ctypes
import ctypes.util
import datetime
import mmap
import os
import struct
import sys
import tempfile

SYNC = 0xEDA1DA01
SYNC_BYTES = struct.pack(">I", SYNC)
EVENT_HEADER_SIGNED = struct.Struct(">Iqqii")
EVENT_HEADER_SIZE = EVENT_HEADER_SIGNED.size  # 28
CHANNEL_MAX = 1000          # what lcm's own log reader accepts (names are at most 63 bytes)
DATA_MAX = 1 << 28          # LCM_MAX_MESSAGE_SIZE

# The messages' layouts and fingerprints, from the .lcm files themselves (tools/lcmgen.py).
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import lcmgen  # noqa: E402

MESSAGES = lcmgen.parse(lcmgen.default_paths())
KIND_TYPES = {"state": "state_chunk_t", "done": "round_complete_t", "request": "chunk_request_t"}
FP_STATE = MESSAGES["state_chunk_t"].fingerprint
FP_DONE = MESSAGES["round_complete_t"].fingerprint
FP_REQUEST = MESSAGES["chunk_request_t"].fingerprint
FINGERPRINTS = {MESSAGES[t].fingerprint: k for k, t in KIND_TYPES.items()}
STATE_CHUNK_MAX = 61440      # firmware/msg/state_chunk.lcm: n_bytes <= 61440
# A keyed fleet's trailer (hal/host/hal_host_auth.h): run id | nonce | tag.
RUN_ID_BYTES, NONCE_BYTES, TAG_BYTES = 8, 24, 16
TRAILER_BYTES = RUN_ID_BYTES + NONCE_BYTES + TAG_BYTES  # 48
KEY_BYTES = 32


def _prefix(msg):
    """A struct.Struct of the fingerprint and the scalar fields before any array, and their names."""
    names, fmt = [], ">Q"
    for f in msg.fields:
        if f.count != 1:
            break
        names.append(f.name)
        fmt += lcmgen.PRIMITIVES[f.type][2]
    return struct.Struct(fmt), names


PREFIX = {t: _prefix(m) for t, m in MESSAGES.items()}


def decode_fields(msg, buf, off, n):
    """The fields of one message of type `msg` (an lcmgen.Message) in buf[off:off + n], after
    its fingerprint: (dict name -> value, None), or (None, reason). A scalar is its value, an
    array its elements as a tuple (a byte array as its length: the payload is not needed here).
    Every count must be non-negative and the fields must end exactly at the message's end."""
    if all(f.count for f in msg.fields) and n != msg.fixed_bytes:
        return None, f"length is not {msg.fixed_bytes} bytes"
    head, names = PREFIX[msg.name]
    if n < head.size:
        return None, "shorter than its header"
    out = dict(zip(names, head.unpack_from(buf, off)[1:]))
    at, end = off + head.size, off + n
    for f in msg.fields[len(names):]:
        fmt = lcmgen.PRIMITIVES[f.type][2]
        count = f.count if f.count else out[f.dim]
        if count < 0 or at + count * f.size > end:
            return None, (f"{f.dim} disagrees with the data" if not f.count else "shorter than its fields")
        if f.count == 1:
            (out[f.name],) = struct.unpack_from(">" + fmt, buf, at)
        elif fmt == "B":
            out[f.name] = count
        else:
            out[f.name] = struct.unpack_from(f">{count}{fmt}", buf, at)
        at += count * f.size
    if at != end:
        last = [f for f in msg.fields if not f.count][-1]
        return None, f"{last.dim} disagrees with the data"
    return out, None


COLUMNS = ["fleet", "round", "agent", "chunks_sent", "state_bytes", "chunks_resent",
           "requests_sent", "chunks_requested", "done_sent", "keyed_messages"]
KEYED_COL = COLUMNS.index("keyed_messages") - 3


class TagChecker:
    """Checks a keyed datagram's tag as hal_host_auth_open does, with the system's libsodium
    (ctypes). Raises LogError when the key file or libsodium cannot be used."""

    def __init__(self, key_file):
        try:
            with open(key_file, "rb") as f:
                text = f.read(2 * KEY_BYTES + 2)
        except OSError as e:
            raise LogError(f"{key_file}: {e.strerror or e}")
        text = text[:-1] if text.endswith(b"\n") else text
        try:
            if len(text) != 2 * KEY_BYTES:
                raise ValueError
            self.key = bytes.fromhex(text.decode("ascii"))
        except (ValueError, UnicodeDecodeError):
            raise LogError(f"{key_file}: not a fleet key ({2 * KEY_BYTES} hexadecimal digits and a newline)")
        lib = None
        for name in ("libsodium.so.23", "libsodium.so", ctypes.util.find_library("sodium")):
            if not name:
                continue
            try:
                lib = ctypes.CDLL(name)
                break
            except OSError:
                pass
        if lib is None or lib.sodium_init() < 0:
            raise LogError("--key-file: libsodium (libsodium23) cannot be loaded: the tags cannot be checked "
                           "(leave --key-file out to strip and count them only)")
        u64, sz, p = ctypes.c_ulonglong, ctypes.c_size_t, ctypes.c_char_p
        lib.crypto_generichash.argtypes = [p, sz, p, u64, p, sz]
        lib.crypto_aead_xchacha20poly1305_ietf_decrypt_detached.argtypes = [p, p, p, u64, p, p, u64, p, p]
        self.lib = lib
        self.channel_keys = {}

    def channel_key(self, channel):
        ck = self.channel_keys.get(channel)
        if ck is None:
            c = channel.encode() + b"\0"
            out = ctypes.create_string_buffer(KEY_BYTES)
            self.lib.crypto_generichash(out, KEY_BYTES, c, len(c), self.key, KEY_BYTES)
            ck = self.channel_keys[channel] = out.raw
        return ck

    def ok(self, channel, wire):
        """True when wire (message and trailer) carries a valid tag on channel."""
        signed = wire[:len(wire) - NONCE_BYTES - TAG_BYTES]
        nonce = wire[len(signed):len(signed) + NONCE_BYTES]
        tag = wire[len(wire) - TAG_BYTES:]
        none = ctypes.create_string_buffer(1)
        return self.lib.crypto_aead_xchacha20poly1305_ietf_decrypt_detached(
            none, None, none, 0, tag, signed, len(signed), nonce, self.channel_key(channel)) == 0


class LogError(Exception):
    pass


class Stats:
    """Everything counted while reading one log."""

    def __init__(self):
        self.events = 0              # events whose framing was valid
        self.first_utime = None
        self.last_utime = None
        self.kind_events = {"state": 0, "done": 0, "request": 0}
        self.telemetry = {}          # robot -> [events, bytes]
        self.other = {}              # channel -> [events, bytes]
        self.malformed = {}          # reason -> count
        self.gaps = 0                # places where the sync word was not found
        self.skipped_bytes = 0       # bytes skipped while looking for the next sync word
        self.truncated_tail = 0      # bytes of an incomplete last event (ignored)
        self.rows = {}               # (fleet, round, agent) -> counts (COLUMNS[3:])
        self.seen_chunks = set()     # (fleet, sender, round, chunk)
        self.fleets = set()
        self.keyed = 0               # fleet messages that carried a keyed fleet's trailer
        self.unkeyed = 0             # valid fleet messages without one
        self.run_ids = {}            # run id (hex) -> keyed messages
        self.tags_checked = 0        # keyed messages whose tag --key-file's key verified

    def bad(self, reason):
        self.malformed[reason] = self.malformed.get(reason, 0) + 1

    def row(self, fleet, rnd, agent):
        key = (fleet, rnd, agent)
        r = self.rows.get(key)
        if r is None:
            r = self.rows[key] = [0] * (len(COLUMNS) - 3)
        return r


def _plausible_event(buf, q, size):
    """True if an event that starts at q has a valid header and ends at the file's end or
    just before another sync word."""
    if q + EVENT_HEADER_SIZE > size:
        return False
    sync, _, _, clen, dlen = EVENT_HEADER_SIGNED.unpack_from(buf, q)
    if sync != SYNC or clen < 1 or clen > CHANNEL_MAX or dlen < 0 or dlen > DATA_MAX:
        return False
    end = q + EVENT_HEADER_SIZE + clen + dlen
    if end > size:
        return False
    return end == size or (end + 4 <= size and buf[end:end + 4] == SYNC_BYTES)


def _next_event(buf, start, size):
    """Offset of the next plausible event at or after `start`, or -1."""
    q = buf.find(SYNC_BYTES, start)
    while q >= 0:
        if _plausible_event(buf, q, size):
            return q
        q = buf.find(SYNC_BYTES, q + 1)
    return -1


def iter_events(buf, size, st):
    """Yields (utime, channel bytes, data offset, data length) of every well-framed event."""
    pos = 0
    while pos < size:
        if size - pos < 4 or buf[pos:pos + 4] != SYNC_BYTES:
            if size - pos < 4 and SYNC_BYTES.startswith(bytes(buf[pos:size])):
                st.truncated_tail += size - pos
                return
            q = _next_event(buf, pos + 1, size)
            if q < 0:
                # No further event: either a truncated event whose sync word was hit, or junk.
                st.gaps += 1
                st.skipped_bytes += size - pos
                return
            st.gaps += 1
            st.skipped_bytes += q - pos
            pos = q
            continue
        if size - pos < EVENT_HEADER_SIZE:
            st.truncated_tail += size - pos
            return
        _, _, utime, clen, dlen = EVENT_HEADER_SIGNED.unpack_from(buf, pos)
        end = pos + EVENT_HEADER_SIZE + clen + dlen
        if clen < 1 or clen > CHANNEL_MAX or dlen < 0 or dlen > DATA_MAX or end > size:
            q = _next_event(buf, pos + 1, size)
            if q >= 0:
                # Lengths that are out of range or run past a later valid event: corrupt.
                st.gaps += 1
                st.skipped_bytes += q - pos
                pos = q
                continue
            if clen >= 1 and clen <= CHANNEL_MAX and dlen >= 0 and dlen <= DATA_MAX:
                st.truncated_tail += size - pos   # a valid header whose event was cut short
            else:
                st.gaps += 1
                st.skipped_bytes += size - pos
            return
        chan = bytes(buf[pos + EVENT_HEADER_SIZE:pos + EVENT_HEADER_SIZE + clen])
        off = pos + EVENT_HEADER_SIZE + clen
        pos = end
        st.events += 1
        if st.first_utime is None or utime < st.first_utime:
            st.first_utime = utime
        if st.last_utime is None or utime > st.last_utime:
            st.last_utime = utime
        yield utime, chan, off, dlen


def decode(kind, fleet, buf, off, n, st, chan=None, tags=None):
    """Checks and counts one fleet message of channel kind `kind`: n bytes at buf[off:], a keyed
    fleet's trailer stripped first (its tag checked with tags, a TagChecker, on chan)."""
    if n < 8:
        st.bad(f"{kind}: shorter than a fingerprint")
        return
    (fp,) = struct.unpack_from(">Q", buf, off)
    got = FINGERPRINTS.get(fp)
    if got is None:
        st.bad(f"{kind}: unknown fingerprint 0x{fp:016x}")
        return
    if got != kind:
        st.bad(f"{kind}: carries a {got} message (fingerprint does not match the channel)")
        return
    msg = MESSAGES[KIND_TYPES[kind]]
    m, why = decode_fields(msg, buf, off, n)
    keyed = False
    if m is None and n >= 8 + TRAILER_BYTES:
        # A keyed fleet's datagram: the message, then run id | nonce | tag.
        mk, _ = decode_fields(msg, buf, off, n - TRAILER_BYTES)
        if mk is not None:
            m, keyed = mk, True
    if m is None:
        st.bad(f"{kind}: {why}")
        return
    if keyed:
        n -= TRAILER_BYTES
        if tags is not None and not tags.ok(chan, bytes(buf[off:off + n + TRAILER_BYTES])):
            st.bad(f"{kind}: bad tag (not --key-file's key, or damaged)")
            return
    if kind == "state":
        if m["n_bytes"] > STATE_CHUNK_MAX:
            st.bad("state: n_bytes above 61440")
            return
        sender, rnd, chunk, n_chunks = m["sender"], m["round"], m["chunk"], m["n_chunks"]
        if sender < 0 or rnd < 0:
            st.bad("state: negative sender or round")
            return
        if n_chunks < 1 or chunk < 0 or chunk >= n_chunks or m["state_bytes"] < 0:
            st.bad("state: chunk, n_chunks or state_bytes out of range")
            return
        st.kind_events["state"] += 1
        r = st.row(fleet, rnd, sender)
        r[KEYED_COL] += keyed
        r[0] += 1
        r[1] += m["n_bytes"]
        key = (fleet, sender, rnd, chunk)
        if key in st.seen_chunks:
            r[2] += 1
        else:
            st.seen_chunks.add(key)
    elif kind == "done":
        sender, rnd = m["sender"], m["round"]
        if sender < 0 or rnd < 0:
            st.bad("done: negative sender or round")
            return
        st.kind_events["done"] += 1
        r = st.row(fleet, rnd, sender)
        r[KEYED_COL] += keyed
        r[5] += 1
    else:
        requester, target, rnd = m["requester"], m["target"], m["round"]
        if requester < 0 or target < 0 or rnd < 0:
            st.bad("request: negative requester, target or round")
            return
        if any(c < 0 for c in m["chunks"]):
            st.bad("request: negative chunk index")
            return
        st.kind_events["request"] += 1
        r = st.row(fleet, rnd, requester)
        r[KEYED_COL] += keyed
        r[3] += 1
        r[4] += m["n_chunks"]
    if keyed:
        st.keyed += 1
        st.tags_checked += tags is not None
        (run_id,) = struct.unpack_from(">Q", buf, off + n)
        rid = f"{run_id:016x}"
        st.run_ids[rid] = st.run_ids.get(rid, 0) + 1
    else:
        st.unkeyed += 1


def classify(chan, prefix):
    """('state'|'done'|'request', fleet) or ('telemetry', robot) or ('other', None)."""
    if not chan.startswith(prefix):
        return "other", None
    rest = chan[len(prefix):]
    if rest.startswith("telemetry/") and len(rest) > len("telemetry/"):
        return "telemetry", rest[len("telemetry/"):]
    fleet, sep, kind = rest.rpartition("/")
    if sep and fleet and "/" not in fleet and kind in ("state", "done", "request"):
        return kind, fleet
    return "other", None


def read_log(path, prefix, tags=None):
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size == 0:
                raise LogError(f"{path}: empty file, no LCM event")
            buf = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    except IsADirectoryError:
        raise LogError(f"{path}: Is a directory")
    except OSError as e:
        raise LogError(f"{path}: {e.strerror or e}")
    st = Stats()
    try:
        for _utime, chan_b, off, dlen in iter_events(buf, size, st):
            if b"\0" in chan_b:
                st.bad("channel name contains NUL")
                continue
            try:
                chan = chan_b.decode("utf-8")
            except UnicodeDecodeError:
                st.bad("channel name is not UTF-8")
                continue
            kind, who = classify(chan, prefix)
            if kind == "other":
                c = st.other.setdefault(chan, [0, 0])
                c[0] += 1
                c[1] += dlen
            elif kind == "telemetry":
                c = st.telemetry.setdefault(who, [0, 0])
                c[0] += 1
                c[1] += dlen
            else:
                st.fleets.add(who)
                decode(kind, who, buf, off, dlen, st, chan, tags)
    finally:
        buf.close()
    if st.events == 0:
        raise LogError(f"{path}: no valid LCM event (not an lcm-logger log?)")
    return st


def _sort_key(v):
    """Fleet ids sort numerically when they are numbers."""
    return (0, int(v), "") if v.isdigit() else (1, 0, v)


def table(st):
    """Rows (fleet, round, agent, counts...) sorted, then per-agent totals, then overall."""
    keys = sorted(st.rows, key=lambda k: (_sort_key(k[0]), k[1], k[2]))
    rows = [[k[0], k[1], k[2]] + st.rows[k] for k in keys]
    per_agent = {}
    for k in keys:
        t = per_agent.setdefault((k[0], k[2]), [0] * (len(COLUMNS) - 3))
        for i, v in enumerate(st.rows[k]):
            t[i] += v
    totals = [[f, "total", a] + per_agent[(f, a)]
              for f, a in sorted(per_agent, key=lambda fa: (_sort_key(fa[0]), fa[1]))]
    overall = [0] * (len(COLUMNS) - 3)
    for t in per_agent.values():
        for i, v in enumerate(t):
            overall[i] += v
    return rows, totals, ["all", "total", "all"] + overall


def fmt_rows(rows):
    widths = [max(len(str(c)) for c in col) for col in zip(COLUMNS, *rows)]
    out = []
    for r in [COLUMNS] + rows:
        out.append("  ".join(str(c).rjust(w) for c, w in zip(r, widths)))
    return out


def fmt_time(us):
    try:
        t = datetime.datetime.fromtimestamp(us / 1e6, tz=datetime.timezone.utc)
        return t.strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] + " UTC"
    except (OverflowError, OSError, ValueError):
        return f"utime {us}"


def write_csv(path, rows, totals, overall):
    d = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise LogError(f"{path}: Is a directory")
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=d, prefix="." + os.path.basename(path) + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(",".join(COLUMNS) + "\n")
            for r in rows + totals + [overall]:
                f.write(",".join(str(c) for c in r) + "\n")
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600: the CSV as readable as every other output
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log", metavar="LOGFILE", help="event log written by lcm-logger")
    ap.add_argument("--prefix", default="fleetsim/", help="channel prefix (default fleetsim/)")
    ap.add_argument("--csv", metavar="FILE", help="also write the table as CSV")
    ap.add_argument("--totals-only", action="store_true",
                    help="print only the totals (the CSV still holds every row)")
    ap.add_argument("--key-file", metavar="F",
                    help="a keyed fleet's key (host_sim key new): check every keyed message's tag (libsodium); "
                         "without it the trailers are stripped and counted, not checked")
    a = ap.parse_args(argv)
    try:
        tags = TagChecker(a.key_file) if a.key_file else None
        st = read_log(a.log, a.prefix, tags)
        rows, totals, overall = table(st)
        if a.csv:
            try:
                write_csv(a.csv, rows, totals, overall)
            except OSError as e:
                raise LogError(f"{a.csv}: {e.strerror or e}")
    except LogError as e:
        print(f"lcm_traffic: {e}", file=sys.stderr)
        return 1
    out = []
    if rows and not a.totals_only:
        out.append("traffic per round and agent:")
        out += fmt_rows(rows)
        out.append("")
    if totals:
        out.append("totals per agent:")
        out += fmt_rows(totals + [overall])
    else:
        out.append(f"no fleet message on {a.prefix}<fleet>/state|done|request")
    out.append("")
    span = (st.last_utime - st.first_utime) / 1e6
    out.append(f"time span: {span:.3f} s, from {fmt_time(st.first_utime)} to {fmt_time(st.last_utime)}")
    k = st.kind_events
    out.append(f"events: {st.events} valid: {k['state']} state chunks, {k['done']} RoundComplete, "
               f"{k['request']} chunk requests, {sum(v[0] for v in st.telemetry.values())} telemetry, "
               f"{sum(v[0] for v in st.other.values())} other, {sum(st.malformed.values())} malformed")
    fleet_msgs = st.keyed + st.unkeyed
    if st.keyed:
        ids = ", ".join(f"{r} ({n})" for r, n in sorted(st.run_ids.items(), key=lambda kv: -kv[1]))
        out.append(f"keyed fleet: {st.keyed} of {fleet_msgs} fleet messages carried the {TRAILER_BYTES}-byte tag "
                   f"trailer (stripped before decoding); run id{'s' if len(st.run_ids) > 1 else ''} {ids}; tags " +
                   (f"checked with {a.key_file}: {st.tags_checked} valid" if a.key_file else
                    "not checked (--key-file F checks them)"))
    elif fleet_msgs:
        out.append(f"unkeyed fleet: none of the {fleet_msgs} fleet messages carried a tag trailer")
    if st.telemetry:
        out.append("telemetry per robot: " + ", ".join(
            f"{r}: {v[0]} ({v[1]} B)" for r, v in sorted(st.telemetry.items(), key=lambda kv: _sort_key(kv[0]))))
    if st.other:
        out.append("other channels: " + ", ".join(
            f"{c}: {v[0]} ({v[1]} B)" for c, v in sorted(st.other.items())))
    for reason, n in sorted(st.malformed.items()):
        out.append(f"malformed: {n} x {reason}")
    if st.gaps:
        out.append(f"bad sync word: {st.gaps} gap(s), {st.skipped_bytes} bytes skipped")
    if st.truncated_tail:
        out.append(f"truncated last event: {st.truncated_tail} bytes ignored")
    if a.csv:
        out.append(f"wrote {a.csv}")
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except BrokenPipeError:
        sys.exit(1)
