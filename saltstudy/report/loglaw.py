"""The log-law report: particle-free surface-layer probes (``saltstudy probe loglaw --json``) side by
side, judged against fixed acceptance bands, with one figure of phi(z) and one of the near-bed
spanwise spectrum of u.

    saltstudy probe loglaw-report DIR  # reads DIR/*.json, writes DIR/summary.{json,md}, DIR/*.png

Each probe file holds windows of 100 s (or so); a probe is summarised by the mean of its last
``n_last`` windows (the first ones still carry the spin-up). The bands are those of the closure's
acceptance: phi = kappa z/u* dU/dz within [0.85, 1.15] from 0.2 m to 1.5 m and within [0.75, 1.3]
at 0.1 m (a log law holds above the grid's first few levels; at 0.1 m the wall model's
first-level error is allowed more room); the free two-parameter fit's u* within 5 % of the drive's
target and its z0 within a factor 2 of the case's; the paper's reading (u* from the total stress at
2 m) within 5 %; the share of the resolved stress at 0.8 m carried by motions uniform in x at most
0.3 (more means the box's streamwise periodicity locks the eddies into rolls).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["BANDS", "summarise_probe", "build_loglaw_report"]

#: (z_lo, z_hi, phi_lo, phi_hi) [m, m, -, -]: the phi bands of the acceptance
BANDS = ((0.2, 1.5, 0.85, 1.15), (0.1, 0.1, 0.75, 1.3))
#: the free fit's u* and the paper's reading: allowed relative error [-]
U_STAR_TOL = 0.05
#: the free fit's z0: allowed factor either way [-]
Z0_FACTOR = 2.0
#: the x-uniform share of the resolved stress at 0.8 m: upper bound [-]
KX0_MAX = 0.3
#: the free fit the acceptance reads (0.3 m to 2 m; the probe's key)
FIT_KEY = "2.00"


def _peak_wavelength(power, length: float, premultiplied: bool) -> float:
    """length / m of the largest mode m >= 1 of P(m), or of m P(m) (energy per log band)."""
    p = np.asarray(power, dtype=np.float64)[1:]
    return length / (1 + int(np.argmax(p * np.arange(1, p.size + 1) if premultiplied else p)))


def _mean(rows: list[dict], get) -> float | np.ndarray:
    vals = [np.asarray(get(r), dtype=float) for r in rows]
    return np.mean(vals, axis=0)


def summarise_probe(data: dict, z0_target: float = 1e-5, n_last: int = 2) -> dict:
    """Mean of the last ``n_last`` windows of one probe result and its verdict per criterion.

    Returns a dict with the heights, phi, the fits, the x-uniform share, the spanwise peak, the
    per-window spread (half the range between windows: a noise level, not a confidence interval)
    and ``checks``: {name: (value, passed)}."""
    wins = data["windows"]
    if len(wins) < n_last:
        raise ValueError(f"probe has {len(wins)} windows, the summary needs {n_last}")
    rows = wins[-n_last:]
    hs = np.asarray(data["heights"], dtype=float)
    phi = _mean(rows, lambda r: r["phi"])
    phi_spread = 0.5 * np.ptp([r["phi"] for r in rows], axis=0)
    fit_u = float(_mean(rows, lambda r: r["fit"][FIT_KEY]["u_star_ratio"]))
    fit_z0 = float(np.exp(_mean(rows, lambda r: math.log(r["fit"][FIT_KEY]["z0"]))))
    paper_u = float(_mean(rows, lambda r: r["paper"]["u_star_ratio"]))
    paper_z0 = float(np.exp(_mean(rows, lambda r: math.log(r["paper"]["z0"]))))
    kx0 = float(_mean(rows, lambda r: r["kx0_share"]))
    # the phi profile on the model levels (same grid in every window)
    zp = np.asarray(rows[-1]["phi_profile"]["z"])
    phip = _mean(rows, lambda r: r["phi_profile"]["phi"])
    power = _mean(rows, lambda r: r["u_spanwise"]["power"])
    Ly = data["L"][1]
    dy = Ly / data["grid"][1]
    # the streak spacing: the peak of the premultiplied spectrum m P(m) (energy per log band)
    lam = _peak_wavelength(power, Ly, premultiplied=True)
    lam_raw = _peak_wavelength(power, Ly, premultiplied=False)
    checks: dict[str, tuple[float, bool]] = {}
    for zlo, zhi, lo, hi in BANDS:
        sel = (hs >= zlo - 1e-9) & (hs <= zhi + 1e-9)
        vals = phi[sel]
        name = (f"phi {zlo:g}-{zhi:g} m in [{lo:g}, {hi:g}]" if zhi > zlo
                else f"phi {zlo:g} m in [{lo:g}, {hi:g}]")
        worst = vals[np.argmax(np.abs(vals - 0.5 * (lo + hi)))]
        checks[name] = (float(worst), bool(np.all((vals >= lo) & (vals <= hi))))
    checks["free fit u*/target within 5 %"] = (fit_u, abs(fit_u - 1) <= U_STAR_TOL)
    checks["free fit z0 within x2 of target"] = (fit_z0, 1 / Z0_FACTOR <= fit_z0 / z0_target <= Z0_FACTOR)
    checks["paper's reading u*/target within 5 %"] = (paper_u, abs(paper_u - 1) <= U_STAR_TOL)
    checks["x-uniform share of u'w' at 0.8 m <= 0.3"] = (kx0, kx0 <= KX0_MAX)
    out = {"heights": hs.tolist(), "phi": phi.tolist(), "phi_spread": phi_spread.tolist(),
           "fit_u_star_ratio": fit_u, "fit_z0": fit_z0, "paper_u_star_ratio": paper_u,
           "paper_z0": paper_z0, "kx0_share": kx0,
           "phi_profile": {"z": zp.tolist(), "phi": np.asarray(phip).tolist()},
           "u_spanwise": {"power": np.asarray(power).tolist(), "Ly": Ly, "dy": dy,
                          "peak_wavelength": lam, "peak_over_dy": lam / dy,
                          "peak_wavelength_raw": lam_raw},
           "windows_used": [r["t"] for r in rows],
           "checks": {k: {"value": v, "pass": p} for k, (v, p) in checks.items()},
           "all_pass": all(p for _, p in checks.values())}
    if "dynamic" in rows[-1]:
        out["dynamic"] = {"z": rows[-1]["dynamic"]["z"],
                          "c_s": np.asarray(_mean(rows, lambda r: r["dynamic"]["c_s"])).tolist()}
    return out


def _label(path: Path, data: dict) -> str:
    return str(data.get("label") or path.stem)


def build_loglaw_report(directory: Path, n_last: int = 2) -> dict:
    """Summarise every probe JSON in ``directory`` (files ending ``.json`` other than summary.json),
    write summary.json, summary.md, phi.png and spanwise.png there. Returns the summary."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory = Path(directory)
    files = sorted(p for p in directory.glob("*.json") if p.name != "summary.json")
    if not files:
        raise ValueError(f"{directory}: no probe results (*.json from `saltstudy probe loglaw --json`)")
    probes = {}
    for p in files:
        data = json.loads(p.read_text())
        if "windows" not in data:
            raise ValueError(f"{p}: not a probe result (no 'windows')")
        s = summarise_probe(data, n_last=n_last)
        s["grid"] = data["grid"]
        s["L"] = data["L"]
        s["drive"] = data.get("drive")
        s["closure"] = data.get("closure")
        s["wall_s"] = data["windows"][-1].get("wall_s")
        probes[_label(p, data)] = s
    summary = {"n_last_windows": n_last, "probes": probes}
    (directory / "summary.json").write_text(json.dumps(summary, indent=1))

    lines = ["| probe | grid | dx [m] | height [m] | drive | " + " | ".join(next(iter(probes.values()))["checks"]) +
             " | spanwise peak of u at 0.1 m [m] (/dy) | wall [s] |",
             "|" + "---|" * (7 + len(next(iter(probes.values()))["checks"]))]
    for name, s in probes.items():
        cells = []
        for c in s["checks"].values():
            v = c["value"]
            txt = f"{v:.3g}" if abs(v) < 1e-3 else f"{v:.3f}"
            cells.append(f"{txt} {'pass' if c['pass'] else 'FAIL'}")
        sp = s["u_spanwise"]
        lines.append(f"| {name} | {'x'.join(map(str, s['grid']))} | {s['L'][0] / s['grid'][0]:.3f} | "
                     f"{s['L'][2]:g} | {s['drive'] or '—'} | "
                     + " | ".join(cells) + f" | {sp['peak_wavelength']:.2f} ({sp['peak_over_dy']:.1f}) | "
                     f"{s['wall_s']:.0f} |")
    lines.append("")
    hdr = "| probe | " + " | ".join(f"{h:g} m" for h in next(iter(probes.values()))["heights"]) + " |"
    lines += ["phi = kappa z/u* dU/dz (mean of the last windows; +- half their range):", "", hdr,
              "|" + "---|" * (1 + len(next(iter(probes.values()))["heights"]))]
    for name, s in probes.items():
        lines.append(f"| {name} | " + " | ".join(
            "-" if not np.isfinite(v) else f"{v:.2f}+-{d:.2f}" for v, d in zip(s["phi"], s["phi_spread"])) + " |")
    (directory / "summary.md").write_text("\n".join(lines) + "\n")

    fig, ax = plt.subplots(figsize=(6.0, 5.0))
    ax.axvspan(0.85, 1.15, ymin=0, ymax=1, color="0.9", zorder=0)
    for zlo, zhi, lo, hi in BANDS:
        ax.fill_betweenx([zlo * 0.97, zhi * 1.03], lo, hi, color="tab:green", alpha=0.15, lw=0)
    for name, s in probes.items():
        pp = s["phi_profile"]
        ax.plot(pp["phi"], pp["z"], marker=".", ms=3, label=name)
    ax.axvline(1.0, color="k", lw=0.6)
    ax.set_yscale("log")
    ax.set_ylim(0.01, max(max(s["phi_profile"]["z"]) for s in probes.values()))
    ax.set_xlim(0.3, 1.8)
    ax.set_xlabel(r"$\phi = \kappa z/u_* \; dU/dz$")
    ax.set_ylabel("z [m]")
    ax.set_title("Particle-free surface layer (green: acceptance bands)")
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(directory / "phi.png", dpi=130)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    for name, s in probes.items():
        sp = s["u_spanwise"]
        pw = np.asarray(sp["power"])
        k = np.arange(pw.size)
        lam = np.where(k > 0, sp["Ly"] / np.maximum(k, 1), np.nan)
        ax.loglog(lam[1:], (pw * k)[1:] / pw[1:].sum(), marker=".", ms=3,
                  label=f"{name}: peak {sp['peak_wavelength']:.2f} m = {sp['peak_over_dy']:.1f} dy")
    ax.set_xlabel(r"spanwise wavelength $\lambda$ [m]")
    ax.set_ylabel(r"$k\,E_{uu}(k)$ / variance")
    ax.set_title("Spanwise spectrum of u at 0.1 m")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(directory / "spanwise.png", dpi=130)
    plt.close(fig)
    return summary
