"""Instruments that measure the model and are not part of it: the speed benchmarks (``saltstudy
bench flow|particles|scene``) and the particle-free log-law probe (``saltstudy probe loglaw``).
They drive the solver from outside; an edit here changes no archive and recompiles no kernel
(the source key, ``saltstudy.SOURCE_KEY``, hashes ``solver/`` and ``physics/`` only)."""
