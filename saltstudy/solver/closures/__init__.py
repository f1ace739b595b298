"""Subgrid-scale closures: Deardorff's TKE (the paper's), dynamic Smagorinsky, near-wall and two-part options, chosen by ``closure.make_closure``."""
