"""The benchmarks' comparison rounds run in fresh processes (instruments/revision.py)."""
import os

import pytest

from saltstudy.instruments.revision import run_isolated


def test_a_function_runs_in_another_process_and_returns_its_json_result():
    assert run_isolated("os:getpid", {}) != os.getpid()


def test_keyword_arguments_and_the_result_go_through_json():
    assert run_isolated("json:loads", {"s": "[1, 2.5, \"a\"]"}) == [1, 2.5, "a"]


def test_a_failure_in_the_child_is_raised_with_its_error():
    with pytest.raises(RuntimeError, match="ZeroDivisionError|division"):
        run_isolated("fractions:Fraction", {"numerator": 1, "denominator": 0})


def test_the_child_gets_the_extra_environment_and_runs_after_the_prefix():
    assert run_isolated("os:getenv", {"key": "SALTSTUDY_ISOLATION_PROBE"},
                        env={"SALTSTUDY_ISOLATION_PROBE": "a"}) == "a"
    assert run_isolated("os:getenv", {"key": "SALTSTUDY_ISOLATION_PROBE"},
                        prefix=["env", "SALTSTUDY_ISOLATION_PROBE=b"]) == "b"
    assert run_isolated("os:getenv", {"key": "SALTSTUDY_ISOLATION_PROBE"}) is None
