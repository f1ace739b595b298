"""Adapter to the semi-empirical z0s and G_tot laws of ``saltstudy.physics.laws`` (Figs 3 and 8).

``physics.laws`` exposes ``Z0S_LAWS`` and ``GTOT_LAWS``: dicts name -> (callable, citation). The
report does not know each callable's signature in advance, so :func:`evaluate_law` matches the
callable's parameter names to a pool of quantities (with common aliases) and calls it, vectorised if
possible, element by element otherwise. A law that cannot be called is skipped with a reason, never
replaced by a formula of our own.
"""
from __future__ import annotations

import importlib
import inspect
from typing import Any, Callable

import numpy as np

__all__ = ["load_laws", "evaluate_law"]

_ALIASES: dict[str, tuple[str, ...]] = {
    "u_star_s": ("u_star_s", "u_star", "ustar", "ustar_s", "us", "u_s", "u"),
    "u_star_t": ("u_star_t", "ustar_t", "ut", "u_t", "u_star_th", "threshold"),
    "d": ("d", "d_p", "dp", "d_mean", "mean_d", "d_m", "diameter", "mu1", "mu", "d_mean_m"),
    "rho": ("rho", "rho_air", "rho_a", "rho_f"),
    "rho_p": ("rho_p", "rho_s", "rho_grain", "rho_sand"),
    "g": ("g", "gravity"),
    "z0": ("z0", "z_0", "z0_bed"),
    "kappa": ("kappa",),
    "nu": ("nu", "nu_air"),
}


def load_laws() -> tuple[dict[str, tuple[Callable, str]], dict[str, tuple[Callable, str]], str | None]:
    """(Z0S_LAWS, GTOT_LAWS, reason) — empty dicts and a reason if physics.laws is not available."""
    try:
        mod = importlib.import_module("saltstudy.physics.laws")
    except Exception as exc:  # not yet written, or broken: the figure says so
        return {}, {}, f"saltstudy.physics.laws unavailable ({type(exc).__name__}: {exc})"
    z0s = dict(getattr(mod, "Z0S_LAWS", {}) or {})
    gtot = dict(getattr(mod, "GTOT_LAWS", {}) or {})
    return z0s, gtot, None


def _pool(values: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, names in _ALIASES.items():
        if key in values:
            for n in names:
                out.setdefault(n, values[key])
    return out


def evaluate_law(fn: Callable, u_star_s: np.ndarray, **quantities: float) -> np.ndarray:
    """Evaluate ``fn`` on ``u_star_s`` (array) with the other ``quantities`` (u_star_t, d, rho,
    rho_p, g, z0, kappa) matched by parameter name. Raises TypeError if a required parameter has no
    match."""
    u = np.asarray(u_star_s, dtype=float)
    pool = _pool({"u_star_s": u, **quantities})
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        sig = None
    kwargs: dict[str, Any] = {}
    positional_u = False
    if sig is not None:
        for name, p in sig.parameters.items():
            if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                continue
            if name in pool:
                kwargs[name] = pool[name]
            elif p.default is p.empty:
                raise TypeError(f"law parameter '{name}' has no matching quantity")
    else:
        positional_u = True

    def call(uval):
        if positional_u:
            return fn(uval)
        kw = {k: (uval if v is u else v) for k, v in kwargs.items()}
        return fn(**kw)

    try:
        out = np.asarray(call(u), dtype=float)
        if out.shape == u.shape:
            return out
    except Exception:
        pass
    return np.array([float(call(float(x))) for x in u])
