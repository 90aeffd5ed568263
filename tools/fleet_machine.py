"""The machine checks of tools/fleet, before the robots start: UDP multicast on this host (what LCM's
udpm:// needs; set up when root), the kernel's socket receive buffer limit, and for a ZeroMQ fleet
a block of free TCP ports."""
import os
import re
import socket
import struct

from fleet_common import fail, run_quiet, say

RMEM_WANT = 32 * 1024 * 1024


def group_port(url):
    """The multicast group and port of an LCM udpm:// URL, or None."""
    m = re.match(r"^udpm://(\d+\.\d+\.\d+\.\d+):(\d+)", url)
    return (m.group(1), int(m.group(2))) if m else None


def multicast_works(group, lcm_port, timeout=1.0):
    """Sends one datagram to a multicast group on this host and reads it back (ttl 0, loop on),
    the way LCM's udpm provider will. Returns None when it works, else why not."""
    port = lcm_port + 1 + os.getpid() % 1000  # not LCM's port: never disturb a running fleet
    rx = tx = None
    try:
        rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        rx.bind(("", port))
        mreq = struct.pack("4s4s", socket.inet_aton(group), socket.inet_aton("0.0.0.0"))
        rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        rx.settimeout(timeout)
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
        tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
        token = f"fleetsim-{os.getpid()}".encode()
        tx.sendto(token, (group, port))
        while True:
            data, _ = rx.recvfrom(256)
            if data == token:
                return None
    except socket.timeout:
        return "a datagram sent to the multicast group did not come back within 1 s"
    except OSError as e:
        return str(e)
    finally:
        for s in (rx, tx):
            if s is not None:
                s.close()


def check_machine(force, group, port):
    root = os.geteuid() == 0
    why = multicast_works(group, port)
    if why is not None:
        fix = ["ip link set lo multicast on", "ip route add 224.0.0.0/4 dev lo"]
        if root:
            say(f"multicast does not work on this host ({why}); setting it up on loopback:")
            for c in fix:
                say(f"  {c}")
                run_quiet(c.split())
            why = multicast_works(group, port)
        if why is not None:
            msg = (f"UDP multicast does not work on this host ({why}); LCM's udpm:// needs it. "
                   "Run as root:\n  " + "\n  ".join("sudo " + c for c in fix))
            if not force:
                fail(msg)
            say(msg + "\n(--force: going on anyway)")
    try:
        with open("/proc/sys/net/core/rmem_max") as f:
            rmem = int(f.read().strip())
    except (OSError, ValueError):
        rmem = None
    if rmem is not None and rmem < RMEM_WANT:
        cmd = f"sysctl -w net.core.rmem_max={RMEM_WANT}"
        if root and run_quiet(cmd.split()).returncode == 0:
            say(f"raised the socket receive buffer limit: {cmd} (was {rmem})")
        else:
            say(f"warning: net.core.rmem_max is {rmem} bytes; a round's states need about "
                f"{RMEM_WANT // 1024 // 1024} MB in flight. Chunks will be lost and asked for again "
                f"(slower, same result). To fix: sudo {cmd}")


def first_busy_port(base, n):
    """The first of the TCP ports base .. base + n - 1 that cannot be bound on 127.0.0.1 the way a
    robot binds it (libzmq sets SO_REUSEADDR: a port in TIME_WAIT is free, one another process
    listens on is not); None when all can."""
    for p in range(base, base + n):
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind(("127.0.0.1", p))
        except OSError:
            return p
        finally:
            s.close()
    return None


def free_port_block(start, n):
    """The first robot's port for a ZeroMQ fleet of n on this host: the first block of n
    consecutive ports from start (then from 1024) that nobody listens on, so that a fleet started
    beside another one (a block of 32 ports per fleet id: a larger fleet spills into the next id's)
    does not take its ports. Exit 1 when no block is free."""
    for base, last in ((start, 65536 - n), (1024, min(start - 1, 65536 - n))):
        while base <= last:
            busy = first_busy_port(base, n)
            if busy is None:
                return base
            base = busy + 1
    fail(f"no {n} consecutive free TCP ports on 127.0.0.1 for the robots (--zmq-port PORT to choose)")
