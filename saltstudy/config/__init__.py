"""Validated, frozen configuration models for cases, fidelities, studies and resolved scenes.

A *case* (``cases/caseNN.toml``) fixes the physics of one run (Dupont et al. 2013, Table 2); a
*fidelity* (``workflows/fidelities/NAME.toml``) only what costs (grid, steps, durations, sampling,
parcels); a *study* (``workflows/NAME.toml``) which cases run at which fidelities. A
:class:`Scene` is one case resolved against one fidelity. SI units, angles in degrees; defaults
are the paper's (``data/dupont2013.toml``).
"""
from __future__ import annotations

from .base import PAPER_AREA_M2, Frozen, content_hash, deep_merge, validate_model
from .case import (Air, Case, Closure, Forcing, Particles, Physics, Soil, SoilMode, Splash, Surface,
                   Threshold)
from .fidelity import Fidelity, GridSpec, Outputs, Relaxation, Sampling, SpinUp, TimeStepping
from .files import ConfigError, case_path, list_case_numbers, project_root, read_toml
from .loading import (airborne_counts, equilibrium_roughness, ladder_table_path, load_case,
                      load_fidelity, load_study, parcel_weight, resolve_scene, roughness_table,
                      study_fidelity_folder, study_file, study_runs, validate_file)
from .study import RunSpec, Scene, SceneSpec, Study

__all__ = [
    "Air", "SoilMode", "Soil", "Splash", "Threshold", "Forcing", "Surface", "Closure", "Physics",
    "Particles", "Case", "GridSpec", "TimeStepping", "SpinUp", "Sampling", "Relaxation", "Outputs",
    "Fidelity", "SceneSpec", "Study", "Scene", "RunSpec", "ConfigError", "Frozen", "content_hash",
    "project_root", "read_toml", "load_case", "load_fidelity", "load_study", "resolve_scene", "case_path",
    "list_case_numbers", "deep_merge", "PAPER_AREA_M2", "study_runs", "study_file",
    "study_fidelity_folder", "validate_model", "validate_file", "airborne_counts",
    "equilibrium_roughness", "roughness_table", "parcel_weight", "ladder_table_path",
]
