"""Table 2 sweeps on Dask: python3 -m hazmap.sweep SPEC.yaml [--scheduler tcp://HOST:8786]

SPEC (YAML):
    out: sweep-out                 # sequences/, runs/, table.csv, runs.csv, table.json
    scenes: [naraha]               # simulator scenarios (built-in names), simulated once per seed
    seeds: [1, 2, 3]
    frames: 40                     # simulator frames per sequence (0 = the whole route)
    simulator: {}                  # more simulator keys (hazmap.defaults('simulator'))
    sequences: []                  # recorded sequence folders/bags with ground truth (no simulation)
    methods: [odometry, icp, icp+pgo, property-icp, property-icp+pgo]
    setups: {default: {}}          # named run configs (the YAML's sections, hazmap.defaults('run'))
    grid: {odometry.voxel_size: [0.5, 0.75]}   # dotted run-config keys x values (cartesian)
    retries: 2                     # a failed task is retried this often, then reported
    threads_per_run: 1             # TBB threads inside one run (the workers are the parallelism)

One Dask task per sequence to simulate and one per run (simulate -> run -> evaluate); a run's
result is written to runs/<key>.json, key = hash of its inputs and parameters, so a re-run
skips what exists. Without --scheduler a LocalCluster (--workers N) runs the tasks.
"""
import argparse
import csv
import hashlib
import itertools
import json
import math
import os
import pathlib
import sys
import time

import yaml

METHOD_ORDER = ("odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo")
PAPER_ROWS = {"odometry": "Odometry", "icp": "ICP", "icp+pgo": "ICP + PGO",
              "property-icp": "Property ICP", "property-icp+pgo": "Property ICP + PGO"}


def _key(obj):
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def _write_json(path, value):
    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(value, indent=1, sort_keys=True))
    os.replace(tmp, path)


def _set_dotted(config, dotted, value):
    *parents, last = dotted.split(".")
    node = config
    for p in parents:
        node = node.setdefault(p, {})
    node[last] = value


def load_spec(path):
    spec = yaml.safe_load(pathlib.Path(path).read_text()) or {}
    known = {"out", "scenes", "seeds", "frames", "simulator", "sequences", "methods", "setups", "grid",
             "retries", "threads_per_run"}
    unknown = set(spec) - known
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {', '.join(sorted(unknown))} (known: {', '.join(sorted(known))})")
    spec.setdefault("out", str(pathlib.Path(path).with_suffix("")) + "-out")
    spec["out"] = str((pathlib.Path(path).parent / spec["out"]).resolve())
    spec.setdefault("scenes", [])
    spec.setdefault("seeds", [1])
    spec.setdefault("frames", 0)
    spec.setdefault("simulator", {})
    spec.setdefault("sequences", [])
    spec.setdefault("methods", list(METHOD_ORDER))
    spec.setdefault("setups", {"default": {}})
    spec.setdefault("grid", {})
    spec.setdefault("retries", 2)
    spec.setdefault("threads_per_run", 1)
    bad = [m for m in spec["methods"] if m not in METHOD_ORDER]
    if bad:
        raise ValueError(f"{path}: methods: unknown {bad} (expected {', '.join(METHOD_ORDER)})")
    if not spec["scenes"] and not spec["sequences"]:
        raise ValueError(f"{path}: no scenes and no sequences to run")
    return spec


def plan(spec):
    """(sequence tasks, run tasks): plain dicts, each run naming its sequence task's key."""
    sequences = {}
    for scene, seed in itertools.product(spec["scenes"], spec["seeds"]):
        sim = dict(spec["simulator"], scenario=scene, seed=seed, frames=spec["frames"])
        key = "sim-" + _key(sim)
        sequences[key] = {"key": key, "scene": scene, "seed": seed, "simulator": sim,
                          "path": str(pathlib.Path(spec["out"]) / "sequences" / key)}
    for path in spec["sequences"]:
        key = "rec-" + _key(os.path.abspath(path))
        sequences[key] = {"key": key, "scene": os.path.basename(os.path.normpath(path)), "seed": 0,
                          "simulator": None, "path": os.path.abspath(path)}
    names = list(spec["grid"])
    points = [dict(zip(names, values)) for values in itertools.product(*(spec["grid"][n] for n in names))] or [{}]
    runs = []
    for seq, (setup, base), params, method in itertools.product(
            sequences.values(), spec["setups"].items(), points, spec["methods"]):
        config = json.loads(json.dumps(base or {}))
        for dotted, value in params.items():
            _set_dotted(config, dotted, value)
        inputs = {"sequence": seq["simulator"] or seq["path"], "method": method, "config": config}
        runs.append({"key": _key(inputs), "sequence": seq["key"], "scene": seq["scene"], "seed": seq["seed"],
                     "setup": setup, "params": params, "method": method, "config": config,
                     "threads": spec["threads_per_run"],
                     "out": str(pathlib.Path(spec["out"]) / "runs")})
    return sequences, runs


def make_sequence(seq):
    """Simulates a sequence unless it exists (its simulation.yaml is written last)."""
    import hazmap
    path = pathlib.Path(seq["path"])
    if seq["simulator"] is not None and not (path / "simulation.yaml").exists():
        hazmap.simulate(str(path), seq["simulator"], overwrite=path.exists())
    return str(path)


def run_one(task, sequence_path):
    """One run: SLAM then its evaluation against the sequence's ground truth; the row is saved."""
    import hazmap
    out = pathlib.Path(task["out"]) / f"{task['key']}.json"
    if out.exists():
        return json.loads(out.read_text())
    start = time.perf_counter()
    r = hazmap.run(sequence_path, task["method"], config=task["config"], threads=task["threads"])
    if r.map_error is None:
        raise hazmap.Error(f"{sequence_path}: no ground truth, so no map error")
    row = {k: task[k] for k in ("key", "scene", "seed", "setup", "params", "method")}
    row.update(map_error=r.table2_error, ate_rmse=r.trajectory["ape"]["rmse"],
               frames=r.frames, loops=r.loops, seconds=time.perf_counter() - start)
    out.parent.mkdir(parents=True, exist_ok=True)
    _write_json(out, row)
    return row


def cell_of(row):
    return (row["scene"], row["setup"], json.dumps(row["params"], sort_keys=True), row["method"])


def summarise(rows):
    """Mean ± std (sample std, n-1; 0 for one seed) per (scene, setup, params, method) over seeds."""
    cells = {}
    for row in rows:
        cells.setdefault(cell_of(row), []).append(row)
    table = []
    for (scene, setup, params, method), members in sorted(cells.items(), key=lambda kv: (kv[0][:3], METHOD_ORDER.index(kv[0][3]))):
        entry = {"scene": scene, "setup": setup, "params": json.loads(params), "method": method, "n": len(members),
                 "seeds": sorted(m["seed"] for m in members)}
        for metric in ("map_error", "ate_rmse"):
            values = [m[metric] for m in members]
            mean = sum(values) / len(values)
            std = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1)) if len(values) > 1 else 0.0
            entry[metric + "_mean"], entry[metric + "_std"] = mean, std
        table.append(entry)
    return table


def table2_text(table):
    """The paper's Table 2 layout: one row per method, one column per scene/setup/parameters."""
    columns = sorted({(e["scene"], e["setup"], json.dumps(e["params"], sort_keys=True)) for e in table})
    by = {(e["scene"], e["setup"], json.dumps(e["params"], sort_keys=True), e["method"]): e for e in table}
    heads = [" ".join(x for x in (s, "" if u == "default" else u, "" if p == "{}" else p) if x) for s, u, p in columns]
    width = max([22] + [len(h) + 2 for h in heads])
    lines = ["Mean map error [m] vs the map from true poses (mean ± std over seeds)",
             f"{'Method':<20}" + "".join(f"{h:>{width}}" for h in heads)]
    for method in METHOD_ORDER:
        cells = [by.get(c + (method,)) for c in columns]
        if not any(cells):
            continue
        text = [f"{e['map_error_mean']:.3f} ± {e['map_error_std']:.3f} ({e['n']})" if e else "-" for e in cells]
        lines.append(f"{PAPER_ROWS[method]:<20}" + "".join(f"{t:>{width}}" for t in text))
    return "\n".join(lines)


def write_results(spec, rows, failures):
    out = pathlib.Path(spec["out"])
    out.mkdir(parents=True, exist_ok=True)
    table = summarise(rows)
    with open(out / "runs.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["key", "scene", "seed", "setup", "params", "method", "map_error", "ate_rmse", "frames", "loops", "seconds"])
        for r in sorted(rows, key=lambda r: (cell_of(r), r["seed"])):
            w.writerow([r["key"], r["scene"], r["seed"], r["setup"], json.dumps(r["params"], sort_keys=True), r["method"],
                        repr(r["map_error"]), repr(r["ate_rmse"]), r["frames"], r["loops"], f"{r['seconds']:.3f}"])
    with open(out / "table.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scene", "setup", "params", "method", "n", "map_error_mean", "map_error_std", "ate_rmse_mean", "ate_rmse_std"])
        for e in table:
            w.writerow([e["scene"], e["setup"], json.dumps(e["params"], sort_keys=True), e["method"], e["n"],
                        repr(e["map_error_mean"]), repr(e["map_error_std"]), repr(e["ate_rmse_mean"]), repr(e["ate_rmse_std"])])
    _write_json(out / "table.json", {"table": table, "runs": rows, "failed": failures})
    return table


def execute(spec, client):
    """Submits every task to `client` (a dask.distributed Client); returns (rows, failures)."""
    from distributed import as_completed
    sequences, runs = plan(spec)
    pathlib.Path(spec["out"], "runs").mkdir(parents=True, exist_ok=True)
    done = {r["key"]: json.loads(p.read_text()) for r in runs
            if (p := pathlib.Path(r["out"]) / f"{r['key']}.json").exists()}
    todo = [r for r in runs if r["key"] not in done]
    needed = {r["sequence"] for r in todo}
    seq_futures = {k: client.submit(make_sequence, sequences[k], key=f"sequence-{k}", retries=spec["retries"],
                                    pure=False) for k in needed}
    futures = {client.submit(run_one, r, seq_futures[r["sequence"]], key=f"run-{r['key']}",
                             retries=spec["retries"], pure=False): r for r in todo}
    rows, failures = list(done.values()), []
    for future in as_completed(list(futures)):
        task = futures[future]
        if future.status == "finished":
            rows.append(future.result())
        else:
            failures.append({k: task[k] for k in ("key", "scene", "seed", "setup", "params", "method")}
                            | {"error": f"{type(future.exception()).__name__}: {future.exception()}"})
    return rows, failures, len(done)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m hazmap.sweep", description=__doc__.split("\n\n")[0])
    ap.add_argument("spec", help="sweep SPEC.yaml")
    ap.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://HOST:8786 (default: a LocalCluster)")
    ap.add_argument("--workers", type=int, default=os.cpu_count(), help="LocalCluster worker processes")
    ap.add_argument("--out", help="output folder (overrides the spec's out)")
    args = ap.parse_args(argv)
    try:
        spec = load_spec(args.spec)
    except (OSError, ValueError, yaml.YAMLError) as e:
        print(f"hazmap.sweep: {e}", file=sys.stderr)
        return 2
    if args.out:
        spec["out"] = os.path.abspath(args.out)
    from distributed import Client, LocalCluster
    start = time.perf_counter()
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        client = Client(LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                     dashboard_address=None))
    with client:
        rows, failures, skipped = execute(spec, client)
    table = write_results(spec, rows, failures)
    print(table2_text(table))
    print(f"{len(rows)} runs ({skipped} already done, skipped) in {time.perf_counter() - start:.1f} s; "
          f"results in {spec['out']}/table.csv, runs.csv, table.json")
    for f in failures:
        print(f"FAILED {f['scene']} seed {f['seed']} {f['setup']} {f['params']} {f['method']}: {f['error']}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
