"""The peer side of bench/harness/peer_harness.hpp, for Python peers (Open3D).

A peer script calls serve(version, kernels) with kernels = {name: (prepare, run)}:
  prepare(task) -> state   untimed: read the inputs, build what the workload says is given
  run(state, task) -> dict timed: one pass of the workload; the last pass's dict is the output
serve reads the task file named by the last argument ({"kernel", "inputs", "parameters",
"warmup", "repeats", "threads"}), runs `warmup` untimed and `repeats` timed passes, and prints
one JSON line: {"peer", "kernel", "seconds": [...], "cpu_seconds": [...], "output"}.
The harness sets OMP_NUM_THREADS to the workload's thread count before starting the peer.
"""
import json
import resource
import sys
import time


def cpu_seconds():
    """This process's CPU time, all threads, plus that of its finished child processes (a peer
    that runs workers, like Open3D's reconstruction system, is charged for them)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def serve(version, kernels):
    with open(sys.argv[-1]) as f:
        task = json.load(f)
    name = task["kernel"]
    if name not in kernels:
        sys.exit(f"{sys.argv[0]}: no kernel '{name}' (have: {', '.join(sorted(kernels))})")
    prepare, run = kernels[name]
    state = prepare(task)
    for _ in range(task["warmup"]):
        run(state, task)
    wall, cpu, output = [], [], {}
    for _ in range(task["repeats"]):
        cpu_start = cpu_seconds()
        start = time.perf_counter()
        output = run(state, task)
        wall.append(time.perf_counter() - start)
        cpu.append(cpu_seconds() - cpu_start)
    print(json.dumps({"peer": version, "kernel": name, "seconds": wall, "cpu_seconds": cpu,
                      "output": output}))
