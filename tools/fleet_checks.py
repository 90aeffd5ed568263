"""The checking of tools/fleet's options before anything is written or moved: the parser's
one-line errors, the robots' options (--extra, `host_sim run` parsing the command line without
running it), the consensus map's options, the tours against the plan, --key-file and --results.
A bad option: one line "tools/fleet: error: ...", exit 2."""
import argparse
import os
import re
import subprocess

from fleet_common import DEFAULT_PATHS, DEFAULT_PLAN, fail, oserror, refuse, shown

class Parser(argparse.ArgumentParser):
    """argparse with a one-line error (no usage block before it), exit 2."""

    def error(self, message):
        refuse(message)


def glued(argv, opts=("--extra", "--net-faults")):
    """argv with `--extra VALUE` as `--extra=VALUE`: the value of these options may start with '-'
    (--extra "--resume"), which argparse would take for an option."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] == "--":
            return out + argv[i:]
        if argv[i] in opts and i + 1 < len(argv):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


# The options of `host_sim run` the launcher gives every robot itself: --extra may not set them
# (the robots would differ from run.json, or from each other); the launcher's own option, if any.
LAUNCHER_SETS = {"--plan": "--plan", "--path": "--paths", "--out": "--results/--name", "--online": "--mode",
                 "--offline": "--mode", "--rounds": "--rounds", "--rounds-per-comm": "--rounds-per-comm",
                 "--pool": "--pool", "--seed": "--seed", "--fleet": "--robots", "--robot": None, "--id": None,
                 "--fleet-id": "--fleet-id", "--transport": "--transport", "--peers": "--zmq-port",
                 "--lcm-url": "--lcm-url", "--net": "--lcm-url", "--strategy": "--strategy", "--radius": "--radius",
                 "--encoding": "--encoding", "--val-every": "--val-every", "--val-poses": "--val-poses",
                 "--peer-timeout": "--peer-timeout", "--resend-ms": "--resend-ms", "--quiet": None,
                 "--no-maps": "--no-report", "--net-faults": "--net-faults", "--key-file": "--key-file",
                 "--run-id": None, "--explore": "--explore", "--explore-policy": "--explore-policy",
                 "--explore-own-posterior": "--explore-own-posterior", "--explore-posterior-first": "--explore-posterior-first",
                 "--explore-no-fence": "--explore-no-fence", "--explore-time": "--explore-time"}


OPT_ROW = re.compile(r"^  (--[\w-]+(?:, --[\w-]+)*)(?: (\S+))?(?:\s{2,}|$)")


def run_options(hs):
    """{option: takes a value} of `host_sim run --help` (its options table), {} if it gives none."""
    try:
        res = subprocess.run([hs, "run", "--help"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                             timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return {}
    opts = {}
    for line in res.stdout.splitlines() if res.returncode == 0 else []:
        m = OPT_ROW.match(line)
        if m:
            for name in m.group(1).split(", "):
                opts[name] = m.group(2) is not None
    return opts


def host_refusal(res, cmd):
    """host_sim's reason, one line, without its 'host_sim CMD: ' prefix."""
    lines = [l.strip() for l in (res.stderr or res.stdout or "").splitlines() if l.strip()]
    why = lines[0] if lines else f"exit status {res.returncode}"
    return why[len(f"host_sim {cmd}: "):] if why.startswith(f"host_sim {cmd}: ") else why


def check_extra(a, hs):
    """--extra's options as `host_sim run` reads them (its --help's table): known, not one the
    launcher sets, a value after each that takes one; exit 2 saying which."""
    opts = run_options(hs)
    if not opts:
        return  # no table to read: the robots' dry parse (check_run_options) still checks them
    args, i = a.extra_args, 0
    while i < len(args):
        t = args[i]
        name = t.split("=", 1)[0] if t.startswith("--") else t
        if not t.startswith("-") or t == "-":
            refuse(f"--extra: '{t}' is not an option of host_sim run (its values follow their option)")
        if name in ("-h", "--help"):
            refuse("--extra: --help is not a robot option (host_sim run --help lists them)")
        if name not in opts:
            refuse(f"--extra: host_sim run has no option {name} (host_sim run --help lists them)")
        if name in LAUNCHER_SETS:
            own = LAUNCHER_SETS[name]
            refuse(f"--extra: the launcher sets {name} for every robot" + (f": give tools/fleet {own}" if own else ""))
        if opts[name] and "=" not in t:
            if i + 1 >= len(args):
                refuse(f"--extra: host_sim run's {name} needs a value")
            i += 1
        i += 1


def host_refusal_of(cmd, sub, cannot, timeout=30, stdout=subprocess.DEVNULL):
    """host_sim's one-line reason when it refuses cmd (a check: a parse ended by --help, a file
    checked), None when it accepts it; exit 2 saying `cannot` when it does not run within timeout."""
    try:
        res = subprocess.run(cmd, stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as e:
        fail(f"{cannot} ({e})", 2)
    return host_refusal(res, sub) if res.returncode != 0 else None


def check_run_options(a, hs, cmd):
    """The robots' command line (cmd: host_sim run and its options, with --extra's) as host_sim run
    parses it, each value checked against its range and syntax (--rounds, --net-faults, ...), but
    not run: --help ends the parse after them. Exit 2 with host_sim's reason."""
    why = host_refusal_of(cmd + ["--help"], "run", f"{hs} run cannot check the robots' options")
    if why is not None:
        refuse(f"{why} (host_sim run refuses it)")


def check_maps_options(a, hs):
    """The consensus map's options as `host_sim maps` parses them (not run); exit 2 with its reason."""
    why = host_refusal_of([hs, "maps", "--res", str(a.map_res), "--mc", str(a.mc), "--seed", str(a.seed), "--help"],
                          "maps", f"{hs} maps cannot check the map's options")
    if why is not None:
        refuse(f"{why.replace('--res', '--map-res')} (host_sim maps refuses it)")


def check_tour_files(a, hs, paths):
    """The tours against the plan (`host_sim paths check`: every waypoint free, every segment
    clear of the walls); exit 2 with the first reason (FILE:LINE)."""
    why = host_refusal_of([hs, "paths", "check", "--plan", a.plan] + paths, "paths check", "cannot check the tours",
                          timeout=120, stdout=subprocess.PIPE)
    if why is not None:
        refuse(f"--paths {a.paths}: not tours of --plan {shown(a.plan)}: {why}")


def check_key(a, hs):
    """--key-file as the robots will read it (`host_sim key check`); exit 2 with the reason."""
    why = host_refusal_of([hs, "key", "check", a.key_file], "key", f"{hs} key cannot check --key-file",
                          stdout=subprocess.PIPE)
    if why is not None:
        refuse(f"--key-file: {why}")


def tour_count(folder):
    """How many tours robot_0.csv, robot_1.csv, ... the folder holds, counting from 0."""
    have = 0
    while os.path.isfile(os.path.join(folder, f"robot_{have}.csv")):
        have += 1
    return have


def check_tours(a):
    """The tours of the robots, one per robot in --paths; exit 2 naming what is missing. None when
    --paths was not given and the default plan's shipped tours are too few for --robots: then
    make_tours generates them in the run's folder."""
    gen = f"host_sim paths gen --plan {shown(a.plan)} --robots {a.robots} --seed {a.seed} --out DIR"
    if a.paths is None and a.tour_rooms == "own":
        return None  # the shipped tours sweep every room: make_tours makes own ones, for any plan
    if a.paths is None:
        if os.path.realpath(a.plan) != os.path.realpath(DEFAULT_PLAN):
            fail(f"--plan {a.plan} needs its own tours: give --paths DIR (the default tours, "
                 f"{shown(DEFAULT_PATHS)}, are for the default plan only); make them with `{gen}`", 2)
        if tour_count(DEFAULT_PATHS) < a.robots:
            return None
        a.paths = DEFAULT_PATHS
    if not os.path.isdir(a.paths):
        fail(f"--paths {a.paths}: no such folder (make tours with `{gen}`)", 2)
    have = tour_count(a.paths)
    if have < a.robots:
        tours = "no tour (robot_0.csv)" if have == 0 else \
            f"{have} tour{'s' if have > 1 else ''} (robot_0.csv .. robot_{have - 1}.csv)"
        fail(f"--paths {a.paths} has {tours} for --robots {a.robots}: every robot drives its own tour. Make "
             f"{a.robots} with `{gen.replace('DIR', 'NEWDIR')}` and give --paths NEWDIR (more robots than the "
             f"plan has rooms share the rooms), or leave --paths out on the default plan: the launcher makes them", 2)
    return [os.path.join(a.paths, f"robot_{i}.csv") for i in range(a.robots)]


def check_results(results):
    """--results can be created and written; exit 2 with the folder and the reason otherwise."""
    try:
        os.makedirs(results, exist_ok=True)
        if not os.path.isdir(results):
            raise NotADirectoryError(20, "Not a directory", results)
        os.close(os.open(os.path.join(results, f".fleet-probe-{os.getpid()}"), os.O_CREAT | os.O_WRONLY, 0o644))
        os.remove(os.path.join(results, f".fleet-probe-{os.getpid()}"))
    except OSError as e:
        if e.filename is None:
            e.filename = results
        fail(f"cannot write the results in --results {results} ({oserror(e)})", 2)
