"""saltstudy bench profile: samples attributed to the compiled kernels' code."""
from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.instruments.kernel_profile import _CODE_BYTES, attribute


def test_samples_go_to_the_function_they_fall_in():
    funcs = {0x1000: ("a", "fa"), 0x40000: ("b", "fb")}
    ips = [0x1000, 0x1004, 0x1004, 0x40010, 0x500, 0x1000 + _CODE_BYTES + 5]
    per, total = attribute(ips, funcs)
    assert total == 6
    assert per[0x1000] == {0: 1, 4: 2}
    assert per[0x40000] == {0x10: 1}
    assert sum(sum(c.values()) for c in per.values()) == 4  # before the first, beyond the code


@pytest.mark.slow   # compiles every grain kernel afresh under perf (~1.5 min on 2 cores)
@pytest.mark.skipif(shutil.which("perf") is None or shutil.which("objdump") is None,
                    reason="needs perf and objdump")
def test_bench_profile_writes_a_listing_of_the_advance_with_sample_counts(tmp_path):
    res = CliRunner().invoke(app, ["bench", "profile", "--n", "20000", "--steps", "30",
                                   "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "summary.json").read_text())
    kernels = [f["kernel"] for f in s["functions"]]
    assert "advance_all" in kernels and "implicit_coefficients" in kernels
    adv = next(f for f in s["functions"] if f["kernel"] == "advance_all")
    assert 0.0 < adv["share_of_kernels"] <= 1.0
    lines = (tmp_path / adv["listing"]).read_text().splitlines()
    counts = [int(line.split()[0]) for line in lines]
    assert sum(counts) > 0 and any("xmm" in line or "zmm" in line for line in lines)
