"""Pure physical laws: threshold, drag, splash, soil size distribution, semi-empirical laws.

The laws the grain kernels call (drag, splash draws, diameter draw) are numba functions here, once,
shared by the kernels, the steady-layer probe and the tests; the rest is numpy. Import them from
their modules (``physics.drag``, ``laws``, ``soil``, ``splash``, ``threshold``).
"""
