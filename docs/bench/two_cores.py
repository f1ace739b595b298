"""What two threads give on this machine, for three kinds of code (numba prange, no shared data):

    NUMBA_NUM_THREADS=1 python docs/bench/two_cores.py; NUMBA_NUM_THREADS=2 python docs/bench/two_cores.py

- a memory stream: a = b + s c over 12 M float64 (GB/s);
- a latency-bound chain: 100 dependent square roots per element of 3 M (ms);
- a throughput-bound sweep: a fused multiply-add over an L1-resident block of 2048 float64, eight
  blocks shared among the threads, 200,000 sweeps each (s).
Two physical cores double all three; two hyper-threads of one core double the first two at most
and give the third ~1.2-1.5x (docs/BENCHMARKS.md, "Single precision and the flow's threads").
"""
import math
import time

import numba
import numpy as np
from numba import njit, prange


@njit(parallel=True)
def triad(a, b, c, s):
    for i in prange(a.size):
        a[i] = b[i] + s * c[i]


@njit(parallel=True)
def chain(a, b):
    for i in prange(a.size):
        x = b[i]
        for _ in range(100):
            x = math.sqrt(x * 1.0001 + 0.3)
        a[i] = x


@njit(fastmath=True)
def sweep(block, reps):
    for _ in range(reps):
        for i in range(block.size):
            block[i] = block[i] * 0.9999 + 0.0001


@njit(parallel=True, fastmath=True)
def sweeps(blocks, reps):
    for t in prange(blocks.shape[0]):
        sweep(blocks[t], reps)


def median_time(f, n):
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return sorted(ts)[n // 2]


a, b, c = np.zeros(12_000_000), np.ones(12_000_000), np.ones(12_000_000)
x, y = np.zeros(3_000_000), np.random.default_rng(1).random(3_000_000)
blocks = np.random.default_rng(2).random((8, 2048))
triad(a, b, c, 2.0), chain(x[:10], y[:10]), sweeps(blocks, 10)
t_triad = median_time(lambda: triad(a, b, c, 2.0), 15)
t_chain = median_time(lambda: chain(x, y), 5)
t_sweep = median_time(lambda: sweeps(blocks, 200_000), 5)
print(f"threads {numba.get_num_threads()}: stream {3 * a.nbytes / t_triad / 1e9:.1f} GB/s, "
      f"chain {t_chain * 1e3:.0f} ms, sweep {t_sweep:.3f} s")
