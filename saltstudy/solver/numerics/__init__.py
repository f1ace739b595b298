"""Numerical building blocks without physics: SIMD helpers and elementary functions."""
