"""Which eddies the grains follow: the spanwise co-spectrum and coherence of C_p and u(z) in one
saltation archive (``saltstudy probe coherence``; docs/USAGE.md), averaged over time and x, with
``--lag TAU`` pairing C_p(t) with u(t - TAU). The paper reads C_p and u at 0.1 m peaking at the
same wavelengths ([49]) and R_cu ~ 0.3 from the large eddies ([51]).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..analysis.streamers import N_BLOCKS, deviation_planes


def spanwise_cospectrum(a: np.ndarray, b: np.ndarray, dy: float, n_blocks: int = N_BLOCKS
                        ) -> dict[str, np.ndarray]:
    """Spanwise spectra of two (nt, nx, ny) plane series averaged over x and time: {"ky" [cycles
    m-1], "S_a", "S_b", "Co", "Co_se", "coherence2"}, one-sided densities as
    ``analysis.streamers.spanwise_spectrum`` (``sum(Co) / Ly``: the covariance). Co_se: from
    ``n_blocks`` contiguous time blocks (NaN with fewer than 4 planes)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 3:
        raise ValueError(f"planes of shape {a.shape} and {b.shape}: need two equal (nt, nx, ny)")
    nt, nx, ny = a.shape
    Ly = ny * dy
    ky = np.arange(ny // 2 + 1) / Ly
    A = np.fft.rfft(deviation_planes(a)[0], axis=2)
    B = np.fft.rfft(deviation_planes(b)[0], axis=2)
    w = np.full(ky.size, 2.0)
    w[0] = 1.0
    if ny % 2 == 0:
        w[-1] = 1.0
    norm = w * Ly / ny ** 2                          # two-sided sum -> one-sided density
    cross = (A * np.conj(B)).mean(axis=1)             # (nt, nky), averaged over x
    Paa = (np.abs(A) ** 2).mean(axis=1)
    Pbb = (np.abs(B) ** 2).mean(axis=1)
    co_t = cross.real * norm
    S_a, S_b, Co = Paa.mean(0) * norm, Pbb.mean(0) * norm, co_t.mean(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        coh = np.abs(cross.mean(0)) ** 2 / (Paa.mean(0) * Pbb.mean(0))
    se = np.full(ky.size, np.nan)
    nb = min(n_blocks, nt)
    if nt >= 4 and nb >= 2:
        bm = np.array([co_t[i].mean(0) for i in np.array_split(np.arange(nt), nb)])
        se = bm.std(axis=0, ddof=1) / math.sqrt(nb)
    return {"ky": ky, "S_a": S_a, "S_b": S_b, "Co": Co, "Co_se": se, "coherence2": coh}


#: the grain fields the probe reads: all the airborne grains, or those above the first grid cell
FIELDS = ("C_p", "C_p_above")


def probe_coherence(samples: Path, n_blocks: int = N_BLOCKS, lag_s: float = 0.0,
                    field: str = "C_p") -> dict:
    """``field`` (C_p or C_p_above) against u at every sampled height of a saltation archive: the
    premultiplied curves each over its own maximum, modes 1 to ny/2, per height."""
    if field not in FIELDS:
        raise ValueError(f"field {field!r}: one of {', '.join(FIELDS)}")
    from ..ncio import open_dataset

    ds = open_dataset(samples)
    for name in (field, "u_plane", "z_plane", "y"):
        if name not in ds:
            raise ValueError(f"{samples}: no {name!r} (not a saltation archive with these planes)")
    C = ds[field].values
    U = ds["u_plane"].values
    lag = 0
    if lag_s:
        t = ds["time_plane"].values if "time_plane" in ds else None
        if t is None or t.size < 2:
            raise ValueError(f"{samples}: a lag needs the planes' times (time_plane)")
        lag = int(round(lag_s / float(t[1] - t[0])))
        if lag < 0 or lag >= C.shape[0] - 4:
            raise ValueError(f"lag {lag_s} s is {lag} planes: needs 0 <= lag < {C.shape[0] - 4}")
        C, U = C[lag:], U[:U.shape[0] - lag]
        lag_s = lag * float(t[1] - t[0])
    y = ds["y"].values
    dy = float(y[1] - y[0])
    heights = []
    kS_c = lam = None
    for k, z in enumerate(ds["z_plane"].values):
        r = spanwise_cospectrum(C, U[..., k], dy, n_blocks)
        ky = r["ky"][1:]
        lam = 1.0 / ky
        kSc = ky * r["S_a"][1:]
        kSc_max = float(np.max(kSc)) if np.max(kSc) > 0 else 1.0
        kS_c = kSc / kSc_max
        kSu = ky * r["S_b"][1:]
        kCo = ky * r["Co"][1:]
        top = float(np.max(np.abs(kCo))) or 1.0
        heights.append({"z": float(z), "kS_u": (kSu / np.max(kSu)).tolist(),
                        "kCo": (kCo / top).tolist(), "kCo_se": (ky * r["Co_se"][1:] / top).tolist(),
                        "coherence2": r["coherence2"][1:].tolist(),
                        "peak_kS_u_m": float(lam[np.argmax(kSu)]),
                        "peak_kCo_m": float(lam[np.argmax(kCo)])})
    ds.close()
    return {"samples": str(samples), "field": field, "lag_s": float(lag_s),
            "wavelength_m": lam.tolist(), "kS_c": kS_c.tolist(),
            "peak_kS_c_m": float(lam[np.argmax(kS_c)]), "heights": heights}


def format_coherence(res: dict, n: int = 12) -> str:
    lam = res["wavelength_m"][:n]
    row = lambda name, v: f"{name:18s}" + " ".join(f"{x:5.2f}" for x in v[:n])
    out = [f"{res.get('field', 'C_p')} against u(z) {res['lag_s']:g} s earlier, {res['samples']}; "
           "premultiplied curves over their maxima",
           row("wavelength [m]", lam),
           row("k S_c", res["kS_c"]) + f"   top at {res['peak_kS_c_m']:.2f} m"]
    for h in res["heights"]:
        out += [f"z = {h['z']:.2f} m",
                row("  k S_u", h["kS_u"]) + f"   top at {h['peak_kS_u_m']:.2f} m",
                row("  k Co(C_p, u)", h["kCo"]) + f"   top at {h['peak_kCo_m']:.2f} m",
                row("    +- block s.e.", h["kCo_se"]),
                row("  coherence^2", h["coherence2"])]
    return "\n".join(out)


def register_coherence(probe_app) -> None:
    import typer

    from ..workflow.cli_commands import fail

    @probe_app.command("coherence")
    def coherence(path: Path = typer.Argument(..., help="a saltation archive (samples.nc) or "
                                              "the directory holding it"),
                  blocks: int = typer.Option(N_BLOCKS, "--blocks", help="time blocks for the "
                                             "co-spectrum's standard error"),
                  lag: float = typer.Option(0.0, "--lag", help="pair C_p(t) with u(t - LAG), s"),
                  field: str = typer.Option("C_p", "--field", help="C_p, or C_p_above: the grains "
                                            "above the first grid cell"),
                  as_json: bool = typer.Option(False, "--json", help="one JSON object")) -> None:
        """Spanwise co-spectrum and coherence of C_p and u at each sampled height of one run."""
        samples = path / "samples.nc" if path.is_dir() else path
        try:
            if not samples.is_file():
                raise ValueError(f"{samples}: no such file")
            if blocks < 2:
                raise ValueError(f"--blocks: {blocks} < 2 (the standard error needs two)")
            res = probe_coherence(samples, blocks, lag, field)
        except (OSError, ValueError) as exc:
            fail(str(exc))
        typer.echo(json.dumps(res) if as_json else format_coherence(res))
