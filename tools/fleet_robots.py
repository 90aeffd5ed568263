"""The robots of tools/fleet as processes: Robot (one host_sim run: started, its output read,
restarted with --resume, its death recorded), stop_all, supervise (watching them until the end)
and Progress (the fleet's one status line)."""
import ctypes
import os
import re
import signal
import subprocess
import sys
import threading
import time

from fleet_common import fail, say

ROUND_RE = re.compile(
    r"^round\s+(\d+)/(\d+).*?val (\S+).*?dis (\S+)\s+sent (\d+) B\s+lost (\d+)\s+recovered \d+\s+resent (\d+)")
_libc = ctypes.CDLL(None, use_errno=True)


def _die_with_parent():
    _libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG: no orphan if the launcher is killed


class Robot:
    def __init__(self, i, cmd, out_dir):
        self.i = i
        self.cmd = cmd
        self.dir = out_dir
        self.round = 0
        self.rounds = 0
        self.val = float("nan")
        self.dis = float("nan")
        self.sent = self.lost = self.resent = 0
        self.err_tail = []
        self.proc = None
        self.restarts = 0
        self.readers = []
        self.lock = threading.Lock()

    def start(self, resume=False):
        """Starts the robot; with resume, again after it died: the same command plus --resume, its
        logs continued."""
        os.makedirs(self.dir, exist_ok=True)
        mode = "a" if resume else "w"
        self.out_log = open(os.path.join(self.dir, "stdout.log"), mode)
        self.err_log = open(os.path.join(self.dir, "stderr.log"), mode)
        if resume:
            for log in (self.out_log, self.err_log):
                log.write(f"---- restart {self.restarts}: {' '.join(self.cmd)} --resume\n")
                log.flush()
        with self.lock:
            self.err_tail = []
        cmd = self.cmd + (["--resume"] if resume else [])
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     bufsize=1, preexec_fn=_die_with_parent)
        # Each reader keeps its own process and log: after a restart the old ones finish apart.
        self.readers = [threading.Thread(target=self._read_out, args=(self.proc, self.out_log), daemon=True),
                        threading.Thread(target=self._read_err, args=(self.proc, self.err_log), daemon=True)]
        for t in self.readers:
            t.start()

    def _read_out(self, proc, out_log):
        for line in proc.stdout:
            out_log.write(line)
            m = ROUND_RE.match(line)
            if m:
                with self.lock:
                    self.round, self.rounds = int(m.group(1)), int(m.group(2))
                    v, d = float(m.group(3)), float(m.group(4))
                    if v == v:
                        self.val = v
                    if d == d:
                        self.dis = d
                    self.sent += int(m.group(5))
                    self.lost += int(m.group(6))
                    self.resent += int(m.group(7))
        out_log.close()

    def _read_err(self, proc, err_log):
        for line in proc.stderr:
            err_log.write(line)
            err_log.flush()
            with self.lock:
                self.err_tail = (self.err_tail + [line.rstrip()])[-6:]
        err_log.close()

    def how(self):
        """How the process ended, in a few words."""
        rc = self.proc.returncode
        if rc < 0:
            return f"killed by signal {signal.Signals(-rc).name}"
        if rc > 128 and rc - 128 in (signal.SIGINT, signal.SIGTERM):
            return f"stopped by {signal.Signals(rc - 128).name} (exit status {rc})"
        return f"exit status {rc}"

    def why(self):
        with self.lock:
            tail = [t for t in self.err_tail if t.strip()]
        return self.how() + ("".join("\n    " + t for t in tail) if tail else "")

    def death(self, restarted):
        """The record of its death for run.json: robot, round (the last its progress line showed),
        how, its last error line, whether it was restarted."""
        for t in self.readers:  # its last lines may still be in the pipes
            t.join(2.0)
        with self.lock:
            tail = [t for t in self.err_tail if t.strip()]
            rnd = self.round
        return {"robot": self.i, "round": rnd, "how": self.how(), "error": tail[-1] if tail else "",
                "restarted": restarted, "restart": self.restarts if restarted else None}

    def failed_record(self, deaths):
        """run.json's "failed" when this robot stopped the fleet: its death, the last recorded."""
        return deaths[-1]

    def failure_text(self, record):
        return (f"robot {self.i} failed at round {record['round']} ({self.why()})\n  stopped the other robots; its "
                f"logs: {self.dir}/stderr.log, {self.dir}/stdout.log")


class ServiceDied:
    """A service the robots need (name, process, log: the ZeroMQ proxy) that exited while they
    ran: what supervise() returns then, in place of the robot that failed."""

    def __init__(self, name, proc, log):
        self.name, self.proc, self.log = name, proc, log

    def failed_record(self, deaths):
        return {"service": self.name, "how": f"exit status {self.proc.returncode}", "log": self.log}

    def failure_text(self, record):
        return f"{self.name} exited with status {self.proc.returncode} while the robots ran; its log: {self.log}\n" \
               "  stopped the robots"


def stop_all(robots, extra=()):
    procs = [r.proc for r in robots if r.proc and r.proc.poll() is None] + [p for p in extra if p.poll() is None]
    for p in procs:
        try:
            p.terminate()
        except ProcessLookupError:
            pass
    deadline = time.time() + 3.0
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.time()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


class Progress:
    """One status line, rewritten in place on a terminal; otherwise a line every 5 % of the rounds,
    and at least every QUIET_S seconds (256 robots on 2 cores take minutes to start)."""

    QUIET_S = 30.0

    def __init__(self, robots, total_rounds):
        self.robots = robots
        self.total = total_rounds
        self.tty = sys.stdout.isatty()
        self.t0 = time.time()
        self.last_t, self.last_sent = self.t0, 0
        self.next_pct = 5
        self.printed = None  # the slowest robot's round of the last line printed (not a tty)
        self.printed_t = self.t0

    def line(self):
        with_locks = []
        for r in self.robots:
            with r.lock:
                with_locks.append((r.round, r.val, r.dis, r.sent, r.lost, r.resent))
        rounds = [x[0] for x in with_locks]
        vals = [x[1] for x in with_locks if x[1] == x[1]]
        dis = [x[2] for x in with_locks if x[2] == x[2]]
        sent = sum(x[3] for x in with_locks)
        lost, resent = sum(x[4] for x in with_locks), sum(x[5] for x in with_locks)
        now = time.time()
        rate = (sent - self.last_sent) / max(now - self.last_t, 1e-6)
        self.last_t, self.last_sent = now, sent
        lo = min(rounds)
        el = now - self.t0
        hi = max(rounds)
        if hi == 0:
            phase = "driving the tours / first round"
        elif lo == hi:
            phase = f"round {lo}/{self.total}"
        else:  # the robots wait for their neighbours, not for all: they may be rounds apart
            phase = f"rounds {lo}-{hi}/{self.total} (slowest-fastest robot)"
        val = f"val {sum(vals) / len(vals):.4f}" if vals else "val -"
        d = f"disagreement {max(dis):.2e}" if dis else "disagreement -"
        # the words of the robots' summary.txt and of summary.md
        return lo, (f"[{el:6.1f} s] {phase}  {val}  {d}  {rate / 1e6:6.2f} MB/s  "
                    f"{lost} chunks lost, {resent} re-sent")

    def show(self, final=False):
        lo, text = self.line()
        if self.tty:
            sys.stdout.write("\r" + text[: os.get_terminal_size().columns - 1].ljust(20) + ("\n" if final else ""))
            sys.stdout.flush()
        elif ((final and self.printed != lo) or (self.total and lo * 100 >= self.next_pct * self.total)
              or time.time() - self.printed_t >= self.QUIET_S):
            print(text, flush=True)  # the final line only when the last one printed was of another round
            self.printed, self.printed_t = lo, time.time()
            while self.total and lo * 100 >= self.next_pct * self.total:
                self.next_pct += 5


def supervise(robots, restarts, prog, interrupted, deaths, services=()):
    """Watches the robots until all finished, one died past its restarts (returned), or an
    interruption. A robot that dies (non-zero exit, killed: the launcher stops robots only after
    this returns) is started again with --resume while it has restarts left; each death goes
    into `deaths`. A service the robots need (name, process, log: the ZeroMQ proxy) that exits
    ends the run too: a ServiceDied naming it is returned (the caller's `finally` stops the
    robots)."""
    while True:
        time.sleep(0.5)
        if interrupted:
            return None
        for name, proc, log in services:
            if proc.poll() is not None:
                return ServiceDied(name, proc, log)
        done = [r for r in robots if r.proc.poll() is not None]
        for r in (x for x in done if x.proc.returncode != 0):
            if r.restarts >= restarts:
                deaths.append(r.death(restarted=False))
                return r
            r.restarts += 1
            d = r.death(restarted=True)
            deaths.append(d)
            if prog.tty:
                print(file=sys.stdout)
            say(f"robot {r.i} died at round {d['round']} ({r.how()}); restarting it ({r.restarts} of {restarts}) "
                f"with --resume")
            r.start(resume=True)
        prog.show()
        if len([r for r in robots if r.proc.poll() == 0]) == len(robots):
            return None
