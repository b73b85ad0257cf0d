#!/usr/bin/env python3
"""Per-call cost of the Python API (python/, docs/python.md) beside its C++ equivalents.

  PYTHONPATH=build/python /usr/bin/python3 bench/python_api_bench.py [--repeat 20]

Times Config.run() of configs/healthy.yaml (one lumped-sphere beat, a simulator made per call)
and Config.parameters (binding and conversion only); build/bench/blackbox_bench
--benchmark_filter=SphereBeat times the same beat in C++: the difference is the API's overhead.
Prints medians in ms.
"""
import os
import statistics
import sys
import time

import sigmaheart as sh

repeat = int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 20
source = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
cfg = sh.load_config(os.path.join(source, "configs", "healthy.yaml"))


def median_ms(f, n):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


cfg.run()  # warm-up
print("Config.run (one beat):   %.3f ms" % median_ms(cfg.run, repeat))
print("Config.parameters:       %.4f ms" % median_ms(lambda: cfg.parameters, 200))
