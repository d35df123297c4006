#!/usr/bin/env python3
"""FMI call-sequence fuzzer for the exported FMUs: FMI 2.0 (target/fmu/*.fmu) and, with
FMI 3.0 (target/fmu3/*.fmu) through scripts/fuzz_fmi3.py, which adds its sequences to this one.

Each sequence is a random series of calls over all 34 functions of FMI 2.0 Co-Simulation,
drawn from one seed: instantiation with good and bad arguments, setup with odd tolerances and
times, Get/Set of every type with valid, wrong-type and unknown value references and values
such as NaN, infinity, 1e300 and negative numbers, fmi2DoStep with odd communication points
and step sizes (1e300, 1e9, 1e3 without a stop time among them), cancel, status queries, FMU
states (get, set, free, serialize, deserialize; corrupted bytes, states and bytes of another
FMU, freed and garbage handles), reset, terminate, free, and calls out of order or on freed
instances. Every sequence runs in its own forked process, so that a crash (the process dies
by a signal) or a hang (it does not finish within the time limit) is caught and reported
with its seed; `--seed N --verbose` replays one sequence call by call.

Oracles, checked after every call:
  crash        the sequence's process died by a signal
  hang         the sequence did not finish within --timeout seconds
  nan_after_ok a Real output or calculated parameter read as NaN or infinite, either by an
               fmi2GetReal that returned fmi2OK or, after any call that returned fmi2OK on an
               instance in a readable state, by the fuzzer's own read of all of them
  bad_status   a status outside the fmi2Status enumeration (0..5)
  slow_step    an fmi2DoStep that used more than --slow seconds of CPU time (its thread's, so
               that a busy machine does not count; reported, counted apart)

The hosts' values for `solver.max_steps` are drawn from 1..20000: that parameter is the
per-step budget of integrator steps a host grants (default 5000), and granting two billion
makes a step to t = 1e300 legitimately long.

Usage:
  python scripts/fuzz_fmi.py --sequences 300 --jobs 2          # a short run
  python scripts/fuzz_fmi.py --sequences 100000 --jobs 2       # the campaign: table + docs/fuzz.csv
  python scripts/fuzz_fmi.py --seed 1234 --verbose             # replay one sequence
  python scripts/fuzz_fmi3.py --sequences 300                    # the FMI 3.0 functions
  python scripts/fuzz_fmi.py --long-steps --csv docs/long_steps.csv   # overlong steps timed
"""

import argparse
import json
import os
import select
import signal
import sys
import tempfile
import time
from pathlib import Path

# the sequences and what they are drawn from, re-exported for scripts/fuzz_fmi3.py and the tests
from fuzz_fmi_sequence import *  # noqa: F401,F403
from fuzz_fmi_sequence import FMU_DIR, FUNCTIONS, ORACLES, ROOT, STATUS_NAMES, FmuInfo, Sequence, load_slave, sequence_length

# --------------------------------------------------------------------------------------
# Running sequences in forked processes
# --------------------------------------------------------------------------------------

_WORKER = {}


# (the Sequence class, the library loader, the function names) per FMI version; the FMI 3.0
# ones are added by scripts/fuzz_fmi3.py when it is imported (it builds on this module)
VERSIONS = {2: (Sequence, load_slave, FUNCTIONS)}


def version_parts(fmi_version):
    """(the Sequence class, the library loader, the function names) of an FMI version."""
    if fmi_version not in VERSIONS:
        sys.exit(f"FMI {fmi_version}: not registered (for FMI 3.0 run scripts/fuzz_fmi3.py, or import fuzz_fmi3)")
    return VERSIONS[fmi_version]


def _worker_init(fmu_paths, unzip_root, slow, inject, fmi_version):
    infos = [FmuInfo(p, unzip_root, extract=False) for p in fmu_paths]
    sequence, loader, _ = version_parts(fmi_version)
    _WORKER.update(infos=infos, slaves=[loader(i) for i in infos], slow=slow, inject=inject, sequence=sequence)


def run_forked(seed, timeout):
    """Runs one sequence in a child process; returns its result with crash/hang detection."""
    w = _WORKER
    read_fd, write_fd = os.pipe()
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:  # the child
        os.close(read_fd)
        code = 0
        try:
            seq = w["sequence"](seed, w["infos"], w["slaves"], slow=w["slow"], inject=w["inject"])
            seq.run(sequence_length(seed))
            data = json.dumps(seq.result()).encode()
        except BaseException as e:  # a Python-side problem is reported, not hidden
            data = json.dumps({"seed": seed, "error": f"{type(e).__name__}: {e}"}).encode()
            code = 3
        with os.fdopen(write_fd, "wb") as f:
            f.write(data)
        os._exit(code)
    os.close(write_fd)
    chunks = []
    hung = False
    while True:
        left = timeout - (time.monotonic() - t0)
        if left <= 0:
            hung = True
            break
        ready, _, _ = select.select([read_fd], [], [], left)
        if not ready:
            hung = True
            break
        chunk = os.read(read_fd, 1 << 16)
        if not chunk:
            break
        chunks.append(chunk)
    os.close(read_fd)
    if hung:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    seconds = time.monotonic() - t0
    if hung:
        return {"seed": seed, "violations": [["hang", -1, f"no result after {timeout} s"]], "calls": 0,
                "functions": {}, "seconds": seconds}
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return {"seed": seed, "violations": [["crash", -1, f"killed by signal {sig} ({signal.Signals(sig).name})"]],
                "calls": 0, "functions": {}, "seconds": seconds}
    try:
        result = json.loads(b"".join(chunks))
    except ValueError:
        result = {"seed": seed, "error": f"exit status {status}, no result"}
    if "error" in result:
        result.update(violations=[["fuzzer_error", -1, result["error"]]], calls=0, functions={})
    result["seconds"] = seconds
    return result


def _run_chunk(args):
    seeds, timeout = args
    return [run_forked(s, timeout) for s in seeds]


def campaign(fmu_paths, seeds, jobs=2, timeout=30.0, slow=1.0, inject=None, progress=None, fmi_version=2):
    """Runs the sequences of `seeds` on `jobs` worker processes (each sequence in a forked
    child) against FMUs of `fmi_version`; returns the list of results."""
    import multiprocessing

    seeds = list(seeds)
    unzip_root = tempfile.mkdtemp(prefix="contact-fmu-fuzz-")
    for p in fmu_paths:  # unzipped here, before the workers load the libraries
        FmuInfo(p, unzip_root)
    chunk = max(1, min(50, len(seeds) // (4 * jobs) or 1))
    chunks = [(seeds[i : i + chunk], timeout) for i in range(0, len(seeds), chunk)]
    ctx = multiprocessing.get_context("fork")
    results = []
    with ctx.Pool(jobs, initializer=_worker_init, initargs=([str(p) for p in fmu_paths], unzip_root, slow, inject, fmi_version)) as pool:
        try:
            for part in pool.imap_unordered(_run_chunk, chunks):
                results.extend(part)
                if progress:
                    progress(results)
        except KeyboardInterrupt:
            # an interrupted campaign (Ctrl-C, SIGTERM) reports the sequences it finished
            pool.terminate()
            print(f"interrupted after {len(results)} sequences", file=sys.stderr)
    import shutil

    shutil.rmtree(unzip_root, ignore_errors=True)
    results.sort(key=lambda r: r["seed"])
    return results


def summarize(results, functions=FUNCTIONS):
    counts = {k: 0 for k in ORACLES}
    other = {}
    bad_seeds = {}
    for r in results:
        kinds = set()
        for kind, _, _ in r["violations"]:
            kinds.add(kind)
        for kind in kinds:
            if kind in counts:
                counts[kind] += 1
            else:
                other[kind] = other.get(kind, 0) + 1
            bad_seeds.setdefault(kind, []).append(r["seed"])
    functions = {name: {"calls": 0, "status": {}, "max_seconds": 0.0, "max_cpu_seconds": 0.0} for name in functions}
    for r in results:
        for name, e in r["functions"].items():
            agg = functions.setdefault(name, {"calls": 0, "status": {}, "max_seconds": 0.0, "max_cpu_seconds": 0.0})
            agg["calls"] += e["calls"]
            for k, v in e["status"].items():
                agg["status"][k] = agg["status"].get(k, 0) + v
            agg["max_seconds"] = max(agg["max_seconds"], e["max_seconds"])
            agg["max_cpu_seconds"] = max(agg["max_cpu_seconds"], e["max_cpu_seconds"])
    return {"sequences": len(results), "calls": sum(r["calls"] for r in results), "counts": counts, "other": other,
            "bad_seeds": bad_seeds, "functions": functions}


def print_table(summary, seconds, jobs, first_seed):
    s = summary
    print(f"\nFMI call-sequence fuzzing: {s['sequences']} sequences (seeds from {first_seed}),"
          f" {s['calls']} calls, {jobs} jobs, {seconds:.0f} s")
    print(f"{'function':32s} {'calls':>8s} {'OK':>8s} {'Warn':>6s} {'Discard':>8s} {'Error':>8s} {'Fatal':>6s} {'max wall s':>10s} {'max CPU s':>9s}")
    for name in s["functions"]:
        e = s["functions"][name]
        st = e["status"]
        ok = st.get("0", 0) + st.get("none", 0)  # (functions without a status count as OK)
        print(f"{name:32s} {e['calls']:8d} {ok:8d} {st.get('1', 0):6d} {st.get('2', 0):8d} {st.get('3', 0):8d}"
              f" {st.get('4', 0):6d} {e['max_seconds']:10.3f} {e['max_cpu_seconds']:9.3f}")
    print()
    print(f"{'oracle':16s} {'sequences':>10s}  first seeds")
    for kind in ORACLES + sorted(s["other"]):
        n = s["counts"].get(kind, s["other"].get(kind, 0))
        seeds = s["bad_seeds"].get(kind, [])[:8]
        print(f"{kind:16s} {n:10d}  {' '.join(map(str, seeds))}")


def write_csv(summary, path, seconds, jobs, first_seed):
    s = summary
    lines = ["function,calls,ok,warning,discard,error,fatal,pending,other,max_wall_seconds,max_cpu_seconds"]
    for name in s["functions"]:
        e = s["functions"][name]
        st = dict(e["status"])
        none = st.pop("none", 0)
        ok = st.pop("0", 0) + none
        known = [st.pop(str(k), 0) for k in range(1, 6)]
        other = sum(st.values())
        lines.append(f"{name},{e['calls']},{ok},{','.join(map(str, known))},{other},{e['max_seconds']:.4f},{e['max_cpu_seconds']:.4f}")
    lines.append("")
    lines.append("oracle,sequences_violating")
    for kind in ORACLES + sorted(s["other"]):
        lines.append(f"{kind},{s['counts'].get(kind, s['other'].get(kind, 0))}")
    lines.append("")
    lines.append("sequences,calls,first_seed,jobs,wall_seconds")
    lines.append(f"{s['sequences']},{s['calls']},{first_seed},{jobs},{seconds:.0f}")
    Path(path).write_text("\n".join(lines) + "\n")


def long_steps(fmu_paths, csv=None):
    """fmi2DoStep(0, h) right after initialisation, without a stop time, for h = 1e300, 1e9,
    1e3, with every integration method and the default step budget: status, the time
    reached, wall and CPU seconds. Prints a table; writes `csv` when given."""
    from fmpy.fmi2 import fmi2CallbackFunctions

    root = tempfile.mkdtemp(prefix="contact-fmu-long-")
    rows = []
    print(f"{'fmu':14s} {'method':>6s} {'h':>7s} {'status':>8s} {'t reached':>10s} {'wall s':>7s} {'CPU s':>7s}")
    for path in fmu_paths:
        info = FmuInfo(path, root)
        f = load_slave(info)._functions
        method_vr = next(vr for vr, n, _, _ in info.vars if n == "solver.method")
        for method in (1, 2, 3, 4):
            for h in (1e300, 1e9, 1e3):
                cb = fmi2CallbackFunctions()
                c = f["fmi2Instantiate"](b"long", 1, info.guid.encode(), info.uri.encode(), byref(cb), 0, 0)
                assert f["fmi2SetupExperiment"](c, 0, 0.0, 0.0, 0, 0.0) == 0
                assert f["fmi2EnterInitializationMode"](c) == 0
                assert f["fmi2SetInteger"](c, (c_uint * 1)(method_vr), 1, (c_int * 1)(method)) == 0
                assert f["fmi2ExitInitializationMode"](c) == 0
                t0, c0 = time.perf_counter(), time.thread_time()
                status = f["fmi2DoStep"](c, 0.0, h, 1)
                wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
                reached = c_double(float("nan"))
                f["fmi2GetRealStatus"](c, 2, byref(reached))
                f["fmi2FreeInstance"](c)
                name = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
                rows.append((info.name, method, h, name, reached.value, wall, cpu))
                print(f"{info.name:14s} {method:6d} {h:7.0e} {name:>8s} {reached.value:10.4g} {wall:7.3f} {cpu:7.3f}",
                      flush=True)
    if csv:
        lines = ["fmu,method,h,status,time_reached,wall_seconds,cpu_seconds"]
        lines += [f"{n},{m},{h:g},{st},{t:.6g},{w:.4f},{c:.4f}" for n, m, h, st, t, w, c in rows]
        Path(csv).write_text("\n".join(lines) + "\n")
        print(f"wrote {csv}")
    return rows


def default_fmus(fmi_version=2):
    folder = FMU_DIR if fmi_version == 2 else FMU_DIR.parent / "fmu3"
    return sorted(folder.glob("*.fmu"))


def main(fmi_version=2):
    """The command line; `fmi_version` is the default of --fmi-version (scripts/fuzz_fmi3.py
    calls it with 3)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequences", type=int, default=300)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds per sequence before it counts as a hang")
    ap.add_argument("--slow", type=float, default=1.0, help="an fmi2DoStep using more CPU seconds counts as slow_step")
    ap.add_argument("--fmu", action="append", help="FMU files (default: target/fmu/*.fmu)")
    ap.add_argument("--csv", default=None, help="CSV to write (default docs/fuzz.csv for >= 10000 sequences)")
    ap.add_argument("--seed", type=int, help="replay one sequence in this process, printing every call")
    ap.add_argument("--fmi-version", type=int, choices=sorted(VERSIONS), default=fmi_version,
                    help="fuzz the FMI 2.0 functions (target/fmu) or, from scripts/fuzz_fmi3.py, the FMI 3.0 "
                         "ones (target/fmu3)")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--inject", choices=["crash", "hang", "nan"], help="self-test: make every sequence fail so")
    ap.add_argument("--long-steps", action="store_true",
                    help="instead of fuzzing: time fmi2DoStep(0, 1e300 | 1e9 | 1e3) per FMU and method")
    args = ap.parse_args()
    fmus = [Path(p) for p in args.fmu] if args.fmu else default_fmus(args.fmi_version)
    sequence, loader, functions = version_parts(args.fmi_version)
    if not fmus:
        sys.exit("no FMUs: export them first (cargo run --release)")
    if args.long_steps:
        long_steps(fmus, args.csv)
        return
    if args.seed is not None:
        root = tempfile.mkdtemp(prefix="contact-fmu-fuzz-")
        infos = [FmuInfo(p, root) for p in fmus]
        seq = sequence(args.seed, infos, [loader(i) for i in infos], verbose=True, slow=args.slow, inject=args.inject)
        print(f"seed {args.seed}: {[i.name for i, _ in seq.fmus]}, {sequence_length(args.seed)} random calls")
        seq.run(sequence_length(args.seed))
        for v in seq.violations:
            print("VIOLATION", v)
        sys.exit(1 if seq.violations else 0)
    def interrupted(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupted)
    t0 = time.monotonic()
    last = [t0]
    campaign_csv = "fuzz.csv" if args.fmi_version == 2 else "fuzz3.csv"
    csv = args.csv or (str(ROOT / "docs" / campaign_csv) if args.sequences >= 10000 else None)

    def progress(results):
        now = time.monotonic()
        if now - last[0] > 60:
            last[0] = now
            s = summarize(results, functions)
            print(f"  {len(results)}/{args.sequences} sequences, {now - t0:.0f} s, "
                  + ", ".join(f"{k} {v}" for k, v in s["counts"].items()), flush=True)
            if csv:  # an interrupted campaign leaves the figures of what it ran
                write_csv(s, csv, now - t0, args.jobs, args.first_seed)

    seeds = range(args.first_seed, args.first_seed + args.sequences)
    results = campaign(fmus, seeds, jobs=args.jobs, timeout=args.timeout, slow=args.slow, inject=args.inject,
                       progress=progress, fmi_version=args.fmi_version)
    seconds = time.monotonic() - t0
    summary = summarize(results, functions)
    print_table(summary, seconds, args.jobs, args.first_seed)
    if csv:
        write_csv(summary, csv, seconds, args.jobs, args.first_seed)
        print(f"wrote {csv}")
    findings = [{"seed": r["seed"], "fmus": r.get("fmus"), "violations": r["violations"]} for r in results if r["violations"]]
    if findings:
        path = ROOT / "target" / "fuzz_findings.json"
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(findings, indent=1))
        print(f"the {len(findings)} sequences with findings: {path} (replay one: python scripts/fuzz_fmi.py --seed N)")
    failed = sum(summary["counts"][k] for k in ("crash", "hang", "nan_after_ok", "bad_status")) + sum(
        summary["other"].values())
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
